"""Clearance as a limit: the velocity dampers of a collision model (Faverjon & Tournassoud 1987).

A collision model ``cm`` (:class:`coop_ga.collision.model.CollisionModel`, or any object with
``distances_and_jacobian(q) → d (n,) [m], J_d (n, nq) [m/rad]`` and ``labels``) gives the signed
clearances of its pairs; for every pair closer than the influence distance d_i the step gets the row

    d_k + Δt · J_{d,k} q̇  ≥  d_s + (1 − ξ)(d_k − d_s),   i.e.   −J_{d,k} q̇ ≤ ξ (d_k − d_s)/Δt     (A1)

(d_s = ``d_safe``, ξ = ``damper_gain`` ∈ (0, 1]; a pair at or below d_s gets h = 0: its clearance may
not decrease) — mink's ``CollisionAvoidanceLimit`` on q̇ with exact capsule Jacobians.  Every h ≥ 0,
so q̇ = 0 satisfies (A1).

With acceleration limits (``braking=True`` and a system that bounds joint accelerations) the damper
alone asks for more than the joints can do: it lets a pair approach at ``ξ (d − d_s)/Δt`` (4.5 m/s at
d = 10 cm) and then halves that speed at every step, so the first step on which the row binds needs the
whole approach speed gone in one step (measured: 25× the Franka's acceleration limits).  The row's bound
is then also capped by the discrete braking speed of :func:`~coop_ga.control.limits.braking_speed` over
the distance ``d − d_s`` with the deceleration ``a_n = κ Σ_j |J_{d,kj}| a_j`` [m/s²] (κ =
``braking_fraction``: the share of the largest rate of change of ḋ_k that the acceleration box allows),
so a pair slows down early enough to stop at d_s within the acceleration limits.  The distances are computed once per configuration (cached under the model's
identity, so a runner that records them reuses them).  See :mod:`coop_ga.control.avoidance`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ... import validation
from ...errors import InvalidInputError
from .base import Inequalities
from .joints import braking_speed

__all__ = ["ClearanceLimit", "check_collision_model", "clearance_constraint", "distances"]


def check_collision_model(cm: Any, nq: int | None = None) -> Any:
    """``cm`` if it has ``distances_and_jacobian`` and ``labels`` (a collision model), else
    :class:`~coop_ga.errors.InvalidInputError`; with ``nq``, its system must have nq joints."""
    if not (callable(getattr(cm, "distances_and_jacobian", None)) and hasattr(cm, "labels")):
        raise InvalidInputError(
            "a collision model is needed (coop_ga.collision.model.CollisionModel: distances_and_jacobian(q), "
            f"labels), got {type(cm).__name__}"
        )
    sys_ = getattr(cm, "system", None)
    if nq is not None and sys_ is not None and int(sys_.nq) != nq:
        raise InvalidInputError(f"the collision model is for {sys_.nq} joints, the task has {nq}")
    return cm


def model_distances(cm: Any, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(d (n,) [m], J_d (n, nv) [m/rad])`` of the collision model at q (nq,) (nv = nq without a free flyer)."""
    d, J = cm.distances_and_jacobian(q)
    d = np.asarray(d, dtype=float).reshape(-1)
    J = np.asarray(J, dtype=float)
    # nv columns (the model's); no pairs: (0, its columns), or (0, nq) when it gives none
    J = J.reshape(d.shape[0], -1) if d.size else J.reshape(0, J.shape[-1] if J.ndim == 2 else q.shape[0])
    return d, J


def distances(cm: Any, configuration: Any) -> tuple[np.ndarray, np.ndarray]:
    """:func:`model_distances` at the configuration's q, computed once per q."""
    return configuration.cached(("clearances", id(cm)), lambda c: model_distances(cm, c.q.copy()))


def check_distances(d_safe: Any, d_influence: Any) -> tuple[float, float]:
    """``(d_safe, d_influence)`` [m] with d_influence > d_safe."""
    ds = validation.scalar(d_safe, "d_safe [m]")
    di = validation.scalar(d_influence, "d_influence [m]")
    if not di > ds:
        raise InvalidInputError(f"d_influence ({di:g} m) must be larger than d_safe ({ds:g} m)")
    return ds, di


def damper_rows(
    d: np.ndarray, Jd: np.ndarray, dt: float, d_safe: float, d_influence: float, gain: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A1) for the pairs with d < d_influence: ``(G, h, indices)``."""
    idx = np.flatnonzero(d < d_influence)
    G = -Jd[idx]
    h = np.maximum(gain * (d[idx] - d_safe) / dt, 0.0)
    return G, h, idx


def _check_gain(damper_gain: Any) -> float:
    return validation.scalar(damper_gain, "damper_gain", low=0.0, high=1.0, low_open=True)


class ClearanceLimit:
    """The rows (A1) of a collision model as a :class:`~coop_ga.control.limits.Limit` (module docstring).

    Args:
        model: the collision model.  d_safe: d_s [m].  d_influence: d_i [m] (> d_safe).
        damper_gain: ξ ∈ (0, 1].
        braking: cap the rows by the braking speed when the system has acceleration limits (module docstring).
        braking_fraction: κ ∈ (0, 1] of the braking deceleration.
        dt: Δt [s] used when the limit is called as a function ``q → LinearConstraint`` (the form
            :func:`~coop_ga.control.diff_ik_reach`'s ``constraints=`` also accepts); a step passes its own Δt.
    """

    relaxable = False
    name = "clearance"

    def __init__(
        self,
        model: Any,
        dt: float = 0.01,
        d_safe: float = 0.01,
        d_influence: float = 0.10,
        damper_gain: float = 0.5,
        *,
        braking: bool = True,
        braking_fraction: float = 0.5,
    ):
        self.model = check_collision_model(model)
        self.dt = validation.positive(dt, "dt")
        self.d_safe, self.d_influence = check_distances(d_safe, d_influence)
        self.damper_gain = _check_gain(damper_gain)
        self.braking = bool(braking)
        self.braking_fraction = validation.scalar(
            braking_fraction, "braking_fraction", low=0.0, high=1.0, low_open=True
        )

    def rows(self, d: np.ndarray, Jd: np.ndarray, dt: float, acceleration: np.ndarray | None = None) -> Inequalities:
        """(A1) from the distances d (n,) and their Jacobian (n, nq); with the joint accelerations (nq,)
        [rad/s²], capped by the braking speed (module docstring)."""
        G, h, idx = damper_rows(d, Jd, dt, self.d_safe, self.d_influence, self.damper_gain)
        if acceleration is not None and idx.size:
            aG = np.abs(G) * acceleration  # (m, nq); 0 · inf (a joint that does not move the pair) counts 0
            aG[np.abs(G) == 0.0] = 0.0
            a_n = self.braking_fraction * aG.sum(axis=1)
            h = np.minimum(h, braking_speed(d[idx] - self.d_safe, a_n, dt))
        labels = tuple(self.model.labels)
        names = tuple(f"clearance of {labels[k] if k < len(labels) else k}" for k in idx)
        return Inequalities(None, None, G, h, names)

    def inequalities(self, configuration: Any, dt: float) -> Inequalities:
        d, Jd = distances(self.model, configuration)
        a = configuration.limits.acceleration
        return self.rows(d, Jd, dt, a if self.braking and np.any(np.isfinite(a)) else None)

    def __call__(self, q: Any) -> Any:
        """The rows at q for a step of ``self.dt`` as a :class:`~coop_ga.control.LinearConstraint`."""
        from ..qp import LinearConstraint

        qv = validation.array(q, "q").reshape(-1)
        d, Jd = model_distances(self.model, qv)
        G, h, _ = damper_rows(d, Jd, self.dt, self.d_safe, self.d_influence, self.damper_gain)
        return LinearConstraint(G, h, "clearance")


def clearance_constraint(
    cm: Any,
    q: Any,
    *,
    dt: float = 0.01,
    d_safe: float = 0.01,
    d_influence: float = 0.10,
    damper_gain: float = 0.5,
) -> Any:
    """The velocity-damper rows (A1) at ``q`` (nq,) as a :class:`~coop_ga.control.LinearConstraint` on q̇
    (``G (m, nq)``, ``h (m,)`` [m/s], one row per pair with d < d_influence, name ``"clearance"``)."""
    return ClearanceLimit(cm, dt, d_safe, d_influence, damper_gain)(q)
