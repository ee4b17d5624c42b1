"""One control step: tasks and limits → one QP on the joint velocity (mink/pink's ``solve_ik``).

:func:`solve_step` builds, from the step's :class:`~coop_ga.control.configuration.Configuration`
(one compiled evaluation shared by everything below), the QP of :mod:`coop_ga.control.qp`

    min_q̇  ½‖A q̇ − b‖² + ½λ²‖q̇‖²            (A, b: the tasks' rows stacked; λ² = damping² + Σ μ‖W e‖²)
    s.t.   lower ≤ q̇ ≤ upper,  G q̇ ≤ h      (the limits: boxes intersected, rows stacked)
           E q̇ = f                          (``equality`` tasks: J q̇ = −k e, their feedback law held exactly)

and solves it with :func:`~coop_ga.control.qp.solve_qp` (DAQP; when the unconstrained minimiser — the
damped pseudo-inverse of Eq 48 — satisfies every bound it is returned as is, so steps that touch no
limit cost one SVD).  Priority ``levels`` (Eq 58, 60) are solved lexicographically: level k minimises its
own cost subject to the limits and to keeping the task velocities ``A_j q̇`` of every higher level j
(equalities on their row space); when no bound is active this is the closed form
``q̇ = q̇₁ + N (A₂ N)⁺ (b₂ − A₂ q̇₁)`` with ``N = I − A₁⁺ A₁`` (Eq 60 for A₂ = I), used as is.

Where the limits leave no feasible point (user or clearance rows against the acceleration bounds), the
step drops the ``relaxable`` limits (the :class:`~coop_ga.control.limits.AccelerationLimit`) and says so
in :attr:`StepSolution.relaxed`; a run reports the violation that follows.  With equality tasks whose
feedback the limits make infeasible, the feedback is dropped (``E q̇ = 0``: q̇ = 0 is then feasible)
and :attr:`StepSolution.feedback_dropped` is set.  Anything else infeasible raises
:class:`~coop_ga.errors.InfeasibleConstraintsError`.

:func:`run_ik` iterates the step: ``q ← q + Δt q̇`` (Eq 61), the configuration moved to the new q with
q̇ as its previous velocity, until a stop criterion or a step budget (:class:`IKRun`, with the measured
position, velocity and acceleration violations of the trajectory).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import InfeasibleConstraintsError, InvalidInputError
from .qp import QPSolution, solve_qp

__all__ = [
    "IKRun",
    "RunHooks",
    "StepSolution",
    "active_labels",
    "run_ik",
    "solve_step",
    "trajectory_acceleration_violation",
]

#: singular values below this fraction of the largest span no direction of a higher level's row space
ROWSPACE_RCOND = 1e-10

#: constraint rows whose singular values fall below this fraction of the largest are dependent
RANK_TOL = 1e-10


@dataclass(slots=True)
class StepSolution:
    """The joint velocity of one step and what shaped it.

    velocity: q̇ (nq,) [rad/s].  used_qp: a bound or row was active (a QP was solved).
    solution: the (last level's) :class:`~coop_ga.control.qp.QPSolution` (active bounds and rows).
    lower, upper: (nq,) the joint box of the step (None: unbounded); G, h: the stacked rows.
    row_labels: (m,) names of the rows; parts: ``(limit, Inequalities)`` per limit (for :func:`active_labels`).
    relaxed: names of the limits dropped on this step; feedback_dropped: the equality feedback was dropped.
    note: a remark (e.g. a lower level dropped after a solver failure).
    """

    velocity: np.ndarray
    used_qp: bool
    solution: QPSolution
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None
    G: np.ndarray | None = None
    h: np.ndarray | None = None
    row_labels: tuple[str, ...] = ()
    parts: tuple[Any, ...] = ()
    relaxed: tuple[str, ...] = ()
    feedback_dropped: bool = False
    note: str = ""


# ----------------------------------------------------------------------------- limits
@dataclass
class _Bounds:
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None
    G: list[np.ndarray] = field(default_factory=list)
    h: list[np.ndarray] = field(default_factory=list)
    labels: list[str] = field(default_factory=list)
    parts: list[Any] = field(default_factory=list)

    def add(self, limit: Any, ineq: Any) -> None:
        self.parts.append((limit, ineq))
        if ineq.lower is not None:
            if self.lower is None:
                self.lower = ineq.lower.copy()
            else:
                np.maximum(self.lower, ineq.lower, out=self.lower)
        if ineq.upper is not None:
            if self.upper is None:
                self.upper = ineq.upper.copy()
            else:
                np.minimum(self.upper, ineq.upper, out=self.upper)
        if ineq.G is not None and ineq.G.shape[0]:
            self.G.append(ineq.G)
            self.h.append(ineq.h)
            self.labels += ineq.labels

    def empty_box(self) -> bool:
        """Whether some joint's box is empty (beyond rounding, which is closed onto the upper bound)."""
        if self.lower is None or self.upper is None or not (self.lower > self.upper).any():
            return False
        gap = self.lower - self.upper
        if np.any(gap > 1e-12 * (1.0 + np.abs(self.upper))):
            return True
        np.minimum(self.lower, self.upper, out=self.lower)
        return False

    def rows(self, nq: int) -> tuple[np.ndarray | None, np.ndarray | None]:
        if not self.G:
            return None, None
        if len(self.G) == 1:
            return self.G[0], self.h[0]
        return np.vstack(self.G), np.concatenate(self.h)


def _stack_limits(configuration: Any, limits: Sequence[Any], dt: float, skip: bool) -> _Bounds:
    out = _Bounds()
    for lim in limits:
        if skip and getattr(lim, "relaxable", False):
            continue
        out.add(lim, lim.inequalities(configuration, dt))
    return out


def _bounds(configuration: Any, limits: Sequence[Any], dt: float) -> tuple[_Bounds, bool]:
    """The stacked limits, and whether the relaxable ones had to be dropped (an empty joint box)."""
    bd = _stack_limits(configuration, limits, dt, False)
    if not bd.empty_box():
        return bd, False
    if any(getattr(lim, "relaxable", False) for lim in limits):
        bd = _stack_limits(configuration, limits, dt, True)
        if not bd.empty_box():
            return bd, True
    assert bd.lower is not None and bd.upper is not None  # an empty box has both sides
    j = int(np.argmax(bd.lower - bd.upper))
    raise InfeasibleConstraintsError(
        f"the joint bounds of the step are empty for joint {j}: [{bd.lower[j]:.6g}, {bd.upper[j]:.6g}] rad/s; "
        "the configuration lies outside the position limits or the limits contradict each other"
    )


# ----------------------------------------------------------------------------- tasks
def _task_rows(configuration: Any, tasks: Sequence[Any]) -> tuple[np.ndarray | None, np.ndarray, float]:
    """``(A or None (identity), b, Σ μ‖W e‖²)`` of a list of tasks (stacked)."""
    if len(tasks) == 1:
        t = tasks[0]
        A, b = t.qp_rows(configuration)
        return A, b, (t.lm_term(configuration) if t.lm_damping else 0.0)
    rows = [t.qp_rows(configuration) for t in tasks]
    lm = sum(t.lm_term(configuration) for t in tasks if t.lm_damping)
    n = configuration.nv
    A = np.vstack([np.eye(n) if a is None else a for a, _ in rows])
    return A, np.concatenate([b for _, b in rows]), lm


def _equalities(configuration: Any, equality: Sequence[Any], gain: float | None) -> tuple[np.ndarray, np.ndarray]:
    """``(E, f)``: ``J q̇ = −k e`` of each equality task (k: ``gain`` or the task's own)."""
    Es = [t.jacobian(configuration) for t in equality]
    fs = [-(t.gain if gain is None else gain) * t.error(configuration) for t in equality]
    E = Es[0] if len(Es) == 1 else np.vstack(Es)
    f = fs[0] if len(fs) == 1 else np.concatenate(fs)
    _check_rank(E, tuple(lab for t in equality for lab in t.labels))
    return E, f


def _check_rank(C: np.ndarray, labels: Sequence[str]) -> None:
    s = np.linalg.svd(C, compute_uv=False)
    if C.shape[0] > C.shape[1] or not (s[0] > 0 and s[-1] > RANK_TOL * s[0]):
        raise InfeasibleConstraintsError(
            f"the {C.shape[0]} equality constraint rows ({', '.join(labels)}) are linearly dependent at this "
            f"configuration (singular values {np.array2string(s, precision=3)}); drop a redundant row (e.g. of a "
            "unit direction only two components are independent) or move away from the singularity"
        )


def equality_minimiser(A: np.ndarray, b: np.ndarray, damping: float, E: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``argmin ½‖A x − b‖² + ½λ²‖x‖²`` s.t. ``E x = f`` (E full row rank), by the nullspace of E."""
    U, s, Vt = np.linalg.svd(E, full_matrices=True)
    r = E.shape[0]
    xp = Vt[:r].T @ ((U.T @ f) / s)  # minimum-norm particular solution
    Z = Vt[r:].T  # (n, n − r) basis of the nullspace of E
    if Z.shape[1] == 0:
        return xp
    AZ = A @ Z
    H = AZ.T @ AZ + damping * damping * np.eye(Z.shape[1])
    g = AZ.T @ (b - A @ xp) - damping * damping * (Z.T @ xp)
    return xp + Z @ np.linalg.lstsq(H, g, rcond=None)[0]


def _pinv(A: np.ndarray, damping: float) -> np.ndarray:
    """``Aᵀ(A Aᵀ + λ² I)⁻¹`` by the SVD (λ = 0: Moore–Penrose, rcond 1e-10), the numbers of
    :func:`coop_ga.cooperative.damped_pinv` without its input checks (hot path)."""
    if damping == 0.0:
        return np.linalg.pinv(A, rcond=1e-10)
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    return (Vt.T * (s / (s * s + damping * damping))) @ U.T


def _feasible(x: np.ndarray, lb: np.ndarray | None, ub: np.ndarray | None, G: Any, h: Any) -> bool:
    return (
        (lb is None or bool(np.all(x >= lb)))
        and (ub is None or bool(np.all(x <= ub)))
        and (G is None or bool(np.all(G @ x <= h)))
    )


def _unconstrained(x: np.ndarray, m: int) -> QPSolution:
    n = x.shape[0]
    return QPSolution(x, False, np.zeros(n, bool), np.zeros(n, bool), np.zeros(m, bool), "unconstrained")


def _clipped(x: np.ndarray, lb: np.ndarray | None, ub: np.ndarray | None) -> QPSolution:
    n = x.shape[0]
    lo = np.full(n, -np.inf) if lb is None else lb
    hi = np.full(n, np.inf) if ub is None else ub
    xc = np.clip(x, lo, hi)
    return QPSolution(xc, bool(np.any(xc != x)), xc <= lo, xc >= hi, np.zeros(0, bool), "clip")


def _rowspace(A: np.ndarray) -> np.ndarray:
    """An orthonormal basis (r, n) of the row space of A (singular values > ROWSPACE_RCOND σ_max)."""
    _, sv, Vt = np.linalg.svd(A, full_matrices=False)
    return Vt[sv > ROWSPACE_RCOND * sv[0]] if sv.size and sv[0] > 0 else Vt[:0]


@dataclass
class _Problem:
    """The data of one step's QP(s): level 1 (A, b, λ), the lower levels, limits and equalities."""

    A: np.ndarray | None
    b: np.ndarray
    lam: float
    levels: list[tuple[np.ndarray | None, np.ndarray]]
    level_damping: float
    E: np.ndarray | None
    f: np.ndarray | None
    n: int

    def first(self) -> np.ndarray:
        return np.eye(self.n) if self.A is None else self.A

    def free(self, f: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """``(level-1 minimiser, minimiser through every level)`` without bounds (module docstring)."""
        A1 = self.first()
        P = None
        if self.A is None and self.E is None:
            x1 = self.b / (1.0 + self.lam * self.lam)  # ½‖x − b‖² + ½λ²‖x‖²
        elif self.E is None:
            P = _pinv(A1, self.lam)
            x1 = P @ self.b
        else:
            assert f is not None  # E comes with f
            x1 = equality_minimiser(A1, self.b, self.lam, self.E, f)
        x, held = x1, A1
        if self.levels and P is None:
            P = _pinv(A1, self.lam)
        for k, (A2, b2) in enumerate(self.levels):
            assert P is not None  # computed when there are levels
            if A2 is None:  # Eq 60: q̇₁ + N q̇₂ with N = I − A₁⁺A₁
                x = x + (b2 - P @ (held @ b2))
            else:
                AN = A2 - (A2 @ P) @ held
                x = x + (np.eye(self.n) - P @ held) @ (_pinv(AN, self.level_damping) @ (b2 - A2 @ x))
            if k + 1 < len(self.levels):
                held = np.vstack([held, np.eye(self.n) if A2 is None else A2])
                P = _pinv(held, 0.0)
        return x1, x


def _refine(sol: QPSolution, Vr: np.ndarray, f: np.ndarray, bd: _Bounds, G: Any, h: Any) -> QPSolution:
    """The solver keeps ``Vr x = f`` to its tolerance (DAQP: 1e-6 of the scaled step); a correction restores
    the higher levels' task velocity to rounding whenever it keeps the point feasible: ``x + Vrᵀ(f − Vr x)``
    (Vr orthonormal), or, with joints on their bounds, the least-norm correction of the other joints."""
    r = f - Vr @ sol.x
    x = sol.x + Vr.T @ r
    if _feasible(x, bd.lower, bd.upper, G, h):
        return dataclasses.replace(sol, x=x)
    free = ~(sol.active_lower | sol.active_upper)
    if free.any():
        x = sol.x.copy()
        x[free] += np.linalg.lstsq(Vr[:, free], r, rcond=None)[0]
        if _feasible(x, bd.lower, bd.upper, G, h) and np.linalg.norm(f - Vr @ x) < np.linalg.norm(r):
            return dataclasses.replace(sol, x=x)
    return sol


def _solve_levels(pb: _Problem, bd: _Bounds, f: np.ndarray | None) -> tuple[QPSolution, str]:
    """The lexicographic QPs of the levels (module docstring); returns the last solution and a note."""
    G, h = bd.rows(pb.n)
    m = 0 if G is None else G.shape[0]
    x1, x = pb.free(f)
    if _feasible(x, bd.lower, bd.upper, G, h):
        return _unconstrained(x, m), ""
    if pb.A is None and pb.E is None and G is None and not pb.levels:
        return _clipped(x, bd.lower, bd.upper), ""  # ½‖x − b‖² + ½λ²‖x‖² in a box: separable, the clip is exact
    labels = tuple(bd.labels)
    A1 = pb.first()
    sol = solve_qp(A1, pb.b, pb.lam, bd.lower, bd.upper, G, h, E=pb.E, f=f, x_free=x1, labels=labels, what="step")
    held = A1
    for k, (A2, b2) in enumerate(pb.levels):
        Vr = _rowspace(held)
        E = Vr if pb.E is None else np.vstack([Vr, pb.E])
        fk = Vr @ sol.x if f is None else np.concatenate([Vr @ sol.x, f])
        A2m = np.eye(pb.n) if A2 is None else A2
        try:
            sol = solve_qp(A2m, b2, pb.level_damping, bd.lower, bd.upper, G, h, E=E, f=fk, labels=labels, what="step")
        except InfeasibleConstraintsError:
            # not in exact arithmetic (the higher level's q̇ is feasible): a numerical failure of the solver;
            # the step keeps the higher levels' solution — feasible — and says so
            return sol, f"level {k + 2} dropped at this step (QP solver failure)"
        sol = _refine(sol, Vr, fk[: Vr.shape[0]], bd, G, h)
        held = np.vstack([held, A2m])
    return sol, ""


def _attempt(pb: _Problem, bd: _Bounds) -> tuple[QPSolution, str, bool]:
    """Solve with the equality feedback, then (if that is infeasible) without it: ``(solution, note, dropped)``."""
    try:
        sol, note = _solve_levels(pb, bd, pb.f)
        return sol, note, False
    except InfeasibleConstraintsError:
        if pb.E is None:
            raise
    sol, note = _solve_levels(pb, bd, np.zeros(pb.E.shape[0]))
    return sol, note, True


#: the dampings tried, in turn, when the QP solver fails on a problem that has a feasible point
RETRY_DAMPINGS = (1e-2, 1e-1)


def _has_point(pb: _Problem, bd: _Bounds) -> bool:
    """Whether the limits and equalities have a common point (the minimum-norm one, by a QP)."""
    G, h = bd.rows(pb.n)
    try:
        solve_qp(np.eye(pb.n), np.zeros(pb.n), 0.0, bd.lower, bd.upper, G, h, E=pb.E, f=pb.f, what="feasibility")
        return True
    except InfeasibleConstraintsError:
        return False


def _robust(pb: _Problem, bd: _Bounds) -> tuple[QPSolution, str, bool]:
    """:func:`_attempt`; when the solver fails on a problem that has a feasible point (a numerical failure:
    DAQP returning a point outside the box, measured on clearance rows near an obstacle), the step is
    solved again with the first-level damping raised to :data:`RETRY_DAMPINGS` (the note says so)."""
    try:
        return _attempt(pb, bd)
    except InfeasibleConstraintsError:
        if not _has_point(pb, bd):
            raise
    for lam in RETRY_DAMPINGS:
        if lam <= pb.lam:
            continue
        try:
            sol, note, dropped = _attempt(dataclasses.replace(pb, lam=lam), bd)
            return sol, (note + "; " if note else "") + f"damping raised to {lam:g} after a QP solver failure", dropped
        except InfeasibleConstraintsError:
            continue
    raise InfeasibleConstraintsError("the QP solver failed on a feasible step at every damping tried")


def solve_step(
    configuration: Any,
    tasks: Sequence[Any],
    limits: Sequence[Any] = (),
    dt: float = 0.01,
    *,
    damping: float = 1e-3,
    equality: Sequence[Any] = (),
    equality_gain: float | None = None,
    levels: Sequence[Sequence[Any]] = (),
    level_damping: float = 0.0,
) -> StepSolution:
    """The joint velocity q̇ (nq,) [rad/s] of one step (module docstring).

    Args:
        configuration: the step's :class:`~coop_ga.control.configuration.Configuration` (q, previous q̇).
        tasks: the first-priority :class:`~coop_ga.control.tasks.Task` s (their rows stacked, one cost).
        limits: :class:`~coop_ga.control.limits.Limit` s (e.g. ``default_limits(system.limits)``).
        dt: Δt [s] (> 0) over which position and acceleration limits become velocity bounds.
        damping: λ ≥ 0 of the first level (``½λ²‖q̇‖²``).
        equality: tasks held exactly, ``J q̇ = −k e`` (k = ``equality_gain`` or each task's gain).
        levels: lower-priority task lists, each solved without changing the task velocities of the ones above.
        level_damping: λ of the lower levels.

    Returns:
        A :class:`StepSolution`.

    Raises:
        InfeasibleConstraintsError: the limits (after dropping the relaxable ones) and the equalities (after
            dropping their feedback) have no common point, or the equality rows are dependent.
        InvalidInputError: a non-positive dt or negative damping.
    """
    if not dt > 0.0 or not damping >= 0.0 or not level_damping >= 0.0:
        raise InvalidInputError(f"dt must be > 0 and the dampings ≥ 0, got dt={dt!r}, damping={damping!r}")
    if not tasks:
        raise InvalidInputError("solve_step needs at least one task")
    for t in tasks:
        target = getattr(t, "similarity_target", None)
        if target is not None:
            configuration.prepare(target)  # its error comes with the step's one evaluation
            break
    A, b, lm = _task_rows(configuration, tasks)
    E, f = _equalities(configuration, equality, equality_gain) if equality else (None, None)
    lower_levels = [_task_rows(configuration, lv)[:2] for lv in levels]
    lam = math.sqrt(damping * damping + lm) if lm else float(damping)
    pb = _Problem(A, b, lam, lower_levels, level_damping, E, f, configuration.nv)
    bd, relaxed = _bounds(configuration, limits, dt)
    try:
        sol, note, dropped = _robust(pb, bd)
    except InfeasibleConstraintsError:
        if relaxed or not any(getattr(lim, "relaxable", False) for lim in limits):
            raise
        bd, relaxed = _stack_limits(configuration, limits, dt, True), True
        if bd.empty_box():
            raise
        sol, note, dropped = _robust(pb, bd)
    G, h = bd.rows(pb.n)
    names = tuple(lim.name for lim in limits if getattr(lim, "relaxable", False)) if relaxed else ()
    return StepSolution(
        sol.x, bool(sol.used_qp), sol, bd.lower, bd.upper, G, h, tuple(bd.labels), tuple(bd.parts), names, dropped, note
    )


def active_labels(step: StepSolution, configuration: Any) -> tuple[str, ...]:
    """Labels of the bounds and rows active in a step, e.g. ``'arm0_panda_joint4 (upper position limit -0.0698)'``:
    each active joint bound is named after the (first) limit that sets it; rows by their labels."""
    sol = step.solution
    lim = configuration.limits
    out: list[str] = []
    for i in np.flatnonzero(sol.active_lower | sol.active_upper):
        upper = bool(sol.active_upper[i])
        bound = step.upper if upper else step.lower
        assert bound is not None  # an active bound exists
        for limit, ineq in step.parts:
            side = ineq.upper if upper else ineq.lower
            if side is not None and side[i] == bound[i] and hasattr(limit, "describe"):
                out.append(limit.describe(lim, int(i), upper))
                break
    out += [lab for lab, a in zip(step.row_labels, sol.active_rows) if a]
    if step.note:
        out.append(step.note)
    return tuple(out)


# ----------------------------------------------------------------------------- the runner
def trajectory_acceleration_violation(limits: Any, traj: np.ndarray, dt: float, velocity0: Any = None) -> float:
    """Largest excess of the finite-difference acceleration over ``limits.acceleration`` [rad/s²] along
    ``traj`` (T, nq) sampled every ``dt`` [s], the run starting with the velocity ``velocity0`` (None: at rest).

    ``q̇_t = (q_{t+1} − q_t)/Δt``, ``q̈_t = (q̇_t − q̇_{t−1})/Δt`` with ``q̇_{−1} = velocity0`` (the stop after
    the last step is not part of the run).  The rounding of the differences, up to ``4 eps max|q| / Δt²``, is
    discounted (as :meth:`~coop_ga.systems.limits.JointLimits.trajectory_velocity_violation` does).
    """
    Q = np.asarray(traj, dtype=float)
    if Q.ndim != 2 or len(Q) < 2:
        return 0.0
    v0 = np.zeros((1, Q.shape[1])) if velocity0 is None else np.asarray(velocity0, float).reshape(1, -1)
    V = np.vstack([v0, np.diff(Q, axis=0) / dt])
    acc = np.abs(np.diff(V, axis=0)) / dt
    scale = np.maximum(np.abs(Q[1:]), np.abs(Q[:-1]))
    resolution = 4.0 * np.finfo(float).eps * (scale + np.abs(v0) * dt) / (dt * dt)
    return float(max(np.max(acc - limits.acceleration - resolution, initial=0.0), 0.0))


@dataclass(frozen=True, kw_only=True)
class IKRun:
    """What :func:`run_ik` returns (T = iterations + 1 configurations).

    trajectory: (T, nq) [rad or m]; velocities: (T − 1, nq) the commanded q̇ [rad/s]; errors: (T,) the
    stop criterion's value (zeros without one); iterations; converged: the criterion fell below tol, no
    step was infeasible and the trajectory respects the limits that were imposed (position always;
    acceleration when an :class:`~coop_ga.control.limits.AccelerationLimit` was among the limits).
    message; infeasible; active_steps: steps with an active bound or row; active_limits: those of the last step;
    relaxed_steps: steps on which the relaxable limits were dropped; feedback_dropped: steps whose equality
    feedback was dropped; max_position_violation [rad], max_velocity_violation [rad/s],
    max_acceleration_violation [rad/s²]: measured on the trajectory (module docstring).
    """

    trajectory: np.ndarray
    velocities: np.ndarray
    errors: np.ndarray
    iterations: int
    converged: bool
    message: str
    infeasible: bool = False
    active_steps: int = 0
    active_limits: tuple[str, ...] = ()
    relaxed_steps: int = 0
    feedback_dropped: int = 0
    max_position_violation: float = 0.0
    max_velocity_violation: float = 0.0
    max_acceleration_violation: float = 0.0


def advance(q: np.ndarray, qd: np.ndarray, dt: float, system: Any = None) -> np.ndarray:
    """``q + Δt q̇`` (Eq 61), refused when it is not finite (a step beyond the float range); with a ``system``
    whose nq ≠ nv (a free flyer), ``system.integrate(q, Δt q̇)`` (``pinocchio.integrate``)."""
    with np.errstate(over="ignore", invalid="ignore"):
        if system is not None and system.nq != system.nv:  # a non-finite q̇ gives NaN, refused below
            q_next = system.integrate(q, dt * qd) if np.all(np.isfinite(qd)) else np.full(q.shape, np.nan)
        else:
            q_next = q + dt * qd
    if not np.all(np.isfinite(q_next)):  # never a NaN
        raise InvalidInputError(
            f"the control step is not finite (dt = {dt:.3g} s, max |q̇| = {float(np.max(np.abs(qd))):.3g}); "
            "use a time step of a control loop (e.g. 0.01 s) and a command of a sensible size"
        )
    return q_next


@dataclass
class RunHooks:
    """Optional parts of :func:`run_ik`.

    error: ``configuration → float``, the stop criterion (the run stops when it is < tol); None: run all steps.
    step: ``configuration → StepSolution`` replacing :func:`solve_step` with the run's arguments.
    after: ``(configuration at q, step, q_next) → q_next``: a correction of the next q (e.g. a projection).
    record: ``(configuration at q, step) → None``, called after every step.
    clip: clip q_next into the position limits (rounding of bounds reached exactly).
    """

    error: Callable[[Any], float] | None = None
    step: Callable[[Any], StepSolution] | None = None
    after: Callable[[Any, StepSolution, np.ndarray], np.ndarray] | None = None
    record: Callable[[Any, StepSolution], None] | None = None
    clip: bool = True


def run_ik(
    configuration: Any,
    tasks: Sequence[Any],
    limits: Sequence[Any] = (),
    *,
    dt: float = 0.01,
    steps: int = 250,
    tol: float = 0.0,
    hooks: RunHooks | None = None,
    **step_options: Any,
) -> IKRun:
    """Iterate :func:`solve_step` and ``q ← q + Δt q̇`` (Eq 61) from the configuration's q and velocity.

    Args:
        configuration: the start (moved along the run: at the end it holds the last q and q̇).
        tasks: as :func:`solve_step`.
        limits: as :func:`solve_step`; ``step_options`` (damping, equality, levels, …) are passed on.
        dt: Δt [s]; steps: the step budget; tol: stop when ``hooks.error`` < tol.
        hooks: :class:`RunHooks` (stop criterion, custom step, correction, recording, clipping).

    Returns:
        An :class:`IKRun`; an infeasible step stops the run (``infeasible=True``, the last feasible q kept).
    """
    hk = hooks or RunHooks()
    lim = configuration.limits
    # with a free flyer q moves through the system's integrate/difference (else q + Δt q̇, as always)
    system = configuration.system if configuration.nq != configuration.nv else None
    v0 = configuration.velocity.copy()
    qs, vs = [configuration.q.copy()], []
    errs = [hk.error(configuration) if hk.error else 0.0]
    active = relaxed = dropped = k = 0
    last: tuple[StepSolution, Any] | None = None
    infeasible, message = False, ""
    while k < steps and not (hk.error is not None and errs[-1] < tol):
        q = configuration.q.copy()
        try:
            st = hk.step(configuration) if hk.step else solve_step(configuration, tasks, limits, dt, **step_options)
            q_next = advance(q, st.velocity, dt, system)
            if hk.clip:
                if system is None:
                    np.clip(q_next, lim.lower, lim.upper, out=q_next)
                else:
                    system.clip(q_next, out=q_next)
            if hk.after is not None:
                q_next = hk.after(configuration, st, q_next)
        except InfeasibleConstraintsError as exc:
            infeasible, message = True, f"stopped at step {k}: {exc}"
            break
        if hk.record is not None:
            hk.record(configuration, st)
        active += st.used_qp
        relaxed += bool(st.relaxed)
        dropped += st.feedback_dropped
        last = (st, q)
        vs.append(st.velocity.copy())
        configuration.update(q_next, (q_next - q) / dt if system is None else system.difference(q, q_next) / dt)
        qs.append(q_next)
        errs.append(hk.error(configuration) if hk.error else 0.0)
        k += 1
    traj = np.array(qs)
    labels = active_labels(last[0], configuration) if last is not None and last[0].used_qp else ()
    return _verdict(
        configuration, limits, traj, np.array(vs) if vs else np.zeros((0, configuration.nv)), np.array(errs), dt, tol, hk, v0, k, infeasible,
        message, active, labels, relaxed, dropped,
    )  # fmt: skip


def _verdict(
    configuration: Any,
    limits: Sequence[Any],
    traj: np.ndarray,
    vel: np.ndarray,
    errors: np.ndarray,
    dt: float,
    tol: float,
    hk: RunHooks,
    v0: np.ndarray,
    k: int,
    infeasible: bool,
    message: str,
    active: int,
    labels: tuple[str, ...],
    relaxed: int,
    dropped: int,
) -> IKRun:
    from .limits.joints import AccelerationLimit, ConfigurationLimit

    lim = configuration.limits
    if configuration.nq != configuration.nv:  # limits in q̇ coordinates (a free flyer's position is unbounded)
        traj_v = configuration.system.tangent_trajectory(traj)
    else:
        traj_v = traj
    pv = lim.position_violation(traj_v)
    vv = lim.trajectory_velocity_violation(traj_v, dt) if k else 0.0
    av = trajectory_acceleration_violation(lim, traj_v, dt, v0) if k else 0.0
    accel = any(isinstance(x, AccelerationLimit) for x in limits)
    position = hk.clip or any(isinstance(x, ConfigurationLimit) for x in limits)
    ok_limits = (not position or pv <= 1e-9) and (not accel or av <= 1e-9)
    reached = hk.error is None or errors[-1] < tol
    converged = bool(reached and ok_limits and not infeasible)
    if converged:
        message = "converged"
    elif not message:
        if not reached:
            message = f"not converged after {k} steps (‖e‖ = {errors[-1]:.3g} ≥ tol)"
        else:
            message = f"limits violated: position by {pv:.3g}, acceleration by {av:.3g} (relaxed on {relaxed} steps)"
        if labels:
            message += f"; bounds active at the last step: {', '.join(labels)}"
    return IKRun(
        trajectory=traj,
        velocities=vel,
        errors=errors,
        iterations=k,
        converged=converged,
        message=message,
        infeasible=infeasible,
        active_steps=int(active),
        active_limits=labels,
        relaxed_steps=int(relaxed),
        feedback_dropped=int(dropped),
        max_position_violation=pv,
        max_velocity_violation=vv,
        max_acceleration_violation=av,
    )
