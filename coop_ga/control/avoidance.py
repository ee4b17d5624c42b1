"""Obstacle and self-collision avoidance in the cooperative controllers.

Every method here uses the *same* distances: a collision model ``cm``
(:class:`coop_ga.collision.model.CollisionModel`, or any object with the same three members)
gives the signed clearances ``d(q)`` (n,) [m] of its pairs (link capsule – obstacle, link – link
of other chains or non-adjacent links of the same chain; negative = penetration depth), their
Jacobian ``J_d = ∂d/∂q`` (n, nq) [m/rad] and ``cm.labels`` (n,) naming the pairs.  No distance
is computed in this module (the geometry lives in :mod:`coop_ga.collision`).

Hard avoidance: velocity dampers as rows of the limit-aware QP
--------------------------------------------------------------
The differential-IK step is the QP of :mod:`coop_ga.control.diffik` (Eq 48 with the limits of
Eq 53); avoidance adds, for every pair closer than the influence distance ``d_i``
(``d_influence``), the linear inequality (velocity damper, Faverjon & Tournassoud 1987,
"A local based approach for path planning of manipulators with a high number of degrees of
freedom", ICRA; Kanoun, Lamiraux, Wieber 2011)

    d_k + Δt · J_{d,k} q̇  ≥  d_s + (1 − ξ)(d_k − d_s),   i.e.   −J_{d,k} q̇ ≤ ξ (d_k − d_s)/Δt     (A1)

with d_s = ``d_safe`` [m] and the damper gain ξ = ``damper_gain`` ∈ (0, 1] (ξ = 1 is the
plain first-order condition ``d_k + J_{d,k} q̇ Δt ≥ d_s``; smaller ξ lets the clearance approach
d_s geometrically, ``d_{t+1} − d_s ≥ (1 − ξ)(d_t − d_s)`` to first order, so it is only reached
asymptotically).  A pair already at or below d_s gets ``h = 0`` (its clearance may not
decrease).  This is the form of mink's ``CollisionAvoidanceLimit``
(kevinzakka/mink, ``mink/limits/collision_avoidance_limit.py``: rows ``−n̂ᵀ(J₂ − J₁) Δq ≤
gain · (d − d_min)/Δt`` for the pairs within ``collision_detection_distance``, ``bound_relaxation``
below d_min; gain 0.85 there), written on the joint velocity q̇ and with our exact capsule
Jacobians.  Since every h ≥ 0, q̇ = 0 always satisfies (A1) and the joint-limit box, so the QP
is never infeasible.  The rows enter :func:`coop_ga.control.qp.solve_qp` as user constraints
``G q̇ ≤ h`` next to the position/velocity box; :func:`clearance_constraint` builds them, and
:class:`~coop_ga.control.limits.ClearanceLimit` is the :class:`~coop_ga.control.limits.Limit` (and the
callable ``q → LinearConstraint`` that :func:`coop_ga.control.diff_ik_reach` accepts as ``constraints=``).  (A1) is first order: the
true clearance after the step differs from its linearisation by O(Δt² |q̇|² · curvature); the
tests measure it.

Soft avoidance: repulsive velocities in the nullspace of the cooperative task
------------------------------------------------------------------------------
A secondary task (Eq 58, 60; :mod:`coop_ga.control.nullspace`): for the pairs closer than
d_i = ``d_influence`` the desired clearance rate follows the gain profile

    ḋ*_k = v_r · s_k²,      s_k = clamp((d_i − d_k)/(d_i − d_s), 0, 1)                          (A2)

(v_r = ``repulsive_speed`` [m/s]; zero with zero slope at d_i — the profile is C¹ — and
saturated at v_r from d_s inwards, like the bounded FIRAS potential of Khatib 1986 without its
1/d singularity).  The rates are realised *in the nullspace* of J^G, accounting for what the
primary motion already does to the distances (the task-priority solution of Nakamura, Hanafusa,
Yoshikawa 1987 / Maciejewski & Klein 1985, with the exact projector N = I − J^G⁺ J^G of Eq 58):

    q̇₁ = J^G⁺_λ B_S,     q̇₂ = N (J_A N)ᵀ ((J_A N)(J_A N)ᵀ + λ_r² I)⁻¹ (ḋ*_A − J_A q̇₁)              (A3)

(A: the pairs with d < d_i, J_A their rows of J_d, λ_r = ``repulsive_damping`` [m/rad]), and
``q̇ = q̇₁ + q̇₂`` is the step of the two-level QP of :mod:`coop_ga.control.nullspace` (Eq 58, 60)
with the joint limits.  Since ``J^G q̇₂ = 0`` exactly, the cooperative task velocity ``J^G q̇`` is
that of plain differential IK — the repulsion moves the elbows and wrists and slides the end
points along the primitive, but never disturbs the primitive (the result's
``task_velocity_deviation`` measures it: ~1e-12 on the demonstration) — and far from every
obstacle (all d ≥ d_i) q̇₂ = 0 and the step *is* the differential-IK step.
:func:`repulsive_velocity` gives the plain (A2) velocity ``J_Aᵀ(J_A J_Aᵀ + λ_r² I)⁻¹ ḋ*_A``
(no task) for other uses.  Soft avoidance alone cannot guarantee clearance (where the nullspace has no direction
that increases d, it does nothing); ``mode="both"`` (the default) adds the hard rows (A1) to both
levels of the QP: the repulsion keeps the arms away from the obstacles while the task allows it,
the dampers guarantee the clearance when it does not (then the task velocity is sacrificed — the
QP minimises its error subject to (A1)).

iLQR
----
:class:`ClearanceCost` is the running clearance cost of :func:`coop_ga.control.ilqr_reach`
(``ILQROptions(clearance=ClearanceCost(cm, ...))``, default None = off): at the knots
k = 1 … n, ``w Σ_i ½ max(0, d_a − d_i(q_k))²`` (a squared hinge: C¹, zero beyond the activation
distance d_a), with its exact gradient from J_d and its Gauss–Newton Hessian
``w J_Aᵀ J_A`` (module :mod:`coop_ga.control.ilqr`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.manipulability import damped_pinv
from ..diagnostics import collect_warnings
from ..errors import InfeasibleConstraintsError, InvalidInputError
from ..geometry.groups import SimilarityLike
from .base import check_problem, resolve_options
from .configuration import Configuration
from .diffik import DiffIKResult, run_result, similarity_error_norm, step_limits
from .limits.clearance import (
    ClearanceLimit,
    check_collision_model,
    check_distances,
    clearance_constraint,
    distances,
    model_distances,
)
from .qp import DEFAULT_LIMIT_GAIN, QPSolution, project_into_limits
from .solve import RunHooks, StepSolution, _stack_limits, run_ik, solve_step
from .tasks import JointVelocityTask, SimilarityTask
from .tasks.similarity import BodyVelocityTask

__all__ = [
    "AVOIDANCE_MODES",
    "AvoidanceOptions",
    "AvoidanceResult",
    "ClearanceCost",
    "ClearanceLimit",
    "avoidance_reach",
    "avoidance_velocity",
    "clearance_constraint",
    "repulsive_velocity",
]

#: ``'none'`` (plain differential IK), ``'soft'`` (nullspace repulsion), ``'hard'`` (QP rows), ``'both'``
AVOIDANCE_MODES = ("none", "soft", "hard", "both")


def _rates(d: np.ndarray, d_safe: float, d_influence: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """``(indices of the pairs with d < d_influence, their desired clearance rates (A2) [m/s])``."""
    idx = np.flatnonzero(d < d_influence)
    s = np.clip((d_influence - d[idx]) / (d_influence - d_safe), 0.0, 1.0)
    return idx, speed * s * s


def _repulsion(
    d: np.ndarray,
    Jd: np.ndarray,
    d_safe: float,
    d_influence: float,
    speed: float,
    damping: float,
    J: np.ndarray | None = None,
    x1: np.ndarray | None = None,
) -> np.ndarray:
    """q̇₂ of (A2); with the task Jacobian J and the primary velocity x1, (A3)."""
    nq = Jd.shape[1]
    idx, rate = _rates(d, d_safe, d_influence, speed)
    if idx.size == 0 or speed == 0.0:
        return np.zeros(nq)
    JA = Jd[idx]
    if J is None or x1 is None:
        M = JA @ JA.T + damping * damping * np.eye(idx.size)
        return JA.T @ np.linalg.solve(M, rate)
    N = np.eye(nq) - np.linalg.pinv(J, rcond=1e-10) @ J  # exact projector onto the nullspace of J^G (Eq 58)
    JAN = JA @ N
    M = JAN @ JAN.T + damping * damping * np.eye(idx.size)
    return N @ (JAN.T @ np.linalg.solve(M, rate - JA @ x1))  # (A3): in the nullspace, J^G q̇₂ = 0


def repulsive_velocity(
    cm: Any,
    q: Any,
    *,
    d_safe: float = 0.01,
    d_influence: float = 0.10,
    repulsive_speed: float = 0.3,
    repulsive_damping: float = 0.05,
) -> np.ndarray:
    """The secondary joint velocity q̇₂ (nq,) [rad/s] of (A2): the damped least-norm velocity giving the
    active pairs (d < d_influence) the clearance rates ``v_r s²`` [m/s] (module docstring)."""
    cm = check_collision_model(cm)
    ds, di = check_distances(d_safe, d_influence)
    v = validation.nonnegative(repulsive_speed, "repulsive_speed [m/s]")
    lam = validation.nonnegative(repulsive_damping, "repulsive_damping")
    qv = validation.array(q, "q").reshape(-1)
    d, Jd = model_distances(cm, qv)
    return _repulsion(d, Jd, ds, di, v, lam)


@dataclass(frozen=True)
class AvoidanceOptions:
    """Settings of :func:`avoidance_reach` (the differential-IK fields are those of
    :class:`~coop_ga.control.DiffIKOptions`, with the same defaults).

    mode: ``'both'`` (default: hard rows (A1) and nullspace repulsion (A2)), ``'hard'``, ``'soft'``
        or ``'none'`` (plain differential IK; the clearances are still recorded).
    d_safe: clearance d_s [m] kept by (A1) and at which (A2) saturates.
    d_influence: d_i [m] (> d_safe): pairs farther away give no row and no repulsion.
    damper_gain: ξ ∈ (0, 1] of (A1).
    repulsive_speed: v_r [m/s] of (A2) (0 disables the repulsion).
    repulsive_damping: λ_r [m/rad] of the least-norm repulsive velocity.
    gain [1/s], dt [s], steps, damping, tol, limit_mode (``'enforce'`` or ``'none'``), limit_gain,
        acceleration_limit: as :class:`~coop_ga.control.DiffIKOptions`.
    """

    mode: str = "both"
    d_safe: float = 0.01
    d_influence: float = 0.10
    damper_gain: float = 0.5
    repulsive_speed: float = 0.3
    repulsive_damping: float = 0.05
    gain: float = 10.0
    dt: float = 0.01
    steps: int = 250
    damping: float = 1e-3
    tol: float = 1e-4
    limit_mode: str = "enforce"
    limit_gain: float = DEFAULT_LIMIT_GAIN
    acceleration_limit: bool = True

    def __post_init__(self) -> None:
        validation.choice(self.mode, AVOIDANCE_MODES, "mode")
        if not isinstance(self.acceleration_limit, bool):
            raise InvalidInputError(f"acceleration_limit must be True or False, got {self.acceleration_limit!r}")
        check_distances(self.d_safe, self.d_influence)
        validation.scalar(self.damper_gain, "damper_gain", low=0.0, high=1.0, low_open=True)
        validation.nonnegative(self.repulsive_speed, "repulsive_speed")
        validation.nonnegative(self.repulsive_damping, "repulsive_damping")
        validation.positive(self.gain, "gain")
        validation.positive(self.dt, "dt")
        validation.integer(self.steps, "steps", minimum=0)
        validation.nonnegative(self.damping, "damping")
        validation.nonnegative(self.tol, "tol")
        validation.choice(self.limit_mode, ("enforce", "none"), "limit_mode")
        validation.scalar(self.limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)


@dataclass(frozen=True, kw_only=True)
class AvoidanceResult(DiffIKResult):
    """Result of :func:`avoidance_reach`: the fields of :class:`~coop_ga.control.DiffIKResult` plus

    mode: the avoidance mode.
    clearance: (T,) smallest signed clearance over all pairs at each configuration [m].
    clearances: (T, n) every pair's clearance [m] (columns: ``labels``).
    labels: (n,) the collision model's pair labels.
    min_clearance: ``min(clearance)`` [m]; closest: the label of the pair that attains it.
    constraint_residual: largest violation of the linearised rows (A1) by the commanded q̇ over
        all steps, ``max(G q̇ − h)`` [m/s] (≤ 0 up to the QP tolerance; 0 without rows).
    task_velocity_deviation: (T−1,) ‖J^G q̇_t − J^G q̇_t^DIK‖ per step, with q̇^DIK the plain
        differential-IK velocity at the same q (same limits, no avoidance) [rad/s | 1/s | body length/s]:
        how much avoidance disturbed the cooperative task.
    active_rows: (T−1,) number of rows (A1) at each step.
    fallback_steps: steps at which the QP solver failed numerically and the step was re-solved with
        more damping and without the repulsion, or scaled into the feasible set (see ``_step``); the
        rows (A1) and the limits hold on those steps too.
    """

    mode: str = "both"
    clearance: np.ndarray = field(default_factory=lambda: np.zeros(0))
    clearances: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    labels: tuple[str, ...] = ()
    min_clearance: float = float("inf")
    closest: str = ""
    constraint_residual: float = 0.0
    task_velocity_deviation: np.ndarray = field(default_factory=lambda: np.zeros(0))
    active_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    fallback_steps: int = 0


#: damping of the retry when the QP solver fails numerically on a step (q̇ = 0 is always feasible)
FALLBACK_DAMPING = 1e-2


def _feasible_fraction(
    x: np.ndarray, lb: np.ndarray | None, ub: np.ndarray | None, G: np.ndarray | None, h: np.ndarray | None
) -> float:
    """The largest α ∈ [0, 1] with α x in the box and ``G (α x) ≤ h`` (0 is feasible: lb ≤ 0 ≤ ub, h ≥ 0)."""
    alpha = 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        if ub is not None:
            over = x > ub
            alpha = min(alpha, float(np.min(np.maximum(ub[over], 0.0) / x[over], initial=1.0)))
        if lb is not None:
            under = x < lb
            alpha = min(alpha, float(np.min(np.minimum(lb[under], 0.0) / x[under], initial=1.0)))
        if G is not None and G.shape[0]:
            assert h is not None  # rows come with h
            gx = G @ x
            bad = gx > h
            alpha = min(alpha, float(np.min(np.maximum(h[bad], 0.0) / gx[bad], initial=1.0)))
    return max(0.0, alpha * (1.0 - 1e-12))


class _AvoidanceStep:
    """One avoidance step from a configuration (module docstring), with the solver-failure fallbacks."""

    def __init__(self, task: Any, cm: Any, o: AvoidanceOptions, primary: Any):
        self.cm, self.o, self.primary = cm, o, primary
        self.base = step_limits(task, o.limit_mode, o.limit_gain, o.acceleration_limit)
        self.hard = o.mode in ("hard", "both")
        braking = o.acceleration_limit and o.limit_mode == "enforce"  # the dampers' braking bound goes with them
        self.clearance = ClearanceLimit(cm, o.dt, o.d_safe, o.d_influence, o.damper_gain, braking=braking)
        self.limits = self.base + [self.clearance] if self.hard else self.base
        self.fallbacks = 0

    def repulsion(self, cfg: Any) -> np.ndarray:
        """(A3): the repulsive velocity in the nullspace of J^G, given the primary velocity."""
        o = self.o
        J = cfg.kinematics().jacobian
        b = self.primary.qp_rows(cfg)[1]
        d, Jd = distances(self.cm, cfg)
        x1 = damped_pinv(J, o.damping) @ b
        return _repulsion(d, Jd, o.d_safe, o.d_influence, o.repulsive_speed, o.repulsive_damping, J, x1)

    def __call__(self, cfg: Any) -> StepSolution:
        o = self.o
        try:
            qd2 = self.repulsion(cfg) if o.mode in ("soft", "both") else None
            if qd2 is not None and np.any(qd2):  # far from every obstacle the step is the differential-IK step
                levels = [[JointVelocityTask(qd2, name="repulsion")]]
                return solve_step(cfg, [self.primary], self.limits, o.dt, damping=o.damping, levels=levels)
            return solve_step(cfg, [self.primary], self.limits, o.dt, damping=o.damping)
        except InfeasibleConstraintsError:
            # a numerical failure of the solver (every h ≥ 0 and the joint box contains 0: q̇ = 0 is feasible)
            self.fallbacks += 1
            lam = max(o.damping, FALLBACK_DAMPING)
            try:
                return solve_step(cfg, [self.primary], self.limits, o.dt, damping=lam)
            except InfeasibleConstraintsError:
                return self.scaled(cfg, lam)

    def scaled(self, cfg: Any, lam: float) -> StepSolution:
        """The unconstrained step scaled into the feasible set of the non-relaxable limits."""
        A, b = self.primary.qp_rows(cfg)
        x = damped_pinv(A, lam) @ b
        bd = _stack_limits(cfg, self.limits, self.o.dt, True)
        G, h = bd.rows(cfg.nq)
        a = _feasible_fraction(x, bd.lower, bd.upper, G, h)
        n, m = x.shape[0], 0 if G is None else G.shape[0]
        sol = QPSolution(a * x, True, np.zeros(n, bool), np.zeros(n, bool), np.zeros(m, bool), "scaled")
        relaxed = tuple(lim.name for lim in self.limits if getattr(lim, "relaxable", False))
        note = f"QP failed: unconstrained step scaled by {a:.3g}"
        return StepSolution(a * x, True, sol, bd.lower, bd.upper, G, h, tuple(bd.labels), (), relaxed, False, note)


def avoidance_velocity(
    task: Any,
    q: Any,
    command_bivector: Any,
    options: AvoidanceOptions | None = None,
    *,
    collision_model: Any,
    velocity: Any = None,
    **overrides: Any,
) -> np.ndarray:
    """The joint velocity q̇ (nq,) [rad/s] of one avoidance step for the body velocity command B_S (7,)
    (module docstring: (A1) rows in the QP for ``'hard'``/``'both'``, (A2) in the nullspace for
    ``'soft'``/``'both'``); ``q`` inside the limits (projected otherwise, with a warning); ``velocity``: the
    previous step's q̇ for the acceleration limit (None: at rest); ``collision_model``: the model of the pairs."""
    o = resolve_options(AvoidanceOptions, options, overrides, "avoidance_velocity")
    cm = check_collision_model(collision_model, task.nq)
    qv = validation.configuration(q, task.nq, "q")
    b = validation.vector(command_bivector, 7, "command_bivector")
    if o.limit_mode != "none":
        qv = project_into_limits(task, qv)
    cfg = Configuration(task, qv, velocity)
    return _AvoidanceStep(task, cm, o, BodyVelocityTask(b))(cfg).velocity


class _Recorder:
    """Per-step records of an avoidance run: clearances, row residuals, task-velocity deviation."""

    def __init__(self, step: _AvoidanceStep):
        self.step = step
        self.D: list[np.ndarray] = []
        self.residual = 0.0
        self.devs: list[float] = []
        self.rows: list[int] = []

    def clearances(self, cfg: Any) -> None:
        self.D.append(distances(self.step.cm, cfg)[0].copy())

    def __call__(self, cfg: Any, st: StepSolution) -> None:
        o, G = self.step.o, st.G
        m = 0 if G is None else G.shape[0]
        if m:
            assert G is not None and st.h is not None  # m > 0
            self.residual = max(self.residual, float(np.max(G @ st.velocity - st.h)))
        self.rows.append(m)
        if o.mode == "none" or not (st.used_qp or np.any(st.velocity)):
            self.devs.append(0.0)
        else:
            ref = solve_step(cfg, [self.step.primary], self.step.base, o.dt, damping=o.damping).velocity
            J = cfg.kinematics().jacobian
            self.devs.append(float(np.linalg.norm(J @ (st.velocity - ref))))


def _closest(Dm: np.ndarray, labels: tuple[str, ...]) -> str:
    if not Dm.size:
        return ""
    t_min, i_min = np.unravel_index(int(np.argmin(Dm)), Dm.shape)
    return f"{labels[i_min] if i_min < len(labels) else i_min} at step {t_min}"


def avoidance_reach(
    task: Any,
    q_init: Any,
    target: SimilarityLike,
    options: AvoidanceOptions | None = None,
    *,
    collision_model: Any,
    **overrides: Any,
) -> AvoidanceResult:
    """Differential IK to ``target`` (Eq 44, 48, 61) with obstacle and self-collision avoidance (module docstring).

    A :class:`~coop_ga.control.tasks.SimilarityTask` with the joint limits, the
    :class:`~coop_ga.control.limits.ClearanceLimit` rows (``'hard'``/``'both'``) and a repulsion level in the
    nullspace (``'soft'``/``'both'``), iterated by :func:`~coop_ga.control.run_ik`; stops when ‖e‖ < ``tol``
    or after ``steps`` steps.

    Args:
        task: a :class:`coop_ga.CooperativeTask`.  q_init: (nq,) start [rad] (at rest; projected onto the
            limits with a warning if outside).  target: V_Sd, a :class:`~coop_ga.Similarity`.
        options: :class:`AvoidanceOptions` (keyword ``overrides`` replace its fields).
        collision_model: the collision model of the task's system (pairs, d (n,) [m], J_d (n, nq)).

    Returns:
        An :class:`AvoidanceResult`; ``converged`` as for differential IK (‖e‖ < tol inside the limits) —
        clearance is reported, not part of ``converged``.
    """
    o = resolve_options(AvoidanceOptions, options, overrides, "avoidance_reach")
    cm = check_collision_model(collision_model, task.nq)
    q, Vd = check_problem(task, q_init, target, "q_init")
    labels = tuple(str(s) for s in cm.labels)
    sim = SimilarityTask(Vd, gain=o.gain)
    step = _AvoidanceStep(task, cm, o, sim)
    rec = _Recorder(step)
    err = similarity_error_norm(sim)

    def error(cfg: Any) -> float:
        rec.clearances(cfg)  # every configuration of the run passes here once
        return err(cfg)

    hooks = RunHooks(error=error, step=step, record=rec, clip=o.limit_mode != "none")
    with collect_warnings() as caught:
        if o.limit_mode != "none":
            q = project_into_limits(task, q, "q_init")
        run = run_ik(Configuration(task, q), [sim], step.limits, dt=o.dt, steps=o.steps, tol=o.tol, hooks=hooks)
    Dm = np.array(rec.D)
    clearance = Dm.min(axis=1) if Dm.shape[1] else np.full(len(rec.D), np.inf)
    return AvoidanceResult(
        **run_result(task, run, o.limit_mode, caught),
        mode=o.mode,
        clearance=clearance,
        clearances=Dm,
        labels=labels,
        min_clearance=float(np.min(clearance)),
        closest=_closest(Dm, labels),
        constraint_residual=rec.residual,
        task_velocity_deviation=np.array(rec.devs),
        active_rows=np.array(rec.rows, int),
        fallback_steps=step.fallbacks,
    )


# ============================================================================ iLQR
@dataclass(frozen=True)
class ClearanceCost:
    """Running clearance cost of :func:`coop_ga.control.ilqr_reach` (``ILQROptions(clearance=...)``).

    ``c(q) = weight · Σ_i ½ max(0, d_a − d_i(q))²`` at every knot k = 1 … n (d_a = ``activation``
    [m], ``weight`` [1/m²]); exact gradient ``−weight · Σ_i max(0, d_a − d_i) ∇d_i`` from the model's
    Jacobian, Gauss–Newton Hessian ``weight · J_Aᵀ J_A`` (A: the pairs with d_i < d_a).
    """

    model: Any
    weight: float = 1e4
    activation: float = 0.05

    def __post_init__(self) -> None:
        check_collision_model(self.model)
        validation.positive(self.weight, "clearance weight")
        validation.scalar(self.activation, "clearance activation [m]")

    def evaluate(self, q: np.ndarray, hessian: bool = True) -> tuple[float, np.ndarray, np.ndarray | None, float]:
        """``(c, ∇c (nq,), GN Hessian (nq, nq) or None, min clearance [m])`` at one configuration."""
        d, Jd = model_distances(self.model, np.asarray(q, float))
        viol = np.maximum(0.0, self.activation - d)
        c = 0.5 * self.weight * float(viol @ viol)
        g = -self.weight * (Jd.T @ viol)
        H = None
        if hessian:
            A = viol > 0
            JA = Jd[A]
            H = self.weight * (JA.T @ JA)
        return c, g, H, float(d.min(initial=np.inf))

    def trajectory_value(self, Q: np.ndarray, lookahead: float = 0.0) -> float:
        """``Σ_k c(q_k)`` over the configurations Q (K, nq): with a model that has a broad phase
        (:meth:`~coop_ga.collision.model.CollisionModel.close_pairs`), one batched kinematics call and the exact
        distances of the pairs whose bounding spheres come within the activation distance only.  ``lookahead``
        [m]: compute the pairs within ``activation + lookahead`` (the model keeps its last pair list, so a
        :meth:`trajectory_rows` call on the same Q with that lookahead reuses it instead of recomputing it)."""
        close = getattr(self.model, "close_pairs", None)
        if not callable(close):
            return float(sum(self.value(q) for q in Q))
        _, _, d = close(np.asarray(Q, float), self.activation + lookahead)
        viol = self.activation - d[d < self.activation]  # the active rows only: the same sum as without lookahead
        return 0.5 * self.weight * float(viol @ viol)

    def trajectory_min(self, Q: np.ndarray, cutoff: float = np.inf) -> float:
        """The smallest clearance [m] over the configurations Q (K, nq) and every pair (``inf`` without pairs): a
        batched evaluation where the model has one (:meth:`~coop_ga.collision.model.CollisionModel.close_pairs`
        with no cutoff), else :meth:`evaluate` at every configuration.  A finite ``cutoff`` [m]: the smallest
        clearance below it, or ``inf`` if none is (the pairs below the cutoff only: e.g. 0 asks whether any pair
        penetrates)."""
        Q = np.asarray(Q, float)
        close = getattr(self.model, "close_pairs", None)
        if not callable(close):
            d_min = float(min((self.evaluate(q, hessian=False)[3] for q in Q), default=np.inf))
            return d_min if d_min < cutoff else float(np.inf)
        if cutoff < np.inf:
            return float(np.min(close(Q, cutoff)[2], initial=np.inf))
        # growing cutoffs: the broad phase returns every pair below the cutoff, so the smallest distance it returns
        # is the minimum over all pairs (exact), at the cost of the near pairs only
        for cutoff in (self.activation, 4.0 * self.activation, np.inf):
            d = close(Q, cutoff)[2]
            if d.size:
                return float(np.min(d))
        return float(np.inf)

    def trajectory_pairs(self, Q: np.ndarray, lookahead: float = 0.0) -> np.ndarray | None:
        """The collision model's pair (m,) of each row of :meth:`trajectory_rows` along Q (K, nq) with the same
        ``lookahead`` [m] (the model's last pair list: no distance computed twice), or None where the model has no
        broad phase (:meth:`~coop_ga.collision.model.CollisionModel.close_pairs`)."""
        close = getattr(self.model, "close_pairs", None)
        if not callable(close):
            return None
        return np.asarray(close(np.asarray(Q, float), self.activation + lookahead)[1], int)

    def trajectory_rows(self, Q: np.ndarray, lookahead: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The rows of the hinge within ``lookahead`` [m] of activation along Q (K, nq) (d_i < d_a + lookahead):
        ``(k (m,) the configuration of each row, v (m,) = d_a − d_i [m] (> 0: active), J (m, nq) = ∂d_i/∂q)``;
        the cost is ``½ weight Σ max(0, v)²``, its gradient at q_k ``−weight Σ_{rows at k} max(0, v) J_rᵀ`` and
        its Gauss–Newton Hessian ``weight Σ_{v > 0} J_rᵀ J_r``.  Jacobians only of these rows
        (:meth:`~coop_ga.collision.model.CollisionModel.close_pairs_and_jacobian`) where the model can; else
        :meth:`evaluate`'s model at every configuration."""
        Q = np.asarray(Q, float)
        cut = self.activation + validation.nonnegative(lookahead, "lookahead [m]")
        if not callable(getattr(self.model, "close_pairs_and_jacobian", None)):
            ks, vs, Js = [], [], []
            for k, q in enumerate(Q):
                d, Jd = model_distances(self.model, q)
                a = np.flatnonzero(d < cut)
                ks.append(np.full(a.size, k))
                vs.append(self.activation - d[a])
                Js.append(Jd[a])
            return np.concatenate(ks).astype(int), np.concatenate(vs), np.concatenate(Js).reshape(-1, Q.shape[1])
        kk, _, d, J = self.model.close_pairs_and_jacobian(Q, cut)
        return kk, self.activation - d, J

    def value(self, q: np.ndarray) -> float:
        """c(q) at one configuration."""
        qv = np.asarray(q, float)
        dist = getattr(self.model, "distances", None)
        d = np.asarray(dist(qv), float).reshape(-1) if callable(dist) else model_distances(self.model, qv)[0]
        viol = np.maximum(0.0, self.activation - d)
        return 0.5 * self.weight * float(viol @ viol)
