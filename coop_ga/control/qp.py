"""A small QP layer for limit-aware kinematic control (paper Eq 53: the sets 𝒳 and 𝒰).

Every limit-aware controller of :mod:`coop_ga.control` (differential IK, Gauss–Newton IK,
nullspace secondary tasks) solves, once per step, a small dense convex QP of the form

    min_x  ½‖A x − b‖² + ½λ²‖x‖²
    s.t.   lb ≤ x ≤ ub,           (joint position and velocity limits, trust bound)
           G x ≤ h,               (user constraints, :class:`LinearConstraint`)
           E x = f                (hierarchy: keep a higher-priority task, see nullspace)

with x a joint velocity q̇ [rad/s or m/s] or a joint step Δq [rad or m] (nq,), A a task
Jacobian (k × nq), λ = ``damping`` (the λ of :mod:`coop_ga.control.base`).

Design (what was taken from pink/mink)
--------------------------------------
`mink <https://github.com/kevinzakka/mink>`_ (and pink before it) split differential IK
into a *Configuration* (q and its kinematics), *Tasks* (each a residual e and Jacobian J
giving the QP cost ``‖J Δq + α e‖²_W`` plus a Levenberg–Marquardt term) and *Limits*
(each a pair ``(G, h)`` with ``G Δq ≤ h``: ``ConfigurationLimit`` gives
``γ (q_min − q) ≤ Δq ≤ γ (q_max − q)`` with a safety gain γ ∈ (0, 1] (mink's default
0.95), ``VelocityLimit`` gives ``|Δq| ≤ v_max Δt``), stacked into one QP handed to a
generic solver.  coop_ga keeps that split — the cooperative task (:class:`CooperativeTask`)
is the one Task, :func:`velocity_bounds` is ConfigurationLimit ∩ VelocityLimit written as
a box, :class:`LinearConstraint` is a user Limit — with three differences:

* joint boxes are passed to the solver as simple bounds (``lb ≤ x ≤ ub``), not as 2·nq
  rows of G, which an active-set solver handles at no cost;
* the *unconstrained* minimiser is computed first, by the SVD-based damped
  pseudo-inverse the solvers always used (:func:`damped_lstsq`); when it satisfies every
  bound and constraint it *is* the QP solution and is returned as is (``used_qp=False``).
  So with no bound active the controllers reproduce the unconstrained results bit for
  bit, and the QP is only solved on the steps where a limit matters;
* there is no generic solver dispatch: the QP solver is DAQP (a dual active-set solver
  for small dense QPs, shipped with CasADi as ``casadi.conic(..., "daqp")``), chosen
  after measuring the CasADi plugins on these problems (21 joints, 0–2 rows; per call
  through a ``casadi.FunctionBuffer``): DAQP ≈ 15 µs, qpOASES 10–200 µs (and a licence
  banner on stdout; up to 1.7× the optimal cost on recorded Gauss–Newton steps), ProxQP
  ≈ 130 µs and only 5e-6 accurate, OSQP inexact (ADMM; did not converge with 2 rows),
  HiGHS verbose and ≈ 1.6 ms, scipy's BVLS exact but ≈ 0.8 ms.  DAQP is exact (active
  set) and reports infeasibility.  It needs a positive definite Hessian, so λ is floored
  at :data:`MIN_RELATIVE_DAMPING` · ‖A‖_F inside the QP (only when ``damping`` is below it).

Cost (three_franka circle, 21 joints, 2-core machine): a differential-IK step whose
unconstrained velocity is feasible costs what the damped pseudo-inverse step costs (one
SVD, ≈ 50 µs, plus ≈ 5–20 µs for the bounds and the check); a step with active bounds
≈ 180 µs for the velocity (≈ 220 µs per step of :func:`~coop_ga.control.diff_ik_reach`,
against ≈ 85 µs for the pseudo-inverse step).

Solvers are built once per (thread, nq, number of rows of G and E) and reused through a
``casadi.FunctionBuffer`` bound to numpy arrays (building one costs milliseconds; a call
≈ 15–25 µs plus ≈ 10 µs for its status).  DAQP's tolerances are absolute (primal 1e-6),
so the QP is solved for ``y = x/σ`` with σ the size of the answer (the unconstrained
minimiser, capped by the box): near convergence a Gauss–Newton step is 1e-9, and without
the scaling the bounded steps lost their quadratic rate.  Every answer is verified
(bounds, rows, finiteness) before use: with a tiny λ (Gauss–Newton's λ² = 1e-9) the
Hessian's condition number reaches 1e12 and DAQP occasionally returns "optimal" for a
point outside the box; box-only problems are then re-solved exactly by BVLS, problems
with rows retried with a larger λ (see :func:`solve_qp`).  A QP with incompatible user
constraints raises :class:`InfeasibleConstraintsError`; nothing unchecked is returned.
The returned point is clipped into the box (a correction of at most the solver's
tolerance, ≈ 1e-10).
"""

from __future__ import annotations

import threading
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..errors import InfeasibleConstraintsError, InvalidInputError

__all__ = [
    "DEFAULT_LIMIT_GAIN",
    "MIN_RELATIVE_DAMPING",
    "InfeasibleConstraintsError",
    "LinearConstraint",
    "QPSolution",
    "damped_lstsq",
    "solve_qp",
    "stack_constraints",
    "velocity_bounds",
]

#: inside the QP, λ ≥ MIN_RELATIVE_DAMPING · ‖A‖_F (DAQP needs a positive definite Hessian);
#: changes the solution by O(λ²/σ²) in the task space (< 1e-12 relative on well-conditioned rows).
MIN_RELATIVE_DAMPING = 1e-6

#: feasibility tolerance [units of x] used to accept a solution and to flag active bounds
FEAS_TOL = 1e-9

SOLVER = "daqp"

# DAQP exit flags (daqp/include/constants.h)
_DAQP_STATUS = {
    1: "optimal",
    2: "soft optimal",
    -1: "infeasible",
    -2: "cycling",
    -3: "unbounded",
    -4: "iteration limit",
    -5: "nonconvex problem",
    -6: "initial working set overdetermined",
}


@dataclass(frozen=True)
class LinearConstraint:
    """A user constraint ``G x ≤ h`` on the QP variable of a controller.

    For :func:`~coop_ga.control.diff_ik_step` / :func:`~coop_ga.control.diff_ik_reach` and
    :func:`~coop_ga.control.nullspace_step` the variable is the joint velocity q̇ (nq,)
    [rad/s or m/s] in q order, so ``G`` is (m, nq) [units of h per rad/s] and ``h`` (m,)
    [e.g. m/s].  The frame is whatever the rows of G are expressed in: e.g. a half-space
    on the world velocity of end point i, ``nᵀ ṗ_i ≤ h`` with n (3,) a world direction,
    is ``G = nᵀ J_p`` with ``J_p = task.tree.euclidean_point_jacobians(q)[i]`` (3×nq,
    world frame, [m/rad]), ``h`` [m/s]; a bound on one joint velocity is a row of ±I.
    ``name`` labels the constraint in error messages.  ``(G, h)`` tuples are accepted
    wherever a LinearConstraint is.
    """

    G: np.ndarray
    h: np.ndarray
    name: str = ""

    #: a user constraint is never dropped by a step (only the acceleration limit may be)
    relaxable = False

    def inequalities(self, configuration: Any, dt: float) -> Any:
        """The rows as :class:`~coop_ga.control.limits.Inequalities` (the :class:`~coop_ga.control.limits.Limit`
        protocol; they do not depend on the configuration or Δt)."""
        from .limits.base import Inequalities

        if self.G.shape[1] != configuration.nv:
            raise InvalidInputError(
                f"constraint {self.name or 'unnamed'}: G must have {configuration.nv} columns (one per joint velocity), "
                f"got shape {self.G.shape}"
            )
        name = self.name or "constraint"
        return Inequalities(None, None, self.G, self.h, tuple(f"{name}[{r}]" for r in range(self.G.shape[0])))

    def __post_init__(self) -> None:
        G = validation.array(self.G, "constraint matrix G")
        if G.ndim == 1:
            G = G.reshape(1, -1)
        if G.ndim != 2:
            raise InvalidInputError(f"constraint matrix G must be (m, n), got shape {G.shape}")
        h = validation.array(self.h, "constraint bound h")
        if h.ndim == 0:
            h = h.reshape(1)
        if h.shape != (G.shape[0],):
            raise InvalidInputError(
                f"constraint bound h must have {G.shape[0]} entries (one per row of G), got shape {h.shape}"
            )
        if not isinstance(self.name, str):
            raise InvalidInputError(f"constraint name must be a string, got {self.name!r}")
        G.setflags(write=False)
        h.setflags(write=False)
        object.__setattr__(self, "G", G)
        object.__setattr__(self, "h", h)


def stack_constraints(constraints: Any, n: int) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """``(G (m, n), h (m,), row labels (m,))`` from None, a :class:`LinearConstraint`, a
    ``(G, h)`` pair or a sequence of them (validated; m = 0 for none)."""
    if constraints is None:
        return np.zeros((0, n)), np.zeros(0), ()
    if isinstance(constraints, LinearConstraint):
        items: list[Any] = [constraints]
    elif (
        isinstance(constraints, tuple)
        and len(constraints) == 2
        and not isinstance(constraints[0], (LinearConstraint, tuple))
    ):
        items = [constraints]  # a single (G, h) pair
    elif isinstance(constraints, Iterable) and not isinstance(constraints, (str, bytes, np.ndarray)):
        items = list(constraints)
    else:
        raise InvalidInputError(
            "constraints must be a LinearConstraint, a (G, h) pair or a sequence of them, "
            f"got {type(constraints).__name__}"
        )
    Gs, hs, labels = [], [], []
    for k, c in enumerate(items):
        if not isinstance(c, LinearConstraint):
            if not (isinstance(c, Sequence) and len(c) == 2):
                raise InvalidInputError(f"constraint {k} must be a LinearConstraint or a (G, h) pair, got {c!r}"[:200])
            c = LinearConstraint(c[0], c[1])
        if c.G.shape[1] != n:
            raise InvalidInputError(
                f"constraint {k} ({c.name or 'unnamed'}): G must have {n} columns (one per joint), "
                f"got shape {c.G.shape}"
            )
        Gs.append(c.G)
        hs.append(c.h)
        labels += [f"{c.name or f'constraint {k}'}[{r}]" for r in range(c.G.shape[0])]
    if not Gs:
        return np.zeros((0, n)), np.zeros(0), ()
    return np.vstack(Gs), np.concatenate(hs), tuple(labels)


def velocity_bounds(
    q: np.ndarray, lower: np.ndarray, upper: np.ndarray, velocity: np.ndarray | None, dt: float, gain: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Joint-velocity box ``(lb, ub)`` (nq,) [rad/s] combining position and velocity limits.

    ``max(−v, γ (lower − q)/Δt) ≤ q̇ ≤ min(v, γ (upper − q)/Δt)`` — mink's
    ``ConfigurationLimit`` (safety gain γ = ``gain`` ∈ (0, 1]: a joint covers at most the
    fraction γ of its remaining range per step) intersected with ``VelocityLimit``
    (|q̇| ≤ v, ``velocity=None``: no velocity limit).  q must lie inside [lower, upper]
    (then 0 is in the box, so the box is never empty).
    """
    lb = gain * (lower - q) / dt
    ub = gain * (upper - q) / dt
    if velocity is not None:
        np.maximum(lb, -velocity, out=lb)
        np.minimum(ub, velocity, out=ub)
    # q on a bound: γ(bound − q) may be ±1e-17 of the wrong sign; 0 must stay feasible
    np.minimum(lb, 0.0, out=lb)
    np.maximum(ub, 0.0, out=ub)
    return lb, ub


def damped_lstsq(A: np.ndarray, b: np.ndarray, damping: float) -> np.ndarray:
    """``argmin ‖A x − b‖² + λ²‖x‖² = Aᵀ(A Aᵀ + λ² I)⁻¹ b`` via the SVD (λ = 0: minimum-norm, rcond 1e-10).

    The same numbers as :func:`coop_ga.cooperative.damped_pinv` ``(A, λ) @ b``.
    """
    if damping == 0.0:
        return np.linalg.pinv(A, rcond=1e-10) @ b
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    return Vt.T @ ((s / (s * s + damping * damping)) * (U.T @ b))


@dataclass(frozen=True)
class QPSolution:
    """The solution of one controller QP (:func:`solve_qp`).

    x: (n,) the minimiser (joint velocity q̇ [rad/s] or step Δq [rad], as the caller set up).
    used_qp: False when the unconstrained minimiser satisfied every bound and constraint
        (it is then the solution, and no QP was solved).
    active_lower, active_upper: (n,) bool, x within :data:`FEAS_TOL` of lb / ub (only
        where the QP was solved; all False otherwise).
    active_rows: (m,) bool, rows of G x ≤ h that are active (within the tolerance).
    status: ``'unconstrained'`` or the solver's status (``'optimal'``).
    """

    x: np.ndarray
    used_qp: bool
    active_lower: np.ndarray
    active_upper: np.ndarray
    active_rows: np.ndarray
    status: str

    @property
    def n_active(self) -> int:
        """Number of active bounds and constraint rows."""
        return int(self.active_lower.sum() + self.active_upper.sum() + self.active_rows.sum())


class _Conic:
    """One DAQP instance for dense (n × n) Hessians and (m × n) constraint matrices, bound to numpy buffers."""

    __slots__ = ("_arrays", "_buf", "a", "eval", "g", "h", "lba", "lbx", "m", "n", "uba", "ubx", "x")

    def __init__(self, n: int, m: int):
        import casadi as ca

        f = ca.conic(
            f"coop_ga_qp_{n}_{m}",
            SOLVER,
            {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(m, n)},
            {"error_on_fail": False, "print_time": False},
        )
        ins = [np.zeros(f.size_in(i), order="F") for i in range(f.n_in())]
        outs = [np.zeros(f.size_out(i), order="F") for i in range(f.n_out())]
        buf, ev = f.buffer()
        for i, a in enumerate(ins):
            # a.T.data is memoryview(a.T); the stub splits SWIG's (buffer, size) pair into two parameters
            buf.set_arg(i, a.T.data)  # type: ignore[call-arg]
        for i, a in enumerate(outs):
            # a.T.data is memoryview(a.T); the stub splits SWIG's (buffer, size) pair into two parameters
            buf.set_res(i, a.T.data)  # type: ignore[call-arg]
        names_in = f.name_in()
        # ev and buf hold raw pointers into *every* input and output array (also x0, lam_x, cost, …,
        # which are never read here): keep them all alive as long as the solver
        self._buf = buf
        self._arrays = (ins, outs)
        self.eval = ev
        self.n, self.m = n, m
        self.h = ins[names_in.index("h")]
        self.a = ins[names_in.index("a")]
        self.g = ins[names_in.index("g")].reshape(-1)
        self.lba = ins[names_in.index("lba")].reshape(-1)
        self.uba = ins[names_in.index("uba")].reshape(-1)
        self.lbx = ins[names_in.index("lbx")].reshape(-1)
        self.ubx = ins[names_in.index("ubx")].reshape(-1)
        self.x = outs[f.name_out().index("x")].reshape(-1)

    def stats(self) -> dict[str, Any]:
        return self._buf.stats()


_local = threading.local()


def _conic(n: int, m: int) -> _Conic:
    cache = getattr(_local, "solvers", None)
    if cache is None:
        cache = _local.solvers = {}
    s = cache.get((n, m))
    if s is None:
        s = cache[(n, m)] = _Conic(n, m)
    return s


def _no_active(n: int, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return np.zeros(n, bool), np.zeros(n, bool), np.zeros(m, bool)


def _bvls(A: np.ndarray, b: np.ndarray, lam: float, lb: np.ndarray | None, ub: np.ndarray | None) -> np.ndarray:
    """Box-constrained damped least squares by scipy's BVLS on the stacked matrix [A; λI] (exact, ≈ 0.8 ms)."""
    from scipy.optimize import lsq_linear

    n = A.shape[1]
    lo = np.full(n, -np.inf) if lb is None else lb
    hi = np.full(n, np.inf) if ub is None else ub
    fixed = lo >= hi  # lsq_linear needs lb < ub: variables with a zero-width box are eliminated
    x = np.where(fixed, lo, 0.0)
    free = np.flatnonzero(~fixed)
    if free.size:
        Af = A[:, free]
        x[free] = lsq_linear(
            np.vstack([Af, lam * np.eye(free.size)]),
            np.concatenate([b - A[:, fixed] @ x[fixed], np.zeros(free.size)]),
            bounds=(lo[free], hi[free]),
            method="bvls",
            tol=1e-14,
        ).x
    return x


def solve_qp(
    A: np.ndarray,
    b: np.ndarray,
    damping: float,
    lb: np.ndarray | None = None,
    ub: np.ndarray | None = None,
    G: np.ndarray | None = None,
    h: np.ndarray | None = None,
    *,
    E: np.ndarray | None = None,
    f: np.ndarray | None = None,
    x_free: np.ndarray | None = None,
    labels: Sequence[str] = (),
    what: str = "QP",
) -> QPSolution:
    """Solve ``min ½‖A x − b‖² + ½λ²‖x‖²`` s.t. ``lb ≤ x ≤ ub``, ``G x ≤ h``, ``E x = f`` (module docstring).

    The step of every limit-aware controller: differential IK (A = J^G, b = B_S, x = q̇: Eq 48
    with Eq 53's bounds), Gauss–Newton (A = J_e, b = −e, x = Δq: Eq 45–46 in a box) and the
    two levels of the nullspace step (Eq 58, 60: A = J^G, then A = I with E = the row space of J^G).

    Args:
        A: (k, n) task matrix; b: (k,) target (A = I, b = x₂ gives ``min ‖x − x₂‖²``).
        damping: λ ≥ 0 (floored at :data:`MIN_RELATIVE_DAMPING` · ‖A‖_F inside the QP).
        lb: (n,) lower bounds (±inf allowed; None: unbounded).
        ub: (n,) upper bounds (±inf allowed; None: unbounded).
        G: (m, n) inequalities ``G x ≤ h``.
        h: (m,) their right-hand side.
        E: (p, n) equalities ``E x = f``; their rows must be linearly independent.
        f: (p,) their right-hand side.
        x_free: the unconstrained minimiser if the caller has it (default: :func:`damped_lstsq`,
            valid only without E); when it is feasible it is returned without solving a QP.
        labels: names of the rows of G (for messages); what: the caller, for messages.

    Robustness: DAQP's answer is verified (bounds, rows, finiteness).  With a tiny λ the
    Hessian ``AᵀA + λ²I`` has a condition number up to 1e12 (e.g. Gauss–Newton's λ² = 1e-9 on
    a rank-6 Jacobian) and DAQP then occasionally reports "optimal" for a point outside the
    box (on the Allegro and three-finger hands, with λ = 3e-5).  Such box-only problems are
    re-solved by scipy's BVLS on the stacked matrix ``[A; λI]`` (exact, well conditioned,
    ≈ 0.8 ms; ``status`` ends in ``'(bvls)'``); problems with rows are retried once with
    λ ≥ 1e-4 ‖A‖_F (``'(regularised)'``).

    Returns a :class:`QPSolution`; raises :class:`InfeasibleConstraintsError` when the
    solver reports infeasible constraints or no attempt returns a point satisfying them.
    """
    n = A.shape[1]
    m = 0 if G is None else G.shape[0]
    p = 0 if E is None else E.shape[0]
    _check_data(A=A, b=b, lb=lb, ub=ub, G=G, h=h, E=E, f=f)
    if x_free is None and p == 0:
        x_free = damped_lstsq(A, b, damping)
    if x_free is not None and (
        (lb is None or np.all(x_free >= lb))
        and (ub is None or np.all(x_free <= ub))
        and (m == 0 or np.all(G @ x_free <= h))
    ):
        return QPSolution(x_free, False, *_no_active(n, m), "unconstrained")
    smax = float(np.linalg.norm(A)) if A.size else 1.0  # ‖A‖_F ≥ σ_max: a cheap scale (no SVD)
    lam0 = max(float(damping), MIN_RELATIVE_DAMPING * max(smax, 1e-300))
    attempts = [(lam0, "")] + ([(max(lam0, 1e-4 * smax), " (regularised)")] if m + p else [])
    sigma = _scale(b, lb, ub, G, h, f, x_free)
    sc = _Scaled(b / sigma, _div(lb, sigma), _div(ub, sigma), _div(h, sigma), _div(f, sigma))
    found = _daqp(A, sc, G, E, attempts, labels, what)
    if found is None:
        y, status = _bvls(A, sc.b, float(damping), sc.lb, sc.ub), "optimal (bvls)"
    else:
        y, status = found
    return _finish(y, sigma, sc, lb, ub, G, status)


def _check_data(**arrays: np.ndarray | None) -> None:
    """±inf bounds mean "no bound"; anything else must be finite and leave room for the scaling of the step."""
    for name, arr in arrays.items():
        if arr is not None and (
            np.any(np.isnan(arr)) or (name not in ("lb", "ub", "h") and not np.all(np.abs(arr) < 1e150))
        ):
            raise InvalidInputError(
                f"the QP data {name} is not finite or beyond 1e150 in magnitude; check the "
                "command, dt and the constraints passed to the controller"
            )


def _div(v: np.ndarray | None, sigma: float) -> np.ndarray | None:
    return None if v is None else v / sigma


def _scale(
    b: np.ndarray,
    lb: np.ndarray | None,
    ub: np.ndarray | None,
    G: np.ndarray | None,
    h: np.ndarray | None,
    f: np.ndarray | None,
    x_free: np.ndarray | None,
) -> float:
    """σ, the size of the answer: the solver's tolerances are absolute (DAQP: primal 1e-6), so the QP is solved
    for y = x/σ (the unconstrained step's size, capped by the box): near convergence a Gauss–Newton step is 1e-9."""
    sigma = float(np.max(np.abs(x_free), initial=0.0)) if x_free is not None else float(np.max(np.abs(b), initial=0.0))
    if G is not None and G.shape[0]:
        assert h is not None  # the rows G x ≤ h were given
        sigma = max(sigma, float(np.max(-h / np.maximum(np.linalg.norm(G, axis=1), 1e-300), initial=0.0)))
    if f is not None and f.shape[0]:
        sigma = max(sigma, float(np.max(np.abs(f), initial=0.0)))
    box = [float(np.max(np.abs(v[np.isfinite(v)]), initial=0.0)) for v in (lb, ub) if v is not None]
    if box and max(box) > 0.0:
        sigma = min(sigma, max(box))  # the answer lies in the box even when the free step is huge
    if not (np.isfinite(sigma) and sigma > 1e-300):
        sigma = 1.0
    return sigma


@dataclass(frozen=True)
class _Scaled:
    """The QP data divided by σ."""

    b: np.ndarray
    lb: np.ndarray | None
    ub: np.ndarray | None
    h: np.ndarray | None
    f: np.ndarray | None


def _load(s: _Conic, A: np.ndarray, sc: _Scaled, G: np.ndarray | None, E: np.ndarray | None) -> None:
    p = 0 if E is None else E.shape[0]
    s.g[:] = -(sc.b @ A)
    s.lbx[:] = -np.inf if sc.lb is None else sc.lb
    s.ubx[:] = np.inf if sc.ub is None else sc.ub
    if p:
        s.a[:p] = E
        s.lba[:p] = sc.f
        s.uba[:p] = sc.f
    if G is not None and G.shape[0]:
        s.a[p:] = G
        s.lba[p:] = -np.inf
        s.uba[p:] = sc.h


def _daqp(
    A: np.ndarray,
    sc: _Scaled,
    G: np.ndarray | None,
    E: np.ndarray | None,
    attempts: list[tuple[float, str]],
    labels: Sequence[str],
    what: str,
) -> tuple[np.ndarray, str] | None:
    """``(y, status)`` of the first attempt whose answer DAQP calls optimal and that verifies; None when none
    does and the problem is box-only (BVLS then); :class:`InfeasibleConstraintsError` otherwise."""
    n = A.shape[1]
    m = 0 if G is None else G.shape[0]
    p = 0 if E is None else E.shape[0]
    s = _conic(n, m + p)
    _load(s, A, sc, G, E)
    HtH = A.T @ A
    diag = HtH.diagonal().copy()
    report = ""
    for lam, tag in attempts:
        HtH.flat[:: n + 1] = diag + lam * lam
        s.h[...] = HtH
        s.eval()
        code = s.stats().get("return_status")
        status = _DAQP_STATUS.get(code, str(code)) if isinstance(code, int) else str(code)
        yt = s.x.copy()
        viol_box, viol_g, viol_e = _violations(yt, sc.lb, sc.ub, G, sc.h, E, sc.f)
        tol = 1e-7 * (1.0 + float(np.max(np.abs(yt), initial=0.0)))
        if code in (1, 2) and np.all(np.isfinite(yt)) and max(viol_box, viol_g, viol_e) <= tol:
            return yt, status + tag
        if code == -1 and m + p:
            worst = ""
            if m and labels:
                assert G is not None and sc.h is not None  # m > 0: the rows G x ≤ h were given
                worst = f"; most violated: {labels[int(np.argmax(G @ yt - sc.h))]}"
            raise InfeasibleConstraintsError(
                f"{what}: the joint limits and the {m} user constraint row(s) G q̇ ≤ h have no common point "
                f"(QP solver {SOLVER}: infeasible{worst}). Relax h (h ≥ 0 always keeps q̇ = 0 feasible) or remove "
                "conflicting rows."
            )
        report = (
            f"{SOLVER}: {status}; relative violation of the bounds {viol_box:.3g}, of G x ≤ h {viol_g:.3g}, "
            f"of E x = f {viol_e:.3g}"
        )
    if m + p:
        raise InfeasibleConstraintsError(
            f"{what}: the QP solver returned no point satisfying the joint limits and the {m} user constraint "
            f"row(s) ({report}): they are (numerically) incompatible. Relax h (h ≥ 0 always keeps q̇ = 0 "
            "feasible) or remove conflicting rows."
        )
    return None


def _finish(
    y: np.ndarray,
    sigma: float,
    sc: _Scaled,
    lb: np.ndarray | None,
    ub: np.ndarray | None,
    G: np.ndarray | None,
    status: str,
) -> QPSolution:
    """The answer y clipped into the scaled box, its active bounds and rows, and x = σ y."""
    n = y.shape[0]
    lbs, ubs, hs = sc.lb, sc.ub, sc.h
    if lbs is not None or ubs is not None:
        np.clip(y, -np.inf if lbs is None else lbs, np.inf if ubs is None else ubs, out=y)
    al = np.zeros(n, bool) if lbs is None else (y <= lbs + FEAS_TOL * (1.0 + np.abs(lbs)))
    au = np.zeros(n, bool) if ubs is None else (y >= ubs - FEAS_TOL * (1.0 + np.abs(ubs)))
    if G is not None and G.shape[0]:
        assert hs is not None  # the rows G x ≤ h were given
        ar = G @ y >= hs - FEAS_TOL * (1.0 + np.abs(hs))
    else:
        ar = np.zeros(0, bool)
    x = sigma * y
    if lb is not None or ub is not None:  # rounding of σ·(lb/σ)
        np.clip(x, -np.inf if lb is None else lb, np.inf if ub is None else ub, out=x)
    if not np.all(np.isfinite(x)):
        raise InvalidInputError(
            "the QP step is not finite: its data spans beyond the float range (e.g. a time step "
            "of 1e300 s); use the scales of a control loop"
        )
    return QPSolution(x, True, al, au, ar, status)


def _violations(
    x: np.ndarray,
    lb: np.ndarray | None,
    ub: np.ndarray | None,
    G: np.ndarray | None,
    h: np.ndarray | None,
    E: np.ndarray | None,
    f: np.ndarray | None,
) -> tuple[float, float, float]:
    """Largest violation of the box, of G x ≤ h (relative to 1 + max|h|) and of E x = f."""
    vb = max(
        float(np.max(lb - x, initial=0.0)) if lb is not None else 0.0,
        float(np.max(x - ub, initial=0.0)) if ub is not None else 0.0,
    )
    if G is not None and G.size:
        assert h is not None  # h comes with G
        vg = float(np.max(G @ x - h, initial=0.0)) / (1.0 + float(np.abs(h).max(initial=0.0)))
    else:
        vg = 0.0
    ve = float(np.max(np.abs(E @ x - f), initial=0.0)) if E is not None and E.size else 0.0
    return vb, vg, ve


# ----------------------------------------------------------------------------- joint-limit helpers
#: default safety gain γ of the position limits in a velocity QP (mink's ConfigurationLimit default)
DEFAULT_LIMIT_GAIN = 0.95


def limit_arrays(task: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(lower, upper, velocity)`` (nq,) of ``task.system.limits`` [rad or m, rad/s or m/s]."""
    lim = task.system.limits
    return lim.lower, lim.upper, lim.velocity


def project_into_limits(task: Any, q: np.ndarray, what: str = "q") -> np.ndarray:
    """q clipped into the position limits; a :class:`~coop_ga.errors.JointLimitWarning` names the
    joints that were outside (a start outside the limits is reported, never silently clipped)."""
    from ..diagnostics import warn
    from ..errors import JointLimitWarning

    lim = task.system.limits
    x = q if task.nq == getattr(task, "nv", task.nq) else task.system.limit_coordinates(q)
    if lim.position_violation(x) > 0.0:
        warn(
            f"{what} lies outside the joint limits of '{task.system.name}' by up to {lim.position_violation(x):.3g} "
            f"({lim.describe(x)}); it was projected onto the limits before solving (pass limit_mode='none' to "
            "solve without limits)",
            JointLimitWarning,
            key=str(task.system.name),
        )
        return lim.clip(q) if x is q else task.system.clip(q)
    return q


def describe_active(
    task: Any, q: np.ndarray, lower_idx: Iterable[int], upper_idx: Iterable[int], velocity_idx: Iterable[int] = ()
) -> tuple[str, ...]:
    """Labels ``'joint (upper position limit 2.8973)'`` of the given active bounds, in q order."""
    lim = task.system.limits
    names = lim.joint_names
    out: dict[int, str] = {}
    for i in lower_idx:
        out[int(i)] = f"{names[i]} (lower position limit {lim.lower[i]:.4f})"
    for i in upper_idx:
        out[int(i)] = f"{names[i]} (upper position limit {lim.upper[i]:.4f})"
    for i in velocity_idx:
        out.setdefault(int(i), f"{names[i]} (velocity limit {lim.velocity[i]:.4g})")
    return tuple(out[i] for i in sorted(out))


def classify_velocity_box(
    sol: QPSolution,
    q: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    velocity: np.ndarray | None,
    dt: float,
    gain: float,
) -> tuple[list[int], list[int], list[int]]:
    """Split the active bounds of a joint-velocity QP (box of :func:`velocity_bounds`) into
    (lower position, upper position, velocity) joint indices: an active bound is the velocity
    limit where ``v < γ · (distance to the position limit) / Δt``, otherwise the position limit."""
    lo_i: list[int] = []
    hi_i: list[int] = []
    vel_i: list[int] = []
    for i in np.flatnonzero(sol.active_lower):
        (vel_i if velocity is not None and velocity[i] < gain * (q[i] - lower[i]) / dt else lo_i).append(int(i))
    for i in np.flatnonzero(sol.active_upper):
        (vel_i if velocity is not None and velocity[i] < gain * (upper[i] - q[i]) / dt else hi_i).append(int(i))
    return lo_i, hi_i, vel_i
