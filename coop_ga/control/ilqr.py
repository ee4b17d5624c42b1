"""iLQR for cooperative reaching under joint limits: optimal control in the similarity task space (§3.9, Eq 53–57).

The problem (Eq 53) for a joint-space double integrator
--------------------------------------------------------
* state ``x_k = [q_k; q̇_k]`` (2·nq) [rad, rad/s], control ``u_k = q̈_k`` (nq) [rad/s²] (Eq 55);
* linear dynamics ``x_{k+1} = A x_k + B u_k`` (Eq 54) — the *exact* zero-order-hold
  discretisation of ``q̈ = u`` (acceleration piecewise constant over each interval):

      q_{k+1} = q_k + Δt q̇_k + ½Δt² u_k,      q̇_{k+1} = q̇_k + Δt u_k;

* running cost ``l(x_k, u_k) = u_kᵀ R u_k`` (Eq 56);
* terminal cost (Eq 57 plus a rest term)

      l_f(x_n) = ‖e(q_n)‖²_Q + q̇_nᵀ Q_v q̇_n,      e(q) = log(Ṽ_Sc(q) V_Sd)   (Eq 44),

  e the 7-vector on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``;
* **constraints** (𝒳, 𝒰 of Eq 53), from ``task.system.limits`` unless ``limits="none"``:
  ``lower ≤ q_k ≤ upper`` and ``|q̇_k| ≤ velocity`` at the knots k = 1 … n, and
  ``|u_k| ≤ acceleration`` (k = 0 … n−1; infinite bounds are absent).

Horizon: the paper (§4.2) states n = 250 knots, Δt = 0.001 s *and* a 2.5 s horizon, which
contradict each other (250 × 0.001 s = 0.25 s).  We keep the 250 knots and the 2.5 s
horizon, i.e. **Δt = 0.01 s** (defaults ``horizon=250, dt=0.01``).

Terminal error as a constraint (``terminal="constraint"``, default)
--------------------------------------------------------------------
With Eq 57 alone the optimum keeps a bias ``e* ≈ (2Q)⁻¹ λ*`` (λ* the multiplier of the
reaching condition): with ``R = 1e-3``, ``Q = 1e5`` it is ~1e-6 on the arms but up to
1e-4 on the small hands, so ``tol = 1e-5`` was missed on reachable targets.  By default
``e(q_n) = 0`` is therefore an equality constraint handled by the method of multipliers:
the terminal cost is ``(e + s)ᵀ Q (e + s)`` with the shift ``s ← s + e`` after each inner
solve (``λ_e = 2Q s``), so Q is the penalty and ``e → 0`` whatever Q/R are: the default
``tol`` is always reachable on a reachable target.  ``terminal="soft"`` solves Eq 57
exactly (the problem of ``benchmarks/ocp.py``'s reference solvers).

Solver: augmented-Lagrangian box-DDP
------------------------------------
(ALTRO-style; Howell, Jackson, Manchester 2019; box-DDP of Tassa, Mansard, Todorov 2014.)

* **Control bounds** are handled exactly in the backward pass: at each knot the
  quadratic model of ``Q(δu)`` is minimised over the box ``a_lo − u_k ≤ δu ≤ a_hi − u_k``
  by projected Newton (:func:`_box_qp`); clamped controls get zero feedback rows, and the
  forward pass clips the controls.
* **Position and velocity bounds** at every knot by an augmented Lagrangian (the
  Powell–Hestenes–Rockafellar form ``(1/2μ)(max(0, λ + μc)² − λ²)`` per inequality c ≤ 0):
  the terms are separable, so their gradients and (diagonal) Hessians enter the Riccati
  recursion knot by knot; after each inner solve ``λ ← max(0, λ + μc)`` and μ grows ×10
  (up to ``al_max_penalty``) when the violation did not drop by 4.  Why AL rather than
  a barrier: the iterates need not start strictly inside, active limits are reached
  exactly in the limit, and the inner problem stays a smooth unconstrained iLQR.
* **No run-away steps.** Far from the target the terminal model is Gauss–Newton
  (``2 J_eᵀ Q J_e``, positive semi-definite); the Newton model (``+ Σ w_i ∇²e_i``, the
  Hessian of the Lagrangian, with w the least-squares multiplier estimate from stationarity
  of the running cost; :meth:`CooperativeTask.error_hessian`) is used only once
  ``‖e‖ < newton_switch``, convexified where needed (the condensed Hessian ``W⁻¹ + H_f``
  lifted to ``λ_min(W⁻¹)``, W the controllability Gramian), so the nullspace curvature
  that Gauss–Newton ignores (it converges only linearly on the redundant arms) is used
  where it is accurate and the convergence becomes superlinear.  And every step's joint travel is capped: the line
  search starts at ``α ≤ max_travel / max_k |δq_k|∞`` (a trust region on the joint
  motion of one iteration, default 0.5 rad).  The study behind this (the limits issue):
  the previous default took a first Newton step that multiplied joint travel by 14
  (118 rad at 71 rad/s on one hexapod target) and the Armijo test accepted it.
* Line search: Armijo backtracking on the augmented merit (running + terminal + AL
  terms), evaluated exactly (a roll-out and one compiled task evaluation per trial).
* Speed: when no AL term is active and no control bound binds, the LQ step is computed in
  closed form through the controllability Gramian (:func:`_condensed_step`, ~1 ms for 21
  joints, identical to the Riccati step); otherwise by the Riccati/box-QP pass (~15 ms).
  ``backward="riccati"`` forces the Riccati pass.

Clearance cost (``clearance=``, default None: off)
--------------------------------------------------
With ``ILQROptions(clearance=ClearanceCost(cm, weight, activation))``
(:class:`coop_ga.control.avoidance.ClearanceCost`) the running cost gains, at the knots
k = 1 … n, ``w Σ_i ½ max(0, d_a − d_i(q_k))²`` over the collision model's signed clearances
d_i (link–obstacle and link–link, [m]): a squared hinge (C¹), zero while every pair is farther
than d_a.  Its exact gradient ``−w J_dᵀ max(0, d_a − d)`` (J_d from the model) and its
Gauss–Newton Hessian ``w J_Aᵀ J_A`` (A: the pairs within d_a) enter the Riccati pass as full
(not diagonal) state-cost blocks; while any pair is within d_a the Riccati pass is used (the
closed-form step knows no state costs) with the Gauss–Newton terminal model.  The line search
evaluates the exact cost.  It is a penalty, not a constraint: it increases the clearance
(measured in ``tests/control/test_avoidance.py``) but does not guarantee a bound on it;
``ILQRResult.min_clearance`` reports the smallest clearance of the returned trajectory.

Feasibility of what is returned.  After the solve, the trajectory is blended with a
strictly feasible reference (rest at q_init, or braking to rest from a moving start):
``u ← (1 − β) u + β u_ref`` with the smallest β that satisfies every bound (the
constraints are affine in u, so β is computed exactly).  β is 0 when the AL solution is
already feasible and tiny otherwise (reported).  A start on a position bound is feasible
but rest there is not *strictly* feasible (the blend could not move the trajectory off that
bound); the blend is then done joint by joint (the dynamics and the bounds are separable per
joint), each joint that leaves a bound with its own strictly feasible reference: braking, a
bang-bang move of ≤ 0.05 rad inward off the bound, or, for a joint moving out through its
bound, a reversal of its velocity in one knot where the acceleration bound allows it.  Hence
**every returned trajectory satisfies the bounds** (to 1e-12), including a start on a bound
(Talos' neutral configuration has four arm joints on one); only a start that no control keeps
inside (a joint moving out through the bound it sits on faster than its acceleration bound can
reverse) is reported as such and is not converged.

Fast honest failure.  Before iterating, :func:`_unreachable` checks a certificate: every end point
stays in a ball about its chain's first joint (radius: the sum of the link offsets, plus the
travel of prismatic joints), and ``e = 0`` puts every end point on the target primitive; if the
target primitive misses one ball by a margin (ten times the displacement ``tol`` allows), no
configuration reaches the target and the solve returns at once (rest, or braking to rest, inside
the limits) with ``converged=False`` and a message saying the target is not reachable inside the
limits from this start.  A target 3 m away thus fails in ~0.01 s instead of the full budget
(1–7 s, 1–20× the bounded Gauss–Newton IK's time; ``benchmarks/ilqr_unreachable.py``).  The
certificate is exact, so no run that can converge is cut short; targets within reach that the
limits (or the primitive's orientation) make unreachable are not certified and still use the
budget.

``converged`` means: ``‖e(q_n)‖ < tol`` **and** the bounds hold **and** the last step was
accepted by the line search on the true (re-evaluated) merit.  An unreachable target
(outside the reachable set, or only reachable outside the limits) ends with
``converged=False`` and a message naming the active constraints and the residual.
A start outside the limits raises :class:`~coop_ga.errors.InvalidInputError` (use
``limits="none"`` to study it).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.targets import displaced_target
from ..diagnostics import collect_warnings, warn
from ..errors import DegeneratePrimitiveError, InvalidInputError, JointLimitWarning
from ..geometry.groups import Similarity
from .base import SolverResult, check_problem, check_q, resolve_options

__all__ = [
    "DEFAULT_Q",
    "DEFAULT_QV",
    "DEFAULT_R",
    "ILQRIteration",
    "ILQROptions",
    "ILQRResult",
    "ReachingOCP",
    "displaced_target",
    "ilqr_reach",
]

#: Default control weight R (scalar → R · I) [1/(rad/s²)²].
DEFAULT_R = 1e-3
#: Default precision Q of the terminal similarity error (scalar → Q · I_7): the penalty of the
#: terminal constraint (``terminal="constraint"``) or the weight of Eq 57 (``"soft"``).
DEFAULT_Q = 1e5
#: Default weight of the terminal rest term q̇_nᵀ Q_v q̇_n [1/(rad/s)²] (scalar → Q_v · I).
DEFAULT_QV = 1e2

_CTOL = 1e-7  # bound violation [rad, rad/s] below which a trajectory counts as feasible inside the solver


def _check_clearance(c: Any) -> Any:
    """None or a clearance cost (``evaluate(q)`` and ``value(q)``, :class:`coop_ga.control.avoidance.ClearanceCost`)."""
    if c is None or (callable(getattr(c, "evaluate", None)) and callable(getattr(c, "value", None))):
        return c
    raise InvalidInputError(
        f"clearance must be None or a coop_ga.control.avoidance.ClearanceCost, got {type(c).__name__}"
    )


def _add_state_hessian(M: np.ndarray, l: np.ndarray) -> None:
    """M += the state-cost Hessian l of one knot: diagonal (2nq,) or full (2nq, 2nq)."""
    if l.ndim == 1:
        M[np.diag_indices(M.shape[0])] += l
    else:
        M += l


# ============================================================================ the problem
class ReachingOCP:
    """The reaching problem of Eq 53–57 for a cooperative task (see the module docstring).

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask` (V_Sc(q), e and J_e, Eq 28, 44, 47).
    q_init: (nq,) initial joint configuration q_0 [rad].
    target: V_Sd, a :class:`~coop_ga.Similarity`.  It must describe a primitive of the
        task's kind (e.g. from :func:`displaced_target`); otherwise the terminal error cannot
        reach zero.
    qd_init: (nq,) initial joint velocity [rad/s] (default 0).
    horizon: number of control knots n (states x_0 … x_n).
    dt: time step Δt [s].
    R: control weight (scalar, (nq,) or (nq, nq); positive definite).
    Q: precision of the terminal similarity error (scalar, (7,) or (7, 7); PSD).
    Qv: terminal velocity weight (scalar, (nq,) or (nq, nq); PSD; 0 = paper's Eq 57 only).
    limits: ``"enforce"`` (default: the bounds of ``task.system.limits``) or ``"none"``.
    clearance: a :class:`coop_ga.control.avoidance.ClearanceCost` (a running cost on the
        clearances at the knots 1 … n, module docstring) or None (default).

    The total cost is ``J(u) = Σ_k u_kᵀ R u_k + e(q_n)ᵀ Q e(q_n) + q̇_nᵀ Q_v q̇_n`` (+ ``Σ_{k≥1} c(q_k)``
    with a clearance cost).
    """

    def __init__(
        self,
        task: Any,
        q_init: Any,
        target: Any,
        *,
        qd_init: Any = None,
        horizon: int = 250,
        dt: float = 0.01,
        R: Any = DEFAULT_R,
        Q: Any = DEFAULT_Q,
        Qv: Any = DEFAULT_QV,
        limits: str = "enforce",
        clearance: Any = None,
    ):
        self.task = task
        self.clearance = _check_clearance(clearance)
        self.nq = n = int(task.nq)
        self.q_init, self.target = check_problem(task, q_init, target, "q_init")
        self.qd_init = np.zeros(n) if qd_init is None else check_q(task, qd_init, "qd_init")
        self.horizon = validation.integer(horizon, "horizon", minimum=2)  # ≥ 2: x_n must be controllable
        self.dt = validation.positive(dt, "dt")
        self.R = validation.weight(R, n, "R", definite=True)
        self.Q = validation.weight(Q, 7, "Q", definite=False)
        self.Qv = validation.weight(Qv, n, "Qv", definite=False)
        self.limits = validation.choice(limits, ("enforce", "none"), "limits")
        self.R2 = 2.0 * self.R
        self.h = 0.5 * self.dt * self.dt
        # Dense A, B for reference and for other solvers (benchmarks); the iLQR uses blocks.
        eye = np.eye(n)
        self.A = np.block([[eye, self.dt * eye], [np.zeros((n, n)), eye]])
        self.B = np.vstack([self.h * eye, self.dt * eye])
        lim = task.system.limits
        inf = np.full(n, np.inf)
        if self.limits == "enforce":
            self.q_lower, self.q_upper = lim.lower.copy(), lim.upper.copy()
            self.v_max, self.a_max = lim.velocity.copy(), lim.acceleration.copy()
        else:
            self.q_lower, self.q_upper, self.v_max, self.a_max = -inf, inf.copy(), inf.copy(), inf.copy()
        self.joint_names = tuple(lim.joint_names)

    # ------------------------------------------------------------------ dynamics
    @property
    def times(self) -> np.ndarray:
        """(n+1,) knot times [s]."""
        return self.dt * np.arange(self.horizon + 1)

    def rollout(self, u: Any) -> tuple[np.ndarray, np.ndarray]:
        """Integrate the double integrator: ``u`` (n, nq) → ``q, q̇`` (n+1, nq) (Eq 54, exact ZOH)."""
        u = self.check_controls(u)
        qd = np.empty((self.horizon + 1, self.nq))
        qd[0] = self.qd_init
        np.cumsum(self.dt * u, axis=0, out=qd[1:])
        qd[1:] += self.qd_init
        q = np.empty_like(qd)
        q[0] = self.q_init
        np.cumsum(self.dt * qd[:-1] + self.h * u, axis=0, out=q[1:])
        q[1:] += self.q_init
        return q, qd

    def check_controls(self, u: Any) -> np.ndarray:
        """Controls (n, nq) [rad/s²] as a checked float array."""
        return validation.array(u, "controls", shape=(self.horizon, self.nq))

    # ------------------------------------------------------------------ costs
    def running_cost(self, u: np.ndarray) -> float:
        """Σ_k u_kᵀ R u_k (Eq 56)."""
        return float(np.einsum("ki,ij,kj->", u, self.R, u))

    def terminal(self, q_n: np.ndarray, qd_n: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """``(l_f, e (7,), J_e (7, nq))`` at the terminal state (Eq 57 + rest term)."""
        e, Je = self.task.error_and_jacobian(q_n, self.target)
        lf = float(e @ self.Q @ e + qd_n @ self.Qv @ qd_n)
        return lf, e, Je

    def cost(self, u: Any) -> float:
        """Total cost J(u) (Eq 53 with Eq 56–57, plus the clearance cost if any)."""
        u = self.check_controls(u)
        q, qd = self.rollout(u)
        return self.running_cost(u) + self.terminal(q[-1], qd[-1])[0] + self.clearance_cost(q)

    def clearance_cost(self, q: np.ndarray) -> float:
        """``Σ_{k=1}^{n} c(q_k)`` of the clearance cost (0 without one); q (n+1, nq)."""
        if self.clearance is None:
            return 0.0
        return float(sum(self.clearance.value(qk) for qk in q[1:]))

    def clearance_terms(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        """Gradients (n+1, nq) and Gauss–Newton Hessians (n+1, nq, nq) of the clearance cost at the
        knots (row 0 zero), and whether any pair is within the activation distance."""
        T, n = self.horizon, self.nq
        g = np.zeros((T + 1, n))
        H = np.zeros((T + 1, n, n))
        if self.clearance is None:
            return g, H, False
        for k in range(1, T + 1):
            _, g[k], Hk, _ = self.clearance.evaluate(q[k])
            assert Hk is not None  # hessian=True
            H[k] = Hk
        return g, H, bool(np.any(g))

    def gradient(self, u: Any) -> np.ndarray:
        """∂J/∂u (n, nq) by the adjoint recursion ``λ_n = ∇l_f``, ``λ_k = Aᵀ λ_{k+1}``,
        ``∂J/∂u_k = 2R u_k + Bᵀ λ_{k+1}`` (exact, with the exact J_e of Eq 47)."""
        u = self.check_controls(u)
        q, qd = self.rollout(u)
        _, e, Je = self.terminal(q[-1], qd[-1])
        lq = 2.0 * Je.T @ (self.Q @ e)
        lv = 2.0 * self.Qv @ qd[-1]
        # λ_{k+1} = (A^T)^{n-1-k} λ_n: the q-part stays lq, the v-part is lv + (n-1-k) Δt lq
        m = np.arange(self.horizon - 1, -1, -1, dtype=float)[:, None]  # n-1-k
        lam_v = lv[None, :] + (m * self.dt) * lq[None, :]
        grad = u @ self.R2.T + self.h * lq[None, :] + self.dt * lam_v
        if self.clearance is not None:
            # ∂q_k/∂u_j = (h + (k−1−j) Δt²) I for k > j: with A_m = Σ_{k≥m} g_k and B_m = Σ_{k≥m} k g_k,
            # Σ_{k>j} (h + (k−1−j)Δt²) g_k = h A_{j+1} + Δt² (B_{j+1} − (j+1) A_{j+1})
            g, _, _ = self.clearance_terms(q)
            kk = np.arange(self.horizon + 1, dtype=float)[:, None]
            A = np.cumsum(g[::-1], axis=0)[::-1]
            B = np.cumsum((kk * g)[::-1], axis=0)[::-1]
            j1 = kk[1:]
            grad = grad + self.h * A[1:] + self.dt**2 * (B[1:] - j1 * A[1:])
        return grad

    # ------------------------------------------------------------------ constraints
    def constraint_values(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Inequalities c ≤ 0 at the knots 1…n, shape (n, 4, nq): ``q − upper, lower − q, q̇ − v, −v − q̇``
        (−inf where a bound is infinite)."""
        with np.errstate(invalid="ignore"):
            c = np.stack(
                [q[1:] - self.q_upper, self.q_lower - q[1:], qd[1:] - self.v_max, -self.v_max - qd[1:]], axis=1
            )
        return np.where(np.isnan(c), -np.inf, c)

    def violation(self, q: np.ndarray, qd: np.ndarray, u: np.ndarray | None = None) -> float:
        """Largest bound violation of a trajectory [rad, rad/s or rad/s²] (0: feasible)."""
        c = self.constraint_values(q, qd)
        v = float(np.max(c, initial=0.0))
        if u is not None:
            v = max(v, float(np.max(np.abs(u) - self.a_max, initial=0.0)))
        return max(v, 0.0)

    @property
    def u_bounded(self) -> bool:
        return bool(np.any(np.isfinite(self.a_max)))


# ============================================================================ results
@dataclass(frozen=True)
class ILQRIteration:
    """Statistics of one accepted iLQR iteration.

    cost: total cost (Eq 53) after the step.  error: ‖e(q_n)‖ after the step.
    merit: the augmented merit the line search decreased (cost + multiplier terms).
    alpha: accepted line-search step length (≤ the travel cap).
    mu: multiple of I added to the terminal Hessian model (Levenberg–Marquardt damping; 0 = none).
    expected_decrease, actual_decrease: model and true merit decrease of the step.
    line_search_trials: roll-outs of the line search.  backward_passes: LQ steps computed.
    time_s: wall time of the iteration [s].
    model: ``"newton"`` or ``"gauss_newton"`` — the terminal-Hessian model of the accepted step.
    outer: index of the outer (multiplier / penalty / terminal-shift) iteration.
    violation: largest bound violation after the step.
    travel: max |δq| of the step [rad].  backward: ``"condensed"`` or ``"riccati"``.

    """

    cost: float
    error: float
    alpha: float
    mu: float
    expected_decrease: float
    actual_decrease: float
    line_search_trials: int
    backward_passes: int
    time_s: float
    model: str = "gauss_newton"
    merit: float = 0.0
    outer: int = 0
    violation: float = 0.0
    travel: float = 0.0
    backward: str = "riccati"


@dataclass(frozen=True)
class ILQROptions:
    """Settings of :func:`ilqr_reach`: the problem (horizon, Δt, weights, limits) and the solver.

    Problem (Eq 53–57, :class:`ReachingOCP`):
        horizon: number of knots n (≥ 2; default 250).
        dt: Δt [s] (default 0.01 → 2.5 s; the paper's Δt = 0.001 s contradicts its 2.5 s
            horizon, see the module docstring).
        R, Q, Qv: weights (scalar, diagonal or matrix; R ≻ 0, Q, Qv ⪰ 0).
        limits: ``"enforce"`` (position, velocity and acceleration bounds of
            ``task.system.limits``) or ``"none"``.
        terminal: ``"constraint"`` (e(q_n) = 0 by multipliers, default) or ``"soft"`` (Eq 57).
    Solver:
        max_iter: maximum number of accepted iterations, all outer iterations together (≥ 0).
        max_outer: maximum outer iterations (AL multipliers and penalty, terminal shift) (≥ 1).
        tol: converged when ‖e(q_n)‖ < tol and the bounds hold.
        ftol: an inner solve ends when the relative merit decrease of an iteration is below it.
        hessian: ``"newton"`` (Gauss–Newton far from the target, Newton once
            ‖e‖ < ``newton_switch``) or ``"gauss_newton"`` (always).
        newton_switch: ‖e‖ below which the Newton terminal model is used.
        max_travel: trust region [rad]: the largest joint motion one iteration may add
            anywhere along the trajectory (the line search starts at α ≤ max_travel / travel).
        backward: ``"auto"`` (closed-form step when no constraint is active, else Riccati/box-QP),
            or ``"riccati"`` (always the backward pass).
        soc: try a second-order correction when a full closed-form step fails the Armijo test.
        armijo: sufficient-decrease constant c ∈ (0, 1).
        max_backtracks: halvings of α per model before the next (damped) model is tried.
        al_penalty, al_growth, al_max_penalty: initial AL penalty μ [1/rad², 1/(rad/s)²], its
            growth factor and its cap.
        al_inner_tol: while a bound is violated, the inner solve ends (and the multipliers are
            updated) once an iteration decreases the merit by less than this fraction.
        al_violation: the solve may stop once the bounds are violated by at most this much
            [rad, rad/s]; the final blend with the feasible reference removes it exactly.
        restart: if the solve from the default guess stalls short of tol (not when it runs out of
            ``max_iter``), restart once from the minimum-energy controls to the bounded Gauss–Newton IK
            solution; both solves count in ``iterations`` and the histories, and the message says so.
        warn_limits: with ``limits="none"``, warn when the trajectory leaves the joint limits.
    Avoidance:
        clearance: a :class:`coop_ga.control.avoidance.ClearanceCost` — a running cost on the
            link–obstacle / link–link clearances of a collision model (module docstring) — or
            None (default: off; results identical to the solver without it).
    """

    horizon: int = 250
    dt: float = 0.01
    R: Any = DEFAULT_R
    Q: Any = DEFAULT_Q
    Qv: Any = DEFAULT_QV
    limits: str = "enforce"
    terminal: str = "constraint"
    max_iter: int = 60
    max_outer: int = 30
    tol: float = 1e-5
    ftol: float = 1e-7
    hessian: str = "newton"
    newton_switch: float = float("inf")
    max_travel: float = 0.5
    backward: str = "auto"
    soc: bool = True
    armijo: float = 1e-4
    max_backtracks: int = 12
    al_penalty: float = 1e3
    al_growth: float = 10.0
    al_max_penalty: float = 1e9
    al_inner_tol: float = 1e-3
    al_violation: float = 1e-6
    restart: bool = True
    warn_limits: bool = True
    clearance: Any = None

    def __post_init__(self) -> None:
        _check_clearance(self.clearance)
        validation.integer(self.horizon, "horizon", minimum=2)
        validation.positive(self.dt, "dt")
        validation.choice(self.limits, ("enforce", "none"), "limits")
        validation.choice(self.terminal, ("constraint", "soft"), "terminal")
        validation.integer(self.max_iter, "max_iter", minimum=0)
        validation.integer(self.max_outer, "max_outer", minimum=1)
        validation.nonnegative(self.tol, "tol")
        validation.nonnegative(self.ftol, "ftol")
        validation.choice(self.hessian, ("newton", "gauss_newton"), "hessian")
        validation.nonnegative(self.newton_switch, "newton_switch", allow_inf=True)
        validation.positive(self.max_travel, "max_travel", allow_inf=True)
        validation.choice(self.backward, ("auto", "riccati"), "backward")
        validation.scalar(self.armijo, "armijo", low=0.0, high=1.0, low_open=True)
        validation.integer(self.max_backtracks, "max_backtracks", minimum=0)
        validation.positive(self.al_penalty, "al_penalty")
        validation.scalar(self.al_growth, "al_growth", low=1.0)
        validation.positive(self.al_max_penalty, "al_max_penalty")
        validation.nonnegative(self.al_inner_tol, "al_inner_tol")
        validation.positive(self.al_violation, "al_violation")
        for name in ("soc", "warn_limits", "restart"):
            if not isinstance(getattr(self, name), bool):
                raise InvalidInputError(f"{name} must be True or False, got {getattr(self, name)!r}")


@dataclass(frozen=True, kw_only=True)
class ILQRResult(SolverResult):
    """Result of :func:`ilqr_reach` (fields of :class:`~coop_ga.control.base.SolverResult` plus):

    q: (nq,) the terminal configuration q_n;  error: ‖e(q_n)‖, ``e = log(Ṽ_Sc(q_n) V_Sd)``
        (Eq 44; plain 7-vector norm, mixed units rad / log-scale / body length);
        converged: ``error < tol`` and the bounds hold and the last step was accepted.
    trajectory: (n+1, nq) joint positions [rad] at the knots; qd: (n+1, nq) velocities [rad/s].
    u: (n, nq) joint accelerations [rad/s²] (piecewise constant over each Δt).
    t: (n+1,) knot times [s].
    error_vector: (7,) e(q_n) on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``.
    terminal_speed: ‖q̇_n‖ [rad/s].
    cost: final total cost (Eq 53).  cost_history: (iterations+1,) costs, [0] = initial guess.
    error_history: (iterations+1,) ‖e(q_n)‖ per iterate.
    solve_time_s: wall time of the solve [s] (excludes building/compiling the task's
        functions, which happens once per task and process; see ``ilqr_reach``).
    stats: one :class:`ILQRIteration` per accepted iteration.
    joint_limit_violation, velocity_violation, acceleration_violation: largest excursion of
        q, |q̇|, |u| beyond their limits over the returned trajectory (0 with ``limits="enforce"``).
    active_constraints: the bounds active at the end (joint, kind, first/last knot).
    outer_iterations: outer iterations (AL multipliers and penalty, terminal shift).
    restoration: the β of the final feasibility blend (0: none was needed).
    dt: the time step [s].  target: V_Sd.  hessian: the terminal-Hessian option.
    clearance_cost: ``Σ_{k≥1} c(q_k)`` of the clearance cost (included in ``cost``; 0 without one).
    min_clearance: smallest clearance of the collision model over the knots [m] (inf without a clearance cost).
    """

    trajectory: np.ndarray
    qd: np.ndarray
    u: np.ndarray
    t: np.ndarray
    error_vector: np.ndarray
    terminal_speed: float
    cost: float
    cost_history: np.ndarray
    error_history: np.ndarray
    solve_time_s: float
    target: Similarity
    stats: tuple[ILQRIteration, ...] = field(default_factory=tuple)
    joint_limit_violation: float = 0.0
    velocity_violation: float = 0.0
    acceleration_violation: float = 0.0
    active_constraints: tuple[str, ...] = ()
    outer_iterations: int = 0
    restoration: float = 0.0
    dt: float = 0.01
    hessian: str = "newton"
    clearance_cost: float = 0.0
    min_clearance: float = float("inf")

    @property
    def within_limits(self) -> bool:
        return (
            self.joint_limit_violation == 0.0 and self.velocity_violation == 0.0 and self.acceleration_violation == 0.0
        )


# ============================================================================ LQ steps
def _gramian(ocp: ReachingOCP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients of x_n w.r.t. u: ``c_k`` with ``∂q_n/∂u_k = c_k I``, ``∂q̇_n/∂u_k = Δt I``,
    and the 2×2 factor G2 of the Gramian ``W = Σ_k G_k (2R)⁻¹ G_kᵀ = G2 ⊗ (2R)⁻¹``."""
    T = ocp.horizon
    ck = ocp.h + np.arange(T - 1, -1, -1, dtype=float) * ocp.dt**2
    s1 = float(ck.sum())
    G2 = np.array([[float(ck @ ck), ocp.dt * s1], [ocp.dt * s1, T * ocp.dt**2]])
    return ck, G2, np.linalg.inv(ocp.R2)


def _condensed_step(
    ocp: ReachingOCP, u: np.ndarray, Vxx: np.ndarray, vx: np.ndarray, ck: np.ndarray, G2: np.ndarray, R2inv: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The LQ step of the unconstrained problem in closed form through the Gramian.

    With ``x_n = x̄_n + Σ_k G_k δu_k`` (``G_k = [c_k I; Δt I]``) the LQ subproblem
    ``min Σ (u_k+δu_k)ᵀR(u_k+δu_k) + vxᵀδx_n + ½δx_nᵀ V_xx δx_n`` has the stationarity
    conditions ``δu_k = −u_k − (2R)⁻¹ G_kᵀ m``, ``m = vx + V_xx δx_n``, hence one
    2nq×2nq solve ``(I + V_xx W) m = vx − V_xx s`` with ``s = Σ G_k u_k``.  Requires the
    condensed Hessian to be positive definite (``W⁻¹ + V_xx ≻ 0``; raises LinAlgError
    otherwise, like the Cholesky of Q_uu in the Riccati pass).
    Returns ``(δu, δq_n, δq̇_n, d₁)``; the model decrease is ``d₁(α − α²/2)``.
    """
    n, dt = ocp.nq, ocp.dt
    W = np.kron(G2, R2inv)
    np.linalg.cholesky(np.linalg.inv(W) + Vxx)  # positive-definiteness check (LinAlgError)
    sq = ck @ u
    sv = dt * u.sum(axis=0)
    svec = np.concatenate([sq, sv])
    m = np.linalg.solve(np.eye(2 * n) + Vxx @ W, vx - Vxx @ svec)
    du = -u - (np.outer(ck, R2inv @ m[:n]) + dt * (R2inv @ m[n:])[None, :])
    gu = u @ ocp.R2.T + np.outer(ck, vx[:n]) + dt * vx[n:][None, :]
    d1 = float(np.sum(gu * du))
    return du, ck @ du, dt * du.sum(axis=0), d1


def _box_qp(
    H: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray, max_iter: int = 30
) -> tuple[np.ndarray, np.ndarray]:
    """``argmin ½xᵀHx + gᵀx`` s.t. ``lo ≤ x ≤ hi`` by projected Newton (Tassa et al. 2014, Alg. 3).

    Returns ``(x, free)`` with ``free`` the mask of the unclamped coordinates at the solution
    (the feedback gains of the clamped ones are zero).  H must be positive definite.
    """
    x = np.clip(x0, lo, hi)
    free = np.ones(x.shape, dtype=bool)
    f = 0.5 * x @ H @ x + g @ x
    for _ in range(max_iter):
        grad = g + H @ x
        clamped = ((x <= lo) & (grad > 0)) | ((x >= hi) & (grad < 0))
        free = ~clamped
        if not free.any():
            break
        dx = np.zeros_like(x)
        Hf = H[np.ix_(free, free)]
        dx[free] = -np.linalg.solve(Hf, grad[free])
        if float(np.max(np.abs(dx))) < 1e-13 * (1.0 + float(np.max(np.abs(x)))):
            break
        step = 1.0
        while True:  # projected Armijo line search
            xn = np.clip(x + step * dx, lo, hi)
            fn = 0.5 * xn @ H @ xn + g @ xn
            if fn - f <= 0.1 * float(grad @ (xn - x)) or step < 1e-10:
                break
            step *= 0.5
        if step < 1e-10 or f - fn <= 1e-15 * (1.0 + abs(f)):
            x, f = xn, fn
            break
        x, f = xn, fn
    grad = g + H @ x
    free = ~(((x <= lo) & (grad > 0)) | ((x >= hi) & (grad < 0)))
    return x, free


def _backward_box(
    ocp: ReachingOCP,
    u: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    lx: np.ndarray | None = None,
    lxx: np.ndarray | None = None,
    box: bool = False,
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Riccati recursion (box-DDP) for the double integrator with separable state costs.

    ``Vxx, vx``: Hessian and gradient of the terminal cost (plus the knot-n state cost).
    ``lx, lxx``: (n+1, 2nq) gradients and Hessians of the state costs at the knots, the Hessians
    *diagonal* (n+1, 2nq) (the augmented-Lagrangian terms) or full (n+1, 2nq, 2nq) (with a
    clearance cost); row 0 unused, row n already in Vxx, vx.
    ``box``: minimise each knot's ``Q(δu)`` over ``a_lo − u_k ≤ δu ≤ a_hi − u_k`` (:func:`_box_qp`).

    ``Q_x = Aᵀv``, ``Q_u = 2R u_k + Bᵀv``, ``Q_xx = AᵀVA``, ``Q_ux = BᵀVA``,
    ``Q_uu = 2R + BᵀVB``; unconstrained ``[k, K] = −Q_uu⁻¹[Q_u, Q_ux]``; then
    ``v ← Q_x + Kᵀ Q_uu k + Kᵀ Q_u + Q_uxᵀ k``, ``V ← Q_xx + Kᵀ Q_uu K + Kᵀ Q_ux + Q_uxᵀ K``
    (plus the state cost of x_k).  Raises ``LinAlgError`` if some Q_uu is not positive definite.

    Returns feedforward k (n, nq), gains K (n, nq, 2nq) and the model coefficients
    ``d1 = Σ kᵀQ_u``, ``d2 = ½ Σ kᵀQ_uu k`` (predicted change ``α d1 + α² d2``).
    """
    n = ocp.nq
    dt, h, R2 = ocp.dt, ocp.h, ocp.R2
    T = ocp.horizon
    kff = np.empty((T, n))
    Kfb = np.empty((T, n, 2 * n))
    V = Vxx.copy()
    v = vx.copy()
    d1 = d2 = 0.0
    Ru = u @ R2.T
    cholesky, solve = np.linalg.cholesky, np.linalg.solve
    lo_all, hi_all = -ocp.a_max, ocp.a_max
    prev = np.zeros(n)
    for k in range(T - 1, -1, -1):
        BV = h * V[:n] + dt * V[n:]  # Bᵀ V (n × 2n)
        Quu = R2 + h * BV[:, :n] + dt * BV[:, n:]
        Qux = np.empty((n, 2 * n))
        Qux[:, :n] = BV[:, :n]
        Qux[:, n:] = dt * BV[:, :n] + BV[:, n:]
        Qu = Ru[k] + h * v[:n] + dt * v[n:]
        VA = np.empty_like(V)  # V A = [V_:q, Δt V_:q + V_:v]
        VA[:, :n] = V[:, :n]
        VA[:, n:] = dt * V[:, :n] + V[:, n:]
        Qxx = VA.copy()  # Aᵀ (V A): row block q unchanged, row block v += Δt row block q
        Qxx[n:] += dt * VA[:n]
        Qx = v.copy()
        Qx[n:] += dt * v[:n]
        cholesky(Quu)  # positive-definiteness check (LinAlgError)
        if box:
            sol = -solve(Quu, np.column_stack([Qu, Qux]))
            # the box QP where the nominal control is at (within 0.1 % of) its bound: with the stiff terminal
            # cost the feedforward alone (δx = 0) is large at the last knots although the actual δu = k + K δx
            # is small, and clamping it there (Tassa's box-DDP verbatim) wrecked the step (25 rad of travel on
            # the flagship); new saturations are caught by the clipped forward roll-out and enter the box QP of
            # the next iteration
            if not np.any(np.abs(u[k]) >= 0.999 * hi_all):
                kk, K = sol[:, 0], sol[:, 1:]
                v = Qx + Qux.T @ kk
                V = Qxx + Qux.T @ K
                Quu_k = -Qu
                V = 0.5 * (V + V.T)
                if k > 0 and lx is not None and lxx is not None:
                    v += lx[k]
                    _add_state_hessian(V, lxx[k])
                kff[k] = kk
                Kfb[k] = K
                d1 += float(kk @ Qu)
                d2 += 0.5 * float(kk @ Quu_k)
                prev = kk
                continue
            kk, free = _box_qp(Quu, Qu, lo_all - u[k], hi_all - u[k], prev)
            prev = kk
            K = np.zeros((n, 2 * n))
            if free.all():
                K = -solve(Quu, Qux)
            elif free.any():
                K[free] = -solve(Quu[np.ix_(free, free)], Qux[free])
            Quu_k = Quu @ kk
            v = Qx + K.T @ (Quu_k + Qu) + Qux.T @ kk
            V = Qxx + K.T @ (Quu @ K) + K.T @ Qux + Qux.T @ K
        else:
            sol = -solve(Quu, np.column_stack([Qu, Qux]))
            kk, K = sol[:, 0], sol[:, 1:]
            Quu_k = -Qu
            v = Qx + Qux.T @ kk
            V = Qxx + Qux.T @ K
        V = 0.5 * (V + V.T)
        if k > 0 and lx is not None and lxx is not None:
            v += lx[k]
            _add_state_hessian(V, lxx[k])
        kff[k] = kk
        Kfb[k] = K
        d1 += float(kk @ Qu)
        d2 += 0.5 * float(kk @ Quu_k)
    return kff, Kfb, d1, d2


def _backward(ocp: ReachingOCP, u: np.ndarray, Vxx: np.ndarray, vx: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Unconstrained Riccati pass (:func:`_backward_box` without bounds): ``(k, K, d1)``."""
    kff, Kfb, d1, _ = _backward_box(ocp, u, Vxx, vx)
    return kff, Kfb, d1


def _forward_deviation(ocp: ReachingOCP, kff: np.ndarray, Kfb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """α = 1 roll-out of the affine policy on deviations (no bounds): δu (n, nq), δq_n, δq̇_n."""
    n, dt, h = ocp.nq, ocp.dt, ocp.h
    du = np.empty_like(kff)
    dx = np.zeros(2 * n)
    for k in range(ocp.horizon):
        d = kff[k] + Kfb[k] @ dx
        du[k] = d
        dx[:n] += dt * dx[n:] + h * d
        dx[n:] += dt * d
    return du, dx[:n].copy(), dx[n:].copy()


def _policy_rollout(ocp: ReachingOCP, u: np.ndarray, kff: np.ndarray, Kfb: np.ndarray, alpha: float) -> np.ndarray:
    """New controls of the policy ``u_k + α k_k + K_k δx_k``, clipped to the acceleration bounds."""
    n, dt, h = ocp.nq, ocp.dt, ocp.h
    un = np.empty_like(u)
    dx = np.zeros(2 * n)
    lo, hi = -ocp.a_max, ocp.a_max
    for k in range(ocp.horizon):
        uk = np.clip(u[k] + alpha * kff[k] + Kfb[k] @ dx, lo, hi)
        un[k] = uk
        d = uk - u[k]
        dx[:n] += dt * dx[n:] + h * d
        dx[n:] += dt * d
    return un


# ============================================================================ the augmented merit
class _Merit:
    """Running + terminal (shifted) + augmented-Lagrangian terms of a control sequence.

    Each inequality c ≤ 0 (position and velocity bounds at the knots) enters as
    ``(1/2μ)(max(0, λ + μc)² − λ²)`` (Powell–Hestenes–Rockafellar), with multiplier λ ≥ 0 and
    penalty μ: exactly zero while the trajectory is inside (and λ = 0), so the unconstrained fast
    path solves every problem whose optimum does not touch a bound.
    """

    def __init__(self, ocp: ReachingOCP, mu: float):
        self.ocp = ocp
        self.shift = np.zeros(7)  # s: terminal multiplier / (2Q)  (terminal="constraint")
        T, n = ocp.horizon, ocp.nq
        self.lam = np.zeros((T, 4, n))
        self.mu = mu

    def evaluate(self, u: np.ndarray) -> dict[str, Any] | None:
        """Everything at u: trajectory, e, J_e, cost, merit, AL terms; None if degenerate."""
        ocp = self.ocp
        q, qd = ocp.rollout(u)
        try:
            with collect_warnings(silent=True):  # trial points: degeneracy is a rejection, not news
                e, Je = ocp.task.error_and_jacobian(q[-1], ocp.target)
        except DegeneratePrimitiveError:
            return None
        run = ocp.running_cost(u) + ocp.clearance_cost(q)  # the clearance cost is a running (state) cost
        es = e + self.shift
        lf = float(es @ ocp.Q @ es + qd[-1] @ ocp.Qv @ qd[-1])
        cost = run + float(e @ ocp.Q @ e + qd[-1] @ ocp.Qv @ qd[-1])
        c = ocp.constraint_values(q, qd)
        al = 0.0
        if self.mu > 0:
            z = np.maximum(0.0, self.lam + self.mu * c)
            al = float(np.sum(z * z - self.lam * self.lam)) / (2.0 * self.mu)
        else:
            z = np.zeros_like(c)
        return {
            "u": u,
            "q": q,
            "qd": qd,
            "e": e,
            "es": es,
            "Je": Je,
            "cost": cost,
            "merit": run + lf + al,
            "c": c,
            "z": z,
            "violation": float(max(np.max(c, initial=0.0), 0.0)),
        }

    def state_terms(self, ev: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, bool]:
        """Gradients and diagonal Hessians (n+1, 2nq) of the AL terms at the knots; whether any is active."""
        ocp = self.ocp
        T, n = ocp.horizon, ocp.nq
        lx = np.zeros((T + 1, 2 * n))
        lxx = np.zeros((T + 1, 2 * n))
        z = ev["z"]
        active = z > 0
        al_active = bool(self.mu > 0 and active.any())
        if al_active:
            # c = [q − hi, lo − q, q̇ − v, −v − q̇]: ∂c/∂q = (+1, −1), ∂c/∂q̇ = (+1, −1)
            lx[1:, :n] = z[:, 0] - z[:, 1]
            lx[1:, n:] = z[:, 2] - z[:, 3]
            lxx[1:, :n] = self.mu * (active[:, 0] | active[:, 1])
            lxx[1:, n:] = self.mu * (active[:, 2] | active[:, 3])
        if ocp.clearance is None:
            return lx, lxx, al_active
        g, H, c_active = ocp.clearance_terms(ev["q"])
        if not c_active:
            return lx, lxx, al_active
        full = np.zeros((T + 1, 2 * n, 2 * n))
        idx = np.arange(2 * n)
        full[:, idx, idx] = lxx
        full[:, :n, :n] += H
        lx[:, :n] += g
        return lx, full, True


def _reference_controls(ocp: ReachingOCP) -> np.ndarray:
    """A strictly feasible guess: rest, or braking to rest from q̇_init within 90 % of the acceleration limits."""
    T, n, dt = ocp.horizon, ocp.nq, ocp.dt
    u = np.zeros((T, n))
    v0 = ocp.qd_init
    if not np.any(v0):
        return u
    with np.errstate(divide="ignore"):
        t_stop = np.maximum(0.2, np.abs(v0) / (0.9 * ocp.a_max))  # [s]: at least 0.2 s, within the limit
    steps = np.minimum(np.ceil(t_stop / dt).astype(int), T)
    for j in range(n):
        if v0[j] != 0.0:
            u[: steps[j], j] = -v0[j] / (steps[j] * dt)
    return u


def _restore(ocp: ReachingOCP, u: np.ndarray, u_ref: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Smallest β ∈ [0, 1] with ``(1 − β) u + β u_ref`` feasible (constraints affine in u); None if u_ref is not
    strictly feasible."""
    q, qd = ocp.rollout(u)
    qr, qdr = ocp.rollout(u_ref)
    c, cr = ocp.constraint_values(q, qd), ocp.constraint_values(qr, qdr)
    ca = np.concatenate([c.ravel(), (np.abs(u) - ocp.a_max).ravel()])
    # |u| ≤ a is convex, not affine; the blend stays within it because both ends are (u is clipped)
    cra = np.concatenate([cr.ravel(), (np.abs(u_ref) - ocp.a_max).ravel()])
    if np.max(ca, initial=-np.inf) <= 0.0:
        return u, 0.0
    if np.max(cra, initial=-np.inf) >= 0.0:
        return None
    bad = ca > 0
    beta = float(np.max(ca[bad] / (ca[bad] - cra[bad])))
    beta = min(1.0, beta * (1.0 + 1e-9) + 1e-15)
    return (1.0 - beta) * u + beta * u_ref, beta


def _active(ocp: ReachingOCP, q: np.ndarray, qd: np.ndarray, u: np.ndarray, tol: float = 1e-6) -> tuple[str, ...]:
    """Human-readable list of the bounds active (within tol) along a trajectory."""
    out = []
    c = ocp.constraint_values(q, qd)  # (T, 4, n)
    kinds = ("upper position", "lower position", "velocity (+)", "velocity (−)")
    for j, name in enumerate(ocp.joint_names):
        for b, kind in enumerate(kinds):
            idx = np.flatnonzero(c[:, b, j] > -tol)
            if idx.size:
                out.append(f"{name} {kind} limit at knots {idx[0] + 1}–{idx[-1] + 1}")
        if not np.isfinite(ocp.a_max[j]):
            continue
        ia = np.flatnonzero(np.abs(u[:, j]) > ocp.a_max[j] - tol * max(1.0, ocp.a_max[j]))
        if ia.size:
            out.append(f"{name} acceleration limit at knots {ia[0]}–{ia[-1]}")
    return tuple(out)


def _strictly_inside(ocp: ReachingOCP, u: np.ndarray) -> np.ndarray:
    """Per joint (nq,): whether the trajectory of ``u`` is strictly inside every bound of that joint at the knots
    1 … n (positions and velocities) and strictly below its acceleration bound."""
    q, qd = ocp.rollout(u)
    c = ocp.constraint_values(q, qd)  # (n, 4, nq), −inf where a bound is infinite
    return np.all(c < 0.0, axis=(0, 1)) & np.all(np.abs(u) < ocp.a_max, axis=0)


def _joint_inside(ocp: ReachingOCP, j: int, uj: np.ndarray) -> bool:
    """Whether joint j alone, driven by ``uj`` (n,), stays strictly inside its bounds at the knots 1 … n."""
    qd = ocp.qd_init[j] + np.cumsum(ocp.dt * uj)
    q = ocp.q_init[j] + np.cumsum(ocp.dt * np.concatenate([[ocp.qd_init[j]], qd[:-1]]) + ocp.h * uj)
    lo, hi, v, a = ocp.q_lower[j], ocp.q_upper[j], ocp.v_max[j], ocp.a_max[j]
    return bool(np.all((q > lo) & (q < hi) & (np.abs(qd) < v) & (np.abs(uj) < a)))


def _joint_reference(ocp: ReachingOCP, j: int) -> np.ndarray | None:
    """Controls (n,) of joint j alone that keep it strictly inside its bounds, or None if there are none of this form.

    Braking to rest at 90 % of the acceleration bound (10 rad/s² where it is infinite), then a bang-bang move of at
    most 0.05 rad inward (toward the middle of the range; from rest on a position bound this is what makes the
    reference strictly feasible).  A joint moving out through a bound it sits on cannot brake in time; if its
    acceleration bound allows (> 2.1 |q̇₀|/Δt, always when it is infinite) it first reverses its velocity in one knot
    ("bounce": ``u₀ = −2.1 q̇₀/Δt``, so that q₁ = q₀ − 0.05 Δt q̇₀ is inside), then brakes and moves inward.
    """
    T, dt, v0, q0 = ocp.horizon, ocp.dt, ocp.qd_init[j], ocp.q_init[j]
    a = 0.9 * ocp.a_max[j] if np.isfinite(ocp.a_max[j]) else 10.0  # [rad/s²]
    plain = _joint_inward(ocp, j, np.zeros(T), a, 0, v0, q0)
    if _joint_inside(ocp, j, plain):
        return plain
    if v0 == 0.0 or T < 3:
        return None
    bounce = np.zeros(T)
    bounce[0] = -2.1 * v0 / dt  # q̇₁ = −1.1 q̇₀, q₁ = q₀ − 0.05 Δt q̇₀
    bounce = _joint_inward(ocp, j, bounce, a, 1, -1.1 * v0, q0 - 0.05 * dt * v0)
    return bounce if _joint_inside(ocp, j, bounce) else None


def _joint_inward(ocp: ReachingOCP, j: int, uj: np.ndarray, a: float, start: int, v: float, q: float) -> np.ndarray:
    """Fill ``uj[start:]``: from velocity v at position q (knot ``start``), brake to rest at deceleration ≤ a, then move
    inward by at most 0.05 rad (k knots at +a, k at −a: rest to rest, a displacement of a (k Δt)²)."""
    T, dt = ocp.horizon, ocp.dt
    m = min(int(np.ceil(abs(v) / (a * dt))), T - start) if v != 0.0 else 0
    if m:
        uj[start : start + m] = -v / (m * dt)
    q_stop = q + 0.5 * v * m * dt  # exact for the constant deceleration (ZOH)
    lo, hi = ocp.q_lower[j], ocp.q_upper[j]
    width, rest = hi - lo, T - start - m
    if not width > 0.0 or rest < 2:
        return uj
    delta = min(0.05, 0.25 * width) if np.isfinite(width) else 0.05
    v_cap = 0.9 * ocp.v_max[j] if np.isfinite(ocp.v_max[j]) else np.inf
    a = min(a, delta / dt**2, v_cap / dt)
    k = int(max(1, min(np.floor(np.sqrt(delta / a) / dt), np.floor(v_cap / (a * dt)), rest // 2)))
    sign = 1.0 if q_stop - lo <= hi - q_stop else -1.0
    i = start + m
    uj[i : i + k] += sign * a
    uj[i + k : i + 2 * k] -= sign * a
    return uj


def _restore_joints(ocp: ReachingOCP, u: np.ndarray, u_ref: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Joint-by-joint feasibility blend: ``u_j ← (1 − β_j) u_j + β_j r_j`` for each joint j that leaves a bound, with
    r_j strictly feasible for joint j (the reference ``u_ref``'s column where it is, else :func:`_joint_reference`).

    The double integrator and the bounds are separable per joint, so each β_j is exact for its joint and the other
    joints are left alone.  Used when ``u_ref`` is not strictly feasible as a whole (a start on a position bound: rest
    there is feasible, not strictly).  Returns ``(u, max β_j)``, or None if a violating joint has no strictly feasible
    reference.
    """
    q, qd = ocp.rollout(u)
    ca = np.concatenate([ocp.constraint_values(q, qd), (np.abs(u) - ocp.a_max)[:, None, :]], axis=1)  # (n, 5, nq)
    bad = np.flatnonzero(np.max(ca, axis=(0, 1)) > 0.0)
    if not bad.size:
        return u, 0.0
    ref = u_ref.copy()
    ok = _strictly_inside(ocp, ref)
    for j in bad:
        if not ok[j]:
            rj = _joint_reference(ocp, int(j))
            if rj is not None:
                ref[:, j] = rj
    if not np.all(_strictly_inside(ocp, ref)[bad]):
        return None
    qr, qdr = ocp.rollout(ref)
    cr = np.concatenate([ocp.constraint_values(qr, qdr), (np.abs(ref) - ocp.a_max)[:, None, :]], axis=1)
    out = u.copy()
    beta_max = 0.0
    for j in bad:
        cj, crj = ca[:, :, j].ravel(), cr[:, :, j].ravel()
        viol = cj > 0
        beta = float(np.max(cj[viol] / (cj[viol] - crj[viol])))
        beta = min(1.0, beta * (1.0 + 1e-9) + 1e-15)
        out[:, j] = (1.0 - beta) * u[:, j] + beta * ref[:, j]
        beta_max = max(beta_max, beta)
    return out, beta_max


def _unit_distance(kind: str, y: np.ndarray) -> float:
    """Distance of the point y (3,) from the unit primitive X_u of ``kind`` (:func:`coop_ga.geometry.unit_primitive`:
    the origin; the points (0, ∓1, 0); the e2 axis; the unit circle in z = 0; the plane z = 0; the unit sphere)."""
    x1, x2, x3 = (float(c) for c in y)
    if kind == "point":
        return float(np.linalg.norm(y))
    if kind == "point_pair":
        return min(float(np.linalg.norm(y - (0.0, -1.0, 0.0))), float(np.linalg.norm(y - (0.0, 1.0, 0.0))))
    if kind == "line":
        return float(np.hypot(x1, x3))
    if kind == "circle":
        return float(np.hypot(np.hypot(x1, x2) - 1.0, x3))
    if kind == "plane":
        return abs(x3)
    return abs(float(np.linalg.norm(y)) - 1.0)  # sphere


def _reach_balls(ocp: ReachingOCP) -> list[tuple[np.ndarray, float]] | None:
    """For each end point of the task, a ball (centre (3,) [m], radius [m]) that contains every position it can take
    within the position limits; None if the task has no kinematic tree.

    Centre: the origin of the chain's first joint (fixed in the world).  Radius: by the triangle inequality, the sum
    of the lengths of the later joint placements and of the end frame's offset (a revolute joint turns about an axis
    through its origin, so it does not move a point away from it by more than that), plus the largest travel of each
    prismatic joint (infinite without position limits).
    """
    tree = getattr(ocp.task, "tree", None)
    if tree is None or not hasattr(tree, "chains"):
        return None
    model = tree.model
    travel = np.maximum(np.abs(ocp.q_lower), np.abs(ocp.q_upper))
    balls = []
    for chain, fname in zip(tree.chains, tree.end_frames):
        offset = np.asarray(model.frames[model.getFrameId(fname)].placement.translation, dtype=float)
        if not chain:
            balls.append((offset, 0.0))
            continue
        radius = float(np.linalg.norm(offset))
        radius += sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in chain[1:])
        radius += sum(float(travel[tree.joints[j].q_index]) for j in chain if tree.joints[j].kind == "prismatic")
        balls.append((np.asarray(model.jointPlacements[chain[0]].translation, dtype=float), radius))
    return balls


def _unreachable(ocp: ReachingOCP, tol: float) -> str | None:
    """A certificate that no configuration within the limits reaches ‖e‖ < tol, or None.

    ‖e‖ = 0 puts every end point on the target primitive X_d = V_Sd X_u Ṽ_Sd (the cooperative primitive passes through
    them, and e = 0 makes it X_d).  If X_d does not meet the ball that contains every position of some end point
    (:func:`_reach_balls`), no configuration reaches the target.  ‖e‖ < tol moves the end points off X_d by at most
    ~tol·(s + 2L) (s the target's scale, L their distance from its centre), so the certificate asks for a gap of ten
    times that; it is off for the least-squares kinds (their points need not lie on the primitive) and for tol > 0.1.
    Cost: microseconds (no task evaluation).
    """
    kind = getattr(ocp.task, "kind", None)
    balls = _reach_balls(ocp) if kind in ("point", "point_pair", "line", "circle", "plane", "sphere") else None
    if balls is None or tol > 0.1:
        return None
    t, Rm, s = ocp.target.translation, ocp.target.rotation_matrix, float(ocp.target.scale)
    for i, (c, r) in enumerate(balls):
        if not np.isfinite(r):
            continue
        gap = s * _unit_distance(str(kind), Rm.T @ (c - t) / s) - r  # [m] between the ball and X_d
        margin = 10.0 * max(tol, 1e-3) * (s + 2.0 * (float(np.linalg.norm(c - t)) + r))
        if gap > margin:
            frame = ocp.task.tree.end_frames[i]
            return (
                f"unreachable: the target {kind} passes {gap:.3g} m outside the reach of end point {i} ('{frame}'), "
                f"a ball of radius {r:.3g} m about its chain's first joint that holds every position it can take, so "
                "the target is not reachable inside the limits from this start (nor from any other)"
            )
    return None


# ============================================================================ solver
def ilqr_reach(
    task: Any,
    q_init: Any,
    target: Any,
    options: ILQROptions | None = None,
    *,
    qd_init: Any = None,
    u_init: Any = None,
    **overrides: Any,
) -> ILQRResult:
    """Reach the target similarity ``V_Sd`` within the joint limits by iLQR on Eq 53–57 (module docstring).

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.
    q_init: (nq,) initial configuration [rad]; the system starts at rest unless ``qd_init``.
    target: V_Sd, a :class:`~coop_ga.Similarity` of the task's kind (e.g. from :func:`displaced_target`).
    options: :class:`ILQROptions` (problem and solver settings); keyword ``overrides``
        replace its fields (``ilqr_reach(task, q, V, max_iter=20)``).
    qd_init: (nq,) initial joint velocity [rad/s] (default 0).
    u_init: (n, nq) initial control guess [rad/s²] (default: rest, or braking to rest).

    Returns
    -------
    :class:`ILQRResult`; every returned trajectory satisfies the bounds (module docstring).

    Raises
    ------
    InvalidInputError: wrong shapes or values (q_init size, weights, horizon, target, …), or
        (``limits="enforce"``) a start state outside the limits.
    NonFiniteError: NaN/inf in q_init, qd_init, u_init or an option.
    DegeneratePrimitiveError: the primitive is degenerate at ``q_init``.

    Timing: before the clock starts, the task's compiled error function is evaluated once
    at ``q_init`` (generated and compiled by gcc on the first call per task — ~1–2 s, cached
    on disk — which also validates the inputs), and the Newton model's second-order function
    is built (~0.2 s, once per task and process); ``solve_time_s`` covers everything else.
    """
    o = resolve_options(ILQROptions, options, overrides, "ilqr_reach")
    ocp = ReachingOCP(
        task,
        q_init,
        target,
        qd_init=qd_init,
        horizon=o.horizon,
        dt=o.dt,
        R=o.R,
        Q=o.Q,
        Qv=o.Qv,
        limits=o.limits,
        clearance=o.clearance,
    )
    if o.limits == "enforce":
        lim = task.system.limits
        if lim.position_violation(ocp.q_init) > 1e-9:
            raise InvalidInputError(
                f"q_init is outside the joint limits ({lim.describe(ocp.q_init, 1e-9)}); move it "
                "inside, or pass limits='none' to solve without bounds"
            )
        if lim.velocity_violation(ocp.qd_init) > 1e-9:
            raise InvalidInputError("qd_init exceeds the velocity limits; lower it, or pass limits='none'")
    with collect_warnings() as caught:
        unreachable = _unreachable(ocp, o.tol)
        if unreachable is not None:  # certified: no iteration can help (module docstring, "Fast honest failure")
            t_start = time.perf_counter()
            u_ref = _reference_controls(ocp)
            return _finish(ocp, o, u_ref, u_ref, _Progress(t_start=t_start, message=unreachable), caught.counts)
        res = _solve(ocp, o, u_init, caught.counts)
        # restart only a solve that stalled (not one that ran out of its iteration budget, not an
        # unreachable tol = 0, not a user's own initial guess)
        stalled = "max_iter" not in res.message and res.iterations < o.max_iter
        if res.converged or u_init is not None or not o.restart or not stalled or o.tol == 0:
            return res
        # Globalisation.  A failed solve usually stalls on a local minimum of the bounded terminal problem
        # (joints pressed on their limits, ‖e‖ ~ 1e-2).  The bounded Gauss–Newton IK reaches the target
        # inside the limits more often from q_init; restart from the minimum-energy controls to its answer
        # (rest-to-rest they are cubics, monotone between the bounds) and keep the better result.
        from .gauss_newton import gauss_newton_ik

        with collect_warnings(silent=True):
            ik = gauss_newton_ik(task, ocp.q_init, ocp.target, limits=o.limits)
        if not ik.converged:
            return res
        u_guess = _controls_to(ocp, ik.q)
        if o.limits == "enforce" and ocp.violation(*ocp.rollout(u_guess), u_guess) > 0:
            blended = _restore(ocp, u_guess, _reference_controls(ocp))  # e.g. a moving start overshoots a bound
            if blended is not None:
                u_guess = blended[0]
        o2 = dataclasses.replace(o, max_iter=max(o.max_iter - res.iterations, 1))
        res2 = _solve(ocp, o2, u_guess, caught.counts)
        if not (res2.converged or res2.error < res.error):
            return res
        return dataclasses.replace(
            res2,
            iterations=res.iterations + res2.iterations,
            solve_time_s=res.solve_time_s + res2.solve_time_s,
            stats=res.stats + res2.stats,
            # the histories of both solves (the restart's own starting point left out, so len = iterations + 1)
            cost_history=np.concatenate([res.cost_history, res2.cost_history[1:]]),
            error_history=np.concatenate([res.error_history, res2.error_history[1:]]),
            message=f"{res2.message} (restarted after {res.iterations} iterations from the minimum-energy controls "
            f"to the bounded Gauss–Newton IK configuration, ‖e‖ = {res.error:.3g} before)",
        )


def _controls_to(ocp: ReachingOCP, q_goal: np.ndarray) -> np.ndarray:
    """Minimum-energy controls (n, nq) taking (q_init, q̇_init) to (q_goal, 0) (closed form via the Gramian)."""
    n, dt, T = ocp.nq, ocp.dt, ocp.horizon
    ck, G2, R2inv = _gramian(ocp)
    Winv = np.kron(np.linalg.inv(G2), ocp.R2)
    free = np.concatenate([ocp.q_init + T * dt * ocp.qd_init, ocp.qd_init])  # the drift with u = 0
    y = np.concatenate([q_goal, np.zeros(n)]) - free
    lam = Winv @ y
    return np.outer(ck, R2inv @ lam[:n]) + dt * (R2inv @ lam[n:])[None, :]


def _multiplier_estimate(ocp: ReachingOCP, ev: dict[str, Any], ck: np.ndarray) -> np.ndarray:
    """Least-squares multiplier w (7,) of the reaching condition from stationarity of the running cost.

    ``2R u_k + Bᵀλ_{k+1} = 0`` with ``λ_n = [J_eᵀ w; 2Q_v q̇_n]`` and ``λ_k = Aᵀλ_{k+1}`` gives
    ``2R u_k + c_k J_eᵀ w + 2Δt Q_v q̇_n = 0`` for every k; w minimises the residual over k.
    (At the optimum it is the exact multiplier; unlike the penalty's own ``2Q(e + s)`` it does
    not overshoot far from the optimum, where Q ≫ the multiplier.)  The AL state terms are
    left out: they are zero unless a bound is active.
    """
    u, Je, qdn = ev["u"], ev["Je"], ev["qd"][-1]
    b = u @ ocp.R2.T + (2.0 * ocp.dt) * (ocp.Qv @ qdn)[None, :]  # (T, n): 2R u_k + 2Δt Q_v q̇_n
    # controls at their acceleration bound are not stationary: leave them out, joint by joint
    free = ~(np.abs(u) >= ocp.a_max * (1.0 - 1e-9)) if ocp.u_bounded else np.ones(u.shape, dtype=bool)
    c = ck[:, None] * free
    W = np.sum(c * c, axis=0)  # (n,): information about joint j's multiplier
    abar = np.where(W > 0, np.sum(c * b, axis=0) / np.where(W > 0, W, 1.0), 0.0)
    sw = np.sqrt(W / max(float(W.max()), 1e-300))
    # joints at a terminal position bound carry their own multiplier ν_j (unknowns beside w)
    qn = ev["q"][-1]
    at = np.flatnonzero((qn <= ocp.q_lower + 1e-9) | (qn >= ocp.q_upper - 1e-9))
    A = Je.T if not at.size else np.hstack([Je.T, np.eye(ocp.nq)[:, at]])
    return -np.linalg.lstsq(sw[:, None] * A, sw * abar, rcond=1e-10)[0][:7]


def _terminal_model(ocp: ReachingOCP, ev: dict[str, Any], w: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Gradient (2nq) and Hessian (2nq × 2nq) of the (shifted) terminal cost at ev's x_n; with a
    multiplier w, the Newton model ``2J_eᵀQJ_e + ∇²_q(wᵀe)``, else Gauss–Newton."""
    n = ocp.nq
    Je, es, qdn = ev["Je"], ev["es"], ev["qd"][-1]
    H = np.zeros((2 * n, 2 * n))
    H[:n, :n] = 2.0 * Je.T @ (ocp.Q @ Je)
    H[n:, n:] = 2.0 * ocp.Qv
    if w is not None and np.any(w != 0):
        H[:n, :n] += ocp.task.error_hessian(ev["q"][-1], ocp.target, w)
    g = np.concatenate([2.0 * Je.T @ (ocp.Q @ es), 2.0 * ocp.Qv @ qdn])
    return g, H


def _solve(ocp: ReachingOCP, o: ILQROptions, u_init: Any, warning_counts: dict[str, int]) -> ILQRResult:
    task = ocp.task
    n = ocp.nq
    u_ref = _reference_controls(ocp)
    u = u_ref.copy() if u_init is None else ocp.check_controls(u_init).copy()
    if u_init is not None and ocp.u_bounded:
        u = np.clip(u, -ocp.a_max, ocp.a_max)
    task.error_and_jacobian(ocp.q_init, ocp.target)  # build/compile once, outside the timed solve
    if o.hessian == "newton":
        task.graph.error_hessian_function  # noqa: B018  (built once per task, outside the timed solve)

    t_start = time.perf_counter()
    ck, G2, R2inv = _gramian(ocp)
    Winv = np.kron(np.linalg.inv(G2), ocp.R2)  # inverse Gramian of x_n (metric (2R)⁻¹)
    wmin = float(np.linalg.eigvalsh(Winv)[0])
    eye2 = np.eye(2 * n)
    bounded = o.limits == "enforce" and bool(np.any(np.isfinite(ocp.q_lower)) or np.any(np.isfinite(ocp.v_max)))
    # AL terms from the start: zero while feasible, a penalty as soon as a bound is crossed
    merit = _Merit(ocp, o.al_penalty if bounded else 0.0)
    ev = merit.evaluate(u)
    if ev is None:
        q_g, _ = ocp.rollout(u)
        ocp.task.error_and_jacobian(q_g[-1], ocp.target)  # re-raises the task's degeneracy error
        raise DegeneratePrimitiveError("the initial guess reaches a degenerate primitive")
    costs = [ev["cost"]]
    errs = [float(np.linalg.norm(ev["e"]))]
    stats: list[ILQRIteration] = []
    it = 0
    outer = 0
    message = ""
    rho_x = 0.0  # LM damping of the state deviations in the Riccati pass (adapted by the step quality)
    lm = 0.0  # LM damping of the terminal model (adapted by the step quality)

    prev_violation = np.inf

    def reached(ev: dict[str, Any]) -> bool:
        return float(np.linalg.norm(ev["e"])) < o.tol

    def done(ev: dict[str, Any]) -> bool:
        # a violation ≤ al_violation is removed exactly by the final blend with the feasible reference
        return float(np.linalg.norm(ev["e"])) < o.tol and ev["violation"] <= o.al_violation

    finished = done(ev)
    if finished:
        message = "initial guess already within tol"
    while not finished and outer < o.max_outer:
        # ------------------------------------------------------------ inner iLQR on the augmented merit
        inner_stalled = False
        while it < o.max_iter:
            t_it = time.perf_counter()
            e_norm = float(np.linalg.norm(ev["e"]))
            newton = o.hessian == "newton" and e_norm < o.newton_switch
            w = _multiplier_estimate(ocp, ev, ck) if newton else None
            shift_estimated = False
            if w is not None and o.terminal == "constraint" and e_norm < 100.0 * o.tol and ev["violation"] == 0.0:
                shift_estimated = True
                # the penalty's optimum keeps e = (2Q)⁻¹λ_e − s; with the multiplier estimate w ≈ λ_e, the shift
                # s = (2Q)⁻¹w puts that optimum at e = 0 now instead of after a stalled inner solve
                s_new = np.linalg.lstsq(2.0 * ocp.Q, w, rcond=1e-12)[0]
                if np.all(np.isfinite(s_new)):
                    merit.shift = s_new
                    ev_s = merit.evaluate(u)
                    assert ev_s is not None  # the same trajectory
                    ev = ev_s
            gf, Hf = _terminal_model(ocp, ev, w)
            lx, lxx, bar_active = merit.state_terms(ev)
            if bar_active:
                newton = False  # the multiplier estimate ignores the AL terms: Gauss–Newton while a bound is active
                gf, Hf = _terminal_model(ocp, ev, None)
            if bar_active and rho_x > 0:
                # Levenberg–Marquardt on the states (a trust region on δx at every knot)
                lxx = lxx + rho_x if lxx.ndim == 2 else lxx + rho_x * eye2
            vx = gf + lx[-1]
            Hf_b = Hf.copy()
            _add_state_hessian(Hf_b, lxx[-1])
            hscale = max(float(np.linalg.norm(Hf_b, 2)), 1e-12)
            models: list[tuple[str, float]] = []
            if newton:
                # convexify: the condensed Hessian W⁻¹ + H_f must be positive definite; lift its smallest
                # eigenvalue to λ_min(W⁻¹) (the running cost's own stiffness at x_n) where it is not
                lmin = float(np.linalg.eigvalsh(Winv + Hf_b)[0])
                base = max(0.0, wmin - lmin)
                models += [("newton", base + lm), ("newton", base + lm + wmin), ("newton", base + lm + 16.0 * wmin)]
            models += [("gauss_newton", lm)]
            models += [("gauss_newton", lm + 10.0**p * hscale) for p in range(-6, 3)]
            accepted = None
            n_back = 0
            mode_used, mu_used, kind_used = models[0][0], 0.0, "riccati"
            for mode, mu in models:
                Vxx = (Hf_b if mode == "newton" or not newton else _gn_only(ocp, ev, lxx[-1])) + mu * eye2
                n_back += 1
                step = _lq_step(ocp, o, u, ev, Vxx, vx, lx, lxx, bar_active, ck, R2inv, Winv)
                if step is None:
                    continue
                kind, propose, d1, d2 = step
                if not d1 < 0:
                    continue
                # trust region on joint travel: the α = 1 step's largest joint motion along the trajectory
                u1 = propose(1.0)
                q1, _ = ocp.rollout(u1)
                travel = float(np.max(np.abs(q1 - ev["q"])))
                alpha = min(1.0, o.max_travel / travel) if travel > 0 else 1.0
                trials = 0
                for b in range(o.max_backtracks + 1):
                    trials += 1
                    u_t = u1 if alpha == 1.0 else propose(alpha)
                    ev_t = merit.evaluate(u_t)  # None: degenerate
                    expected = alpha * d1 + alpha * alpha * d2
                    if ev_t is not None and ev_t["merit"] <= ev["merit"] + o.armijo * min(expected, 0.0):
                        accepted = (alpha, ev_t, expected, trials, travel)
                        break
                    if b == 0 and o.soc and ev_t is not None and kind == "condensed":
                        # second-order correction (the Maratos effect: the stiff terminal penalty rejects good
                        # steps whose error is second order): the minimum-energy change of u that cancels the
                        # linearised terminal error at the trial point and keeps q̇_n, in closed form
                        u_c = _second_order_correction(ocp, ev_t, ck, G2, R2inv)
                        ev_c = merit.evaluate(u_c) if u_c is not None else None
                        trials += 1
                        if (
                            ev_c is not None
                            and ev_c["violation"] <= ev["violation"]
                            and ev_c["merit"] <= ev["merit"] + o.armijo * min(expected, 0.0)
                        ):
                            accepted = (alpha, ev_c, expected, trials, travel)
                            break
                    alpha *= 0.5
                if accepted is not None:
                    mode_used, mu_used, kind_used = mode, mu, kind
                    break
            if accepted is None:
                inner_stalled = True
                message = (
                    "no descent step found (stationary point of the merit or line-search failure): the "
                    "terminal error cannot be reduced further from here"
                )
                break
            alpha, ev_t, expected, trials, travel = accepted
            decrease = ev["merit"] - ev_t["merit"]
            # Levenberg–Marquardt on the terminal model (a trust region in x_n): a step whose decrease is far
            # below the model's, or that had to be cut, asks for more damping; a good full step for less
            ratio_t = decrease / max(-expected, 1e-300)
            if ratio_t < 0.25 or alpha < 1.0:
                lm = max(4.0 * lm, wmin) if lm < 1e6 * hscale else lm
            elif ratio_t > 0.75:
                lm = lm / 4.0 if lm / 4.0 >= wmin else 0.0
            if kind_used == "riccati":
                ratio = decrease / max(-expected, 1e-300)
                if alpha < 1.0 or ratio < 0.25:  # a poor model: damp the state deviations more
                    rho_x = max(4.0 * rho_x, wmin)
                elif ratio > 0.5:
                    rho_x = rho_x / 4.0 if rho_x / 4.0 >= wmin else 0.0
            ev = ev_t
            u = ev["u"]
            it += 1
            costs.append(ev["cost"])
            errs.append(float(np.linalg.norm(ev["e"])))
            stats.append(
                ILQRIteration(
                    cost=ev["cost"],
                    error=errs[-1],
                    alpha=alpha,
                    mu=mu_used,
                    expected_decrease=-expected,
                    actual_decrease=decrease,
                    line_search_trials=trials,
                    backward_passes=n_back,
                    time_s=time.perf_counter() - t_it,
                    model=mode_used,
                    merit=ev["merit"],
                    outer=outer,
                    violation=ev["violation"],
                    travel=alpha * travel,
                    backward=kind_used,
                )
            )
            if done(ev):
                finished = True
                break
            if decrease <= o.ftol * max(abs(ev["merit"]), 1e-300):
                inner_stalled = True
                break
            # near the target the penalty's own optimum keeps e ≈ λ_e/(2Q): once a Newton step no longer halves
            # ‖e‖, shift the terminal target (the multiplier update) instead of creeping toward that optimum
            if (
                o.terminal == "constraint"
                and newton
                and errs[-1] < 100.0 * o.tol
                and errs[-1] > 0.5 * errs[-2]
                and ev["violation"] <= o.al_violation
                and not shift_estimated
            ):
                break
            # the AL subproblem is solved well enough: update the multipliers now (the penalty optimum keeps a
            # violation ~ λ*/μ that only the outer update removes)
            if ev["violation"] > o.al_violation and (reached(ev) or decrease <= o.al_inner_tol * abs(ev["merit"])):
                break
        if finished or it >= o.max_iter:
            if not finished:
                message = f"max_iter ({o.max_iter}) reached"
            break
        # ------------------------------------------------------------ outer update: multipliers, penalty, shift
        outer += 1
        changed = False
        viol = ev["violation"]
        if merit.mu > 0:
            new_lam = np.maximum(0.0, merit.lam + merit.mu * ev["c"])
            changed = not np.allclose(new_lam, merit.lam, rtol=0.0, atol=1e-12)
            merit.lam = new_lam
            if viol > o.al_violation and viol > 0.25 * prev_violation and merit.mu < o.al_max_penalty:
                merit.mu = min(merit.mu * o.al_growth, o.al_max_penalty)
                changed = True
        prev_violation = viol
        if o.terminal == "constraint" and not reached(ev):
            merit.shift = merit.shift + ev["e"]
            changed = True
        if not changed:
            if inner_stalled and o.terminal == "soft":
                message = (
                    "stationary: the optimum of the soft terminal cost (Eq 57) keeps ‖e‖ above tol; use "
                    "terminal='constraint' (the default) or raise Q relative to R"
                )
            elif inner_stalled:
                message = (
                    "stationary: the optimum within the limits is reached but the terminal error stays above "
                    "tol (the target is not reachable inside the limits from here)"
                )
            break
        ev_new = merit.evaluate(u)
        assert ev_new is not None  # the same trajectory
        ev = ev_new
    else:
        if not finished:
            message = f"max_outer ({o.max_outer}) outer iterations reached"
    progress = _Progress(
        t_start=t_start, costs=costs, errs=errs, stats=stats, iterations=it, outer=outer, message=message
    )
    return _finish(ocp, o, u, u_ref, progress, warning_counts)


@dataclass
class _Progress:
    """What a solve reports besides its final controls: histories, counters, the reason it stopped."""

    t_start: float
    costs: list[float] = field(default_factory=list)
    errs: list[float] = field(default_factory=list)
    stats: list[ILQRIteration] = field(default_factory=list)
    iterations: int = 0
    outer: int = 0
    message: str = ""


def _finish(
    ocp: ReachingOCP,
    o: ILQROptions,
    u: np.ndarray,
    u_ref: np.ndarray,
    progress: _Progress,
    warning_counts: dict[str, int],
) -> ILQRResult:
    """The result of a solve that ended at ``u``: the feasibility blend with ``u_ref``, the re-evaluated terminal error
    and cost, the limit checks, the verdict and its message."""
    task = ocp.task
    solve_time = time.perf_counter() - progress.t_start
    message = progress.message or "stopped"

    # ---------------------------------------------------------------- feasibility of what is returned
    beta = 0.0
    if o.limits == "enforce":
        restored = _restore(ocp, u, u_ref)
        if restored is not None:
            u, beta = restored
            if beta > 0:
                message += f"; blended with the feasible reference (β = {beta:.2e}) to satisfy the bounds exactly"
        else:  # the reference is not strictly feasible as a whole (e.g. at rest on a position bound)
            restored = _restore_joints(ocp, u, u_ref)
            if restored is None:
                message += (
                    "; the start state cannot be kept inside the limits (a joint moves out through a bound faster "
                    "than its acceleration limit can stop it): the trajectory may violate them"
                )
            else:
                u, beta = restored
                if beta > 0:
                    message += (
                        f"; blended joint by joint with feasible references (largest β = {beta:.2e}) to satisfy "
                        "the bounds exactly"
                    )
    q, qd = ocp.rollout(u)
    # the reported error is re-evaluated at the re-integrated terminal state (and re-checks degeneracy)
    lf, e, _ = ocp.terminal(q[-1], qd[-1])
    c_cost = ocp.clearance_cost(q)
    cost = ocp.running_cost(u) + lf + c_cost
    min_clear = (
        float(min(ocp.clearance.evaluate(qk, hessian=False)[3] for qk in q)) if ocp.clearance is not None else np.inf
    )
    # the last iterate's entries re-evaluated (an early exit has no history yet: its only entry)
    costs = [*progress.costs[:-1], cost]
    errs = [*progress.errs[:-1], float(np.linalg.norm(e))]
    lim = task.system.limits
    pviol = lim.position_violation(q)
    vviol = lim.velocity_violation(qd)
    aviol = lim.acceleration_violation(u)
    if o.limits == "none" and pviol > 0 and o.warn_limits:
        warn(
            f"iLQR trajectory leaves the joint limits by up to {pviol:.3g} rad (limits='none': not enforced)",
            JointLimitWarning,
            key=task.name,
        )
    feasible = o.limits == "none" or (pviol <= 1e-9 and vviol <= 1e-9 and aviol <= 1e-9)
    # every iterate is the result of a step accepted on the true merit (or the initial guess)
    converged = bool(errs[-1] < o.tol and feasible)
    active = _active(ocp, q, qd, u, tol=1e-3) if o.limits == "enforce" else ()
    if converged:
        message = (
            "converged: terminal error below tol within the limits"
            if o.limits == "enforce"
            else "converged: terminal error below tol (limits not enforced)"
        )
    else:
        message = f"not converged: {message}; ‖e‖ = {errs[-1]:.3g}" + (
            f"; bounds within 1e-3 of active: {'; '.join(active[:6])}{' …' if len(active) > 6 else ''}"
            if active
            else ""
        )
    return ILQRResult(
        converged=converged,
        error=errs[-1],
        iterations=progress.iterations,
        message=message,
        q=q[-1].copy(),
        warnings=warning_counts,
        trajectory=q,
        qd=qd,
        u=u,
        t=ocp.times,
        error_vector=e.copy(),
        terminal_speed=float(np.linalg.norm(qd[-1])),
        cost=cost,
        cost_history=np.array(costs),
        error_history=np.array(errs),
        solve_time_s=solve_time,
        stats=tuple(progress.stats),
        joint_limit_violation=pviol,
        velocity_violation=vviol,
        acceleration_violation=aviol,
        active_constraints=active,
        outer_iterations=progress.outer,
        restoration=beta,
        dt=ocp.dt,
        target=ocp.target,
        hessian=o.hessian,
        clearance_cost=c_cost,
        min_clearance=min_clear,
    )


def _second_order_correction(
    ocp: ReachingOCP, ev: dict[str, Any], ck: np.ndarray, G2: np.ndarray, R2inv: np.ndarray
) -> np.ndarray | None:
    """Controls ``u − δu_c`` with the minimum-energy δu_c such that ``J_e δq_n = e_s`` and ``δq̇_n = 0`` (e_s the
    shifted terminal error at ev); None if the trajectory then leaves the bounds."""
    n, dt = ocp.nq, ocp.dt
    Je, es, u = ev["Je"], ev["es"], ev["u"]
    Cw = np.block([[G2[0, 0] * Je @ R2inv @ Je.T, G2[0, 1] * Je @ R2inv], [G2[1, 0] * R2inv @ Je.T, G2[1, 1] * R2inv]])
    y = np.linalg.lstsq(Cw, np.concatenate([es, np.zeros(n)]), rcond=1e-12)[0]
    a_q = R2inv @ (Je.T @ y[:7])
    a_v = R2inv @ y[7:]
    u_c = u - (np.outer(ck, a_q) + dt * a_v[None, :])
    q_c, qd_c = ocp.rollout(u_c)
    if ocp.limits == "enforce" and ocp.violation(q_c, qd_c, u_c) > 1e-12:
        return None
    return u_c


def _gn_only(ocp: ReachingOCP, ev: dict[str, Any], lxx_n: np.ndarray) -> np.ndarray:
    """Gauss–Newton terminal Hessian plus the knot-n AL Hessian."""
    n = ocp.nq
    Je = ev["Je"]
    H = np.zeros((2 * n, 2 * n))
    H[:n, :n] = 2.0 * Je.T @ (ocp.Q @ Je)
    H[n:, n:] = 2.0 * ocp.Qv
    _add_state_hessian(H, lxx_n)
    return H


def _condensed_box_step(
    ocp: ReachingOCP,
    u: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    ck: np.ndarray,
    R2inv: np.ndarray,
    Winv: np.ndarray,
) -> tuple[np.ndarray, float, float, np.ndarray] | None:
    """The LQ step over the terminal state with the terminal bounds, in closed form otherwise.

    For a terminal state ``y = Σ_k G_k ũ_k`` (relative to the free drift) the cheapest controls
    are the minimum-energy ones, ``ũ_k = (2R)⁻¹ G_kᵀ W⁻¹ y`` (u affine in time: every joint
    moves on a cubic), with running cost ``½ yᵀ W⁻¹ y``.  The LQ subproblem therefore reduces
    to a 2nq-dimensional QP in ``δx_n = y − s`` (``s = Σ G_k u_k``):
    ``min ½ δxᵀ(W⁻¹ + V_xx)δx + (W⁻¹ s + v_x)ᵀ δx`` over the box of the position and velocity
    limits of x_n (:func:`_box_qp`).  Rest-to-rest cubics are monotone, so the terminal bounds
    are usually all the path constraints there are; the caller checks every knot.
    Returns ``(δu, d1, d2, δx_n)`` (predicted change ``α d1 + α² d2``) or None if not convex.
    """
    n, dt = ocp.nq, ocp.dt
    H = Winv + Vxx
    try:
        np.linalg.cholesky(H)
    except np.linalg.LinAlgError:
        return None
    svec = np.concatenate([ck @ u, dt * u.sum(axis=0)])
    g = Winv @ svec + vx
    xn = np.concatenate([q[-1], qd[-1]])
    margin = 1e-13 * (1.0 + np.abs(xn))  # keep x_n a hair inside, so round-off cannot put it outside
    lo = np.concatenate([ocp.q_lower, -ocp.v_max]) - xn + margin
    hi = np.concatenate([ocp.q_upper, ocp.v_max]) - xn - margin
    lo, hi = np.minimum(lo, 0.0), np.maximum(hi, 0.0)  # the current x_n is inside (or the AL path is used)
    dx0 = -np.linalg.solve(H, g)
    dx = dx0 if np.all((dx0 >= lo) & (dx0 <= hi)) else _box_qp(H, g, lo, hi, np.clip(dx0, lo, hi))[0]
    lam = Winv @ (svec + dx)
    du = (np.outer(ck, R2inv @ lam[:n]) + dt * (R2inv @ lam[n:])[None, :]) - u
    Ru = u @ ocp.R
    d1 = 2.0 * float(np.sum(Ru * du)) + float(vx @ dx)
    d2 = float(np.einsum("ki,ij,kj->", du, ocp.R, du)) + 0.5 * float(dx @ Vxx @ dx)
    return du, d1, d2, dx


def _control_box_step(
    ocp: ReachingOCP, u: np.ndarray, Vxx: np.ndarray, vx: np.ndarray, ck: np.ndarray, max_iter: int = 50
) -> tuple[np.ndarray, float, float] | None:
    """The LQ step with the acceleration bounds, exactly, by projected Newton over the whole control sequence.

    With linear dynamics the LQ subproblem is the QP ``min ½ δuᵀ H δu + gᵀ δu`` over the box
    ``−a − u_k ≤ δu_k ≤ a − u_k`` with ``H = 2R ⊗ I_n + Gᵀ V_xx G`` (G: δu → δx_n, rank 2nq) and
    ``g_k = 2R u_k + G_kᵀ v_x`` — Tassa et al.'s box QP, solved for all knots at once instead of
    knot by knot (their per-knot QP clamps the feedforward at δx = 0, which with the stiff terminal
    cost saturates the last knots for nothing).  Newton steps on the free set use the Woodbury
    identity (``2R`` diagonal plus a rank-2nq term): O(n·nq·nq) per iteration.  Requires a
    diagonal R; returns ``(δu, d1, d2)`` or None (not convex, or R not diagonal).
    """
    n, dt = ocp.nq, ocp.dt
    r2 = np.diag(ocp.R2)
    if not np.allclose(ocp.R2, np.diag(r2)) or not np.all(r2 > 0):
        return None
    lo, hi = -ocp.a_max - u, ocp.a_max - u

    def G(v: np.ndarray) -> np.ndarray:  # (T, n) → δx_n (2n)
        return np.concatenate([ck @ v, dt * v.sum(axis=0)])

    def GT(y: np.ndarray) -> np.ndarray:  # 2n → (T, n)
        return np.outer(ck, y[:n]) + dt * y[n:][None, :]

    g = u * r2 + GT(vx)

    def f_grad(x: np.ndarray) -> tuple[float, np.ndarray]:
        y = G(x)
        Vy = Vxx @ y
        return float(0.5 * np.sum(x * x * r2) + 0.5 * y @ Vy + np.sum(g * x)), x * r2 + GT(Vy) + g

    x = np.zeros_like(u)
    f, grad = f_grad(x)
    eye = np.eye(2 * n)
    for _ in range(max_iter):
        clamped = ((x <= lo) & (grad > 0)) | ((x >= hi) & (grad < 0))
        free = ~clamped
        # Newton direction on the free set: (D + Gfᵀ V Gf) d = −grad_f, D = 2R (diagonal)
        dinv = np.where(free, 1.0 / r2, 0.0)
        rhs = -np.where(free, grad, 0.0)
        a = dinv * rhs
        # Gf D⁻¹ Gfᵀ (2n × 2n): blocks over the free entries
        ckf = ck[:, None] * dinv  # (T, n)
        S11 = np.diag((ck[:, None] * ckf).sum(axis=0))
        S12 = np.diag(dt * ckf.sum(axis=0))
        S22 = np.diag(dt * dt * dinv.sum(axis=0))
        M = np.block([[S11, S12], [S12, S22]])
        try:
            z = np.linalg.solve(eye + Vxx @ M, Vxx @ G(a))
        except np.linalg.LinAlgError:
            return None
        d = a - dinv * GT(z)
        if float(np.max(np.abs(d))) < 1e-14 * (1.0 + float(np.max(np.abs(x)))):
            break
        step = 1.0
        while True:  # projected Armijo line search
            xn = np.clip(x + step * d, lo, hi)
            fn, gn = f_grad(xn)
            if fn - f <= 0.1 * float(np.sum(grad * (xn - x))) or step < 1e-10:
                break
            step *= 0.5
        converged = f - fn <= 1e-14 * (1.0 + abs(f))
        x, f, grad = xn, fn, gn
        if converged:
            break
    if not f < 0:
        return None
    y = G(x)
    d1 = float(np.sum(g * x))
    d2 = float(0.5 * np.sum(x * x * r2) + 0.5 * y @ Vxx @ y)
    return x, d1, d2


def _lq_step(
    ocp: ReachingOCP,
    o: ILQROptions,
    u: np.ndarray,
    ev: dict[str, Any],
    Vxx: np.ndarray,
    vx: np.ndarray,
    lx: np.ndarray,
    lxx: np.ndarray,
    state_terms: bool,
    ck: np.ndarray,
    R2inv: np.ndarray,
    Winv: np.ndarray,
):
    """One LQ step: ``(kind, propose(α) → u_trial, d1, d2)`` or None if the model is not convex.

    ``"condensed"`` (:func:`_condensed_box_step`) when no AL term is active and the full step's
    trajectory is inside every bound (then every α ∈ [0, 1] is: the bounds are linear in u);
    else ``"riccati"`` (:func:`_backward_box` with the AL terms and the control box).
    """
    if o.backward == "auto" and not state_terms:
        step = _condensed_box_step(ocp, u, ev["q"], ev["qd"], Vxx, vx, ck, R2inv, Winv)
        if step is None:
            return None
        du, d1, d2, _ = step
        q1, qd1 = ocp.rollout(u + du)
        if ocp.violation(q1, qd1, u + du) <= 1e-12:  # round-off at a bound the box QP put x_n on
            return "condensed", (lambda a, du=du: u + a * du), d1, d2
        if ocp.u_bounded and ocp.violation(q1, qd1) <= 1e-12:  # only the acceleration bounds are in the way
            cstep = _control_box_step(ocp, u, Vxx, vx, ck)
            if cstep is not None:
                du, d1, d2 = cstep
                q1, qd1 = ocp.rollout(u + du)
                if ocp.violation(q1, qd1) <= 1e-12:
                    return "condensed", (lambda a, du=du: u + a * du), d1, d2
    box = ocp.u_bounded
    try:
        kff, Kfb, d1, d2 = _backward_box(ocp, u, Vxx, vx, lx, lxx, box=box)
    except np.linalg.LinAlgError:
        return None
    # the α = 1 roll-out of the box-DDP policy, then u + α (u₁ − u): with linear dynamics this is the policy's
    # own roll-out wherever no control clips, it stays inside the control box (both ends are), and it avoids the
    # high feedback gains of the stiff terminal cost amplifying a clipped control into the last knots
    u1 = _policy_rollout(ocp, u, kff, Kfb, 1.0)
    du = u1 - u
    return "riccati", (lambda a, du=du: u + a * du), d1, d2
