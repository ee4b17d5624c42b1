"""Time parameterisation of a planned path within the joint velocity and acceleration limits (TOPP-RA).

:func:`time_parameterise` hands the waypoints to TOPP-RA (``toppra``, the ``plan`` extra): a cubic spline
through them, parameterised by their cumulative joint-space chord length, and the time-optimal speed profile
along it under ``|q̇_i| ≤ v_i`` and ``|q̈_i| ≤ a_i`` (the system's :class:`~coop_ga.systems.JointLimits`,
scaled by ``velocity_scale`` / ``acceleration_scale``).  Why TOPP-RA and not ruckig: the planned path is a
fixed geometric curve on the constraint manifold, and TOPP-RA keeps it (only the speed along it is chosen);
ruckig plans point-to-point motions between waypoints that would leave the curve.

The spline passes through the waypoints (spaced ``delta`` apart on the manifold) but not exactly on the
manifold between them: :class:`Timed` reports the sampled trajectory with its measured velocity and
acceleration excesses (zero when the limits hold) and the caller measures the constraint along it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..errors import InfeasibleConstraintsError, InvalidInputError

__all__ = ["Timed", "time_parameterise"]


@dataclass(frozen=True)
class Timed:
    """A time-parameterised path: ``t`` (T,) [s], ``q``, ``qd``, ``qdd`` (T, nq), its ``duration`` [s], and the
    measured excesses over the limits along the samples, ``velocity_excess`` [rad/s] and
    ``acceleration_excess`` [rad/s²] (max over joints and samples of |value| − limit, clipped at 0)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    duration: float
    velocity_excess: float
    acceleration_excess: float


def time_parameterise(
    path: Any,
    limits: Any,
    *,
    velocity_scale: float = 1.0,
    acceleration_scale: float = 1.0,
    dt: float = 0.01,
    gridpoints: int | None = None,
) -> Timed:
    """Time-optimal timing of ``path`` (N ≥ 2, nq) [rad] within ``limits`` (module docstring).

    Args:
        path: the waypoints, e.g. :attr:`~coop_ga.plan.ompl.PlanResult.path`.
        limits: the system's :class:`~coop_ga.systems.JointLimits` (``velocity``, ``acceleration``; an
            infinite acceleration limit is refused: TOPP-RA needs a bound).
        velocity_scale, acceleration_scale: fractions (0, 1] of the limits used.
        dt: sampling step of the returned trajectory [s].
        gridpoints: TOPP-RA's discretisation (default: 20 per waypoint, at least 1000: with 100 points the
            constant-acceleration segments overshot the acceleration limits by up to 4 rad/s² on a 25-waypoint
            path, with 1000 by 0.04).

    Raises:
        InvalidInputError: fewer than two distinct waypoints, or unbounded acceleration.
        InfeasibleConstraintsError: TOPP-RA found no parameterisation.
    """
    import toppra as ta  # type: ignore[import-untyped, import-not-found, unused-ignore]
    import toppra.algorithm as algo  # type: ignore[import-untyped, import-not-found, unused-ignore]
    import toppra.constraint as constraint  # type: ignore[import-untyped, import-not-found, unused-ignore]

    Q = validation.array(path, "path")
    if Q.ndim != 2 or Q.shape[0] < 2:
        raise InvalidInputError(f"path must be (N ≥ 2, nq), got {Q.shape}")
    s = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(Q, axis=0), axis=1))))
    keep = np.concatenate(([True], np.diff(s) > 1e-12))
    Q, s = Q[keep], s[keep]
    if len(Q) < 2:
        raise InvalidInputError("path has no two distinct waypoints: nothing to time")
    v = validation.positive(velocity_scale, "velocity_scale") * np.asarray(limits.velocity, float)
    a = validation.positive(acceleration_scale, "acceleration_scale") * np.asarray(limits.acceleration, float)
    if not np.all(np.isfinite(a)):
        raise InvalidInputError("the acceleration limits are unbounded; give the system finite ones (with_limits)")
    ta.setup_logging("WARNING")
    spline = ta.SplineInterpolator(s, Q)
    n_grid = gridpoints or max(1000, 20 * len(Q))
    inst = algo.TOPPRA(
        [constraint.JointVelocityConstraint(np.column_stack((-v, v))),
         constraint.JointAccelerationConstraint(np.column_stack((-a, a)))],
        spline,
        gridpoints=np.linspace(0.0, s[-1], n_grid),
        parametrizer="ParametrizeConstAccel",
    )  # fmt: skip
    traj = inst.compute_trajectory()
    if traj is None:
        raise InfeasibleConstraintsError("TOPP-RA found no time parameterisation of the path within the limits")
    T = float(traj.duration)
    t = np.append(np.arange(0.0, T, validation.positive(dt, "dt [s]")), T)
    q, qd, qdd = traj(t), traj(t, 1), traj(t, 2)
    return Timed(
        t,
        q,
        qd,
        qdd,
        T,
        float(np.max(np.abs(qd) - v, initial=0.0).clip(min=0.0)),
        float(np.max(np.abs(qdd) - a, initial=0.0).clip(min=0.0)),
    )
