"""Secondary tasks in the geometric nullspace of a cooperative primitive (§3.10, §4.3, Eq 58, 60).

Primary task: keep the cooperative similarity at ``V_hold`` (e.g. V_Sc(q_0): "stay on the
circle").  Secondary task: any joint velocity ``q̇_2`` (e.g. one arm reaching a point),
executed only through the nullspace projector of the geometric similarity Jacobian::

    N(q)  = I − J^G⁺ J^G                                         (Eq 58)
    q̇     = J^G⁺ (k_p · log(Ṽ_Sc(q) V_hold)) + N(q) q̇_2           (Eq 48 + Eq 60)
    q_{t+1} = q_t + Δt q̇                                          (Eq 61)

``N`` uses the exact (undamped, SVD rank-revealing) pseudo-inverse, so ``J^G N q̇_2 = 0``
and the secondary motion leaves V_Sc unchanged to first order; the primary feedback term
(gain ``k_p`` [1/s]) removes the second-order drift of the discrete steps.  With
``project=False`` the secondary velocity is applied unprojected and without the primary
term — the paper's Fig. 16 counter-example, where the similarity distance grows.

Secondary task provided here (Eq 60): end point ``i`` of the task reaches a Euclidean
target ``p*`` [m] by ``q̇_{i,d} = J_{p,i}⁺ k_s (p* − p_i(q))`` with the 3×nq world-frame
point Jacobian of that chain only (its other columns are zero), i.e. ``[q̇_{0,d}; 0; 0]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.manipulability import damped_pinv
from ..diagnostics import collect_warnings
from ..errors import InvalidInputError
from ..geometry.primitives import center, normal
from .base import SolverResult, bounds, check_q, resolve_options

__all__ = [
    "NullspaceOptions",
    "NullspaceResult",
    "nullspace_point_reach",
    "nullspace_step",
    "point_on_circle",
    "point_reaching_velocity",
]


def _index(task: Any, index: Any) -> int:
    n = len(task.end_frames)
    i = validation.integer(index, "index")
    if not 0 <= i < n:
        raise InvalidInputError(f"index must be an end point of the task, 0 ≤ index < {n} ({', '.join(task.end_frames)}); "
                                f"got {index!r}")
    return i


def point_reaching_velocity(task: Any, q: Any, index: int, target_point: Any, *, gain: float = 1.0,
                            damping: float = 1e-3, max_speed: float | None = 0.2) -> np.ndarray:
    """Secondary joint velocity ``[0 … q̇_{i,d} … 0]`` (nq,) moving end point ``index`` to ``target_point``.

    ``q̇ = J_p⁺ v`` with ``v = gain · (p* − p_i(q))`` [m/s] (capped at ``max_speed`` m/s),
    ``J_p`` the 3×nq world point Jacobian of end point ``index`` of ``task`` (only its own
    chain's columns are non-zero), damped pseudo-inverse with ``damping`` λ.
    """
    q = check_q(task, q)
    index = _index(task, index)
    p_star = validation.vector(target_point, 3, "target_point [m]")
    gain = validation.nonnegative(gain, "gain")
    damping = validation.nonnegative(damping, "damping")
    if max_speed is not None:
        max_speed = validation.positive(max_speed, "max_speed", allow_inf=True)
    p = task.tree.end_points_array(q)[index]
    Jp = task.tree.euclidean_point_jacobians(q)[index]
    v = gain * (p_star - p)
    if max_speed is not None:
        s = float(np.linalg.norm(v))
        if s > max_speed:
            v *= max_speed / s
    return damped_pinv(Jp, damping) @ v


def nullspace_step(task: Any, q: Any, V_hold: Any, qd_secondary: Any, *, dt: float = 0.01,
                   primary_gain: float = 10.0, damping: float = 0.0, project: bool = True,
                   limits: str = "none") -> np.ndarray:
    """One step ``q + Δt (J⁺ k_p log(Ṽ_Sc V_hold) + N q̇_2)`` (Eq 58, 60, 61); returns q_next (nq,).

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.   q: (nq,) [rad].
    V_hold: the similarity versor to keep (primary task).
    qd_secondary: (nq,) secondary joint velocity q̇_2 [rad/s].
    dt: step [s].  primary_gain: k_p [1/s] of the primary error feedback (0 disables it).
    damping: λ of the pseudo-inverse in J⁺ and N (0 = exact projector, ``J N = 0``).
    project: False applies q̇_2 directly, without projection and without primary term.
    limits: ``'none'`` or ``'clamp'`` (clip to joint limits; may break ``J N = 0``).
    """
    validation.choice(limits, ("none", "clamp"), "limits")
    dt = validation.positive(dt, "dt")
    primary_gain = validation.nonnegative(primary_gain, "primary_gain")
    damping = validation.nonnegative(damping, "damping")
    q = check_q(task, q)
    qd2 = check_q(task, qd_secondary, "qd_secondary")
    hold = validation.target(V_hold, "V_hold")
    if not project:
        q_next = q + dt * qd2
    else:
        e = task.error(q, hold)
        J = task.evaluate_views(q)[2]
        Jp = damped_pinv(J, damping)
        qd = Jp @ (primary_gain * e) + (qd2 - Jp @ (J @ qd2))
        q_next = q + dt * qd
    if limits == "clamp":
        lo, hi = bounds(task)
        np.clip(q_next, lo, hi, out=q_next)
    return q_next


def point_on_circle(task: Any, q: Any, index: int, angle: float) -> np.ndarray:
    """End point ``index`` (of a circle task) rotated by ``angle`` [rad] along the cooperative
    circle: about its axis ``normal(X_c)`` through ``center(X_c)``, right-handed about the
    normal.  Returns (3,) [m], world frame."""
    X = task.primitive(q)
    c = np.asarray(center(X), float).reshape(3)
    n = np.asarray(normal(X), float).reshape(3)
    n = n / np.linalg.norm(n)
    index = _index(task, index)
    angle = validation.scalar(angle, "angle")
    p = task.points(q)[index] - c
    p_rot = p * np.cos(angle) + np.cross(n, p) * np.sin(angle) + n * (n @ p) * (1 - np.cos(angle))
    return c + p_rot


@dataclass(frozen=True)
class NullspaceOptions:
    """Settings of :func:`nullspace_point_reach`.

    duration: simulated time [s]; dt: step [s].
    secondary_gain: k_s [1/s] of the point-reaching task; max_speed: its speed cap [m/s] (None: no cap).
    primary_gain: k_p [1/s] of the primary error feedback (0 disables it).
    damping: λ of the pseudo-inverse in J⁺ and N (0 = exact projector, ``J N = 0``).
    project: False applies q̇_2 unprojected and without the primary term (Fig. 16).
    tol: the result is ``converged`` when the final point error < tol [m].
    """

    duration: float = 4.0
    dt: float = 0.01
    secondary_gain: float = 2.0
    primary_gain: float = 10.0
    max_speed: float | None = 0.2
    damping: float = 0.0
    project: bool = True
    tol: float = 1e-3

    def __post_init__(self) -> None:
        validation.nonnegative(self.duration, "duration")
        validation.positive(self.dt, "dt")
        validation.nonnegative(self.secondary_gain, "secondary_gain")
        validation.nonnegative(self.primary_gain, "primary_gain")
        if self.max_speed is not None:
            validation.positive(self.max_speed, "max_speed", allow_inf=True)
        validation.nonnegative(self.damping, "damping")
        if not isinstance(self.project, bool):
            raise InvalidInputError(f"project must be True or False, got {self.project!r}")
        validation.nonnegative(self.tol, "tol")


@dataclass(frozen=True, kw_only=True)
class NullspaceResult(SolverResult):
    """Result of :func:`nullspace_point_reach` (T = steps + 1; ``error`` = final point error [m],
    ``converged`` iff it is < ``tol``, ``iterations`` = steps, ``q`` = final configuration):

    t (T,) [s]; trajectory (T, nq); points (T, 3) the controlled end point [m];
    point_error (T,) ‖p_i − p*‖ [m]; similarity_distance (T,) ‖log(Ṽ_Sc(q_0) V_Sc(q_t))‖;
    target_point (3,); projected: whether Eq 60 was used.
    """

    t: np.ndarray
    trajectory: np.ndarray
    points: np.ndarray
    point_error: np.ndarray
    similarity_distance: np.ndarray
    target_point: np.ndarray
    projected: bool


def nullspace_point_reach(task: Any, q0: Any, index: int, target_point: Any, options: NullspaceOptions | None = None,
                          *, V_hold: Any = None, **overrides: Any) -> NullspaceResult:
    """§4.3 experiment: end point ``index`` reaches ``target_point`` [m] while V_Sc is held (Eq 60).

    The primary task holds ``V_hold`` (a :class:`~coop_ga.Similarity`; default V_Sc(q0)); the
    secondary task is :func:`point_reaching_velocity`; every step is :func:`nullspace_step`.
    ``options``: :class:`NullspaceOptions` (keyword ``overrides`` replace its fields);
    ``project=False`` reproduces Fig. 16.
    """
    o = resolve_options(NullspaceOptions, options, overrides, "nullspace_point_reach")
    q = check_q(task, q0, "q0")
    index = _index(task, index)
    p_star = validation.vector(target_point, 3, "target_point [m]")
    n = int(round(o.duration / o.dt))
    hold = task.similarity(q) if V_hold is None else validation.target(V_hold, "V_hold")
    V0 = task.similarity(q)
    with collect_warnings() as caught:
        Q = [q.copy()]
        for _ in range(n):
            qd2 = point_reaching_velocity(task, q, index, p_star, gain=o.secondary_gain, max_speed=o.max_speed)
            q = nullspace_step(task, q, hold, qd2, dt=o.dt, primary_gain=o.primary_gain, damping=o.damping,
                               project=o.project)
            Q.append(q.copy())
        Qa = np.array(Q)
        P = np.array([task.points(qk)[index] for qk in Qa])
        V0i = V0.inverse()
        dist = np.array([np.linalg.norm((V0i @ task.similarity(qk)).log()) for qk in Qa])
    err = np.linalg.norm(P - p_star, axis=1)
    converged = bool(err[-1] < o.tol)
    msg = f"end point {index} is {err[-1]:.3g} m from the target after {o.duration:g} s"
    return NullspaceResult(converged=converged, error=float(err[-1]), iterations=n, message=msg, q=Qa[-1].copy(),
                           warnings=dict(caught.counts), t=np.arange(n + 1) * o.dt, trajectory=Qa, points=P,
                           point_error=err, similarity_distance=dist, target_point=p_star, projected=o.project)
