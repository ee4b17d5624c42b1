"""Reference solvers for the constrained reaching OCP: CasADi Opti + IPOPT and FATROP (Eq 53–57 with 𝒳, 𝒰).

The problem
-----------
The :class:`~coop_ga.control.ilqr.ReachingOCP` of Eq 53–57 — double integrator
``x_k = [q_k; q̇_k]`` (2·nq), ``u_k = q̈_k`` (nq), exact zero-order hold (Eq 54)::

    q_{k+1} = q_k + Δt q̇_k + ½Δt² u_k,      q̇_{k+1} = q̇_k + Δt u_k,      x_0 = [q_init; q̇_init],

    min  Σ_{k<n} u_kᵀ R u_k + e(q_n)ᵀ Q e(q_n) + q̇_nᵀ Q_v q̇_n,     e(q) = log(Ṽ_Sc(q) V_Sd)  (Eq 44, 56, 57)

plus the bounds (𝒳, 𝒰 of Eq 53) of a :class:`~coop_ga.systems.limits.JointLimits`, at every knot:

    lower ≤ q_k ≤ upper,   |q̇_k| ≤ velocity      (k = 1 … n),
    |u_k| ≤ acceleration                           (k = 0 … n−1),

joint by joint, infinite bounds left out (the initial state is data, not constrained).
``terminal="constraint"`` replaces the soft terminal term by the equality ``e(q_n) = 0``
(the objective is then ``Σ u_kᵀ R u_k + q̇_nᵀ Q_v q̇_n``) — the problem the iLQR solves with
``terminal="constraint"``.

Free flyers (nq ≠ nv).  A system with a floating base is posed as a :class:`TangentReachingOCP`:
the state is ``x_k = [q_k (nq); v_k (nv)]``, ``u_k`` (nv), and the double integrator runs on
the configuration manifold,

    q_{k+1} = q_k ⊕ (Δt v_k + ½Δt² u_k),      v_{k+1} = v_k + Δt u_k,

``⊕`` being ``pinocchio.integrate`` written in CasADi exactly
(:func:`~coop_ga.kinematics.chains.integrate_symbolic`: the SE(3) exponential of the flyer's LOCAL
velocity, a Taylor series near ω = 0), so the quaternions of the knots stay unit through the
gap-closing equalities and no norm constraint is needed.  The position bounds are on the joints'
coordinates only (a velocity row's q index; the flyer has none), the velocity and acceleration
bounds on v and u.  A :class:`~coop_ga.control.ilqr.ReachingOCP` of such a system is refused
(its q̇ has nq entries).  With nq = nv nothing changes (the same expressions, bit for bit).

Transcription (multiple shooting, :class:`casadi.Opti`)
-------------------------------------------------------
Decision variables ``X_k`` (2·nq, k = 0 … n) and ``U_k`` (nq, k = 0 … n−1), declared in
stage order ``X_0, U_0, X_1, U_1, …, X_n``; the dynamics are gap-closing equalities
``X_{k+1} = A X_k + B U_k`` and every other constraint is a path constraint of one stage
(``X_0 = x_0`` and the bounds of ``U_0`` on stage 0; the bounds of ``X_k`` and ``U_k`` on
stage k; those of ``X_n`` — and ``e(q_n) = 0`` — on stage n), written stage by stage after
the stage's gap-closing constraint.  That is the layout FATROP's automatic structure
detection needs (``structure_detection="auto"``: it reads ``nx = 42, nu = 21`` and
``ng = 63`` per stage for three arms); IPOPT does not care.  The terminal error is
``task.graph.error_expression(q_n, V_Sd)`` — the task graph's own expression of e (no
algebra is rebuilt here) — and the NLP is expanded to SX (``expand=True``), so both solvers
get exact first and second derivatives (Hessian of the Lagrangian) by CasADi AD.

Solvers
-------
* ``"ipopt"``: interior point, MUMPS sparse linear algebra, exact Hessian.
* ``"fatrop"``: the structure-exploiting interior point of FATROP (a Riccati-based linear
  solver on the stage structure above; shipped with CasADi since 3.6.5 — FATROP 1.1 in the
  CasADi 3.8 used here).

Both get ``tol`` (default 1e-10; it is also their ``compl_inf_tol``) and ``constr_viol_tol``
(1e-9).  The default tolerances of the two solvers (1e-8 and a complementarity tolerance of
1e-4) leave costs that differ in the 7th digit where bounds are active (the optimum moves
by Σ z_i δ_i when the bounds move by δ; Σ z ≈ 30 for the velocity-bound test case).  For the
same reason the two must solve the *same* feasible set: FATROP relaxes every inequality
``g ≤ b`` by ``1e-8 · max(1, |b|)`` (its ``bound_relax_factor``, which CasADi's interface
does not let one set), so it is given bounds tightened by exactly that amount
(:data:`FATROP_BOUND_RELAX`; the bound values are Opti parameters), and IPOPT's own
relaxation is switched off (``bound_relax_factor = 0``).  Then both return solutions
within the original bounds, and costs that agree to 1e-8–1e-7 relative when they end in
the same local optimum (1.5e-8 on the 20-knot test, 1.5e-7 on the 250-knot benchmark).

Local optima.  The terminal error makes the problem non-convex, and with a tight joint
range (a redundant chain blocked) the two interior-point methods can end in *different*
local optima from the same start (both converged; ``tests/control/test_reference_ocp.py``
shows one, and that IPOPT started from FATROP's solution stays there).  Compare costs only
together with the trajectories.

Both start from the same guess: ``u_init`` (default 0) and the states of its roll-out
(dynamically feasible, not necessarily within the bounds — neither solver needs a feasible
start).  :attr:`ReferenceSolution.max_violation` is recomputed from the returned
trajectories (the tests require < 1e-6; it is 0 in practice).

Times.  :attr:`ReferenceSolution.solve_time_s` is the solver's own ``t_wall_total``
(excluding the one-off creation of the ``nlpsol`` — symbolic expansion, sparsity patterns,
FATROP's structure detection — which :attr:`~ReferenceSolution.wall_time_s` includes);
:attr:`~ReferenceSolution.build_time_s` is the Python construction of the Opti problem.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError, UnsupportedJointError
from ..geometry.groups import SimilarityLike
from ..kinematics.chains import integrate_symbolic
from ..systems.limits import JointLimits
from .base import check_problem, check_v
from .ilqr.problem import DEFAULT_Q, DEFAULT_QV, DEFAULT_R

__all__ = [
    "ACTIVE_TOL",
    "FATROP_BOUND_RELAX",
    "SOLVERS",
    "ReferenceProblem",
    "ReferenceSolution",
    "TangentReachingOCP",
    "check_trajectory",
    "solve_reference",
]

#: Names accepted by :func:`solve_reference`.
SOLVERS = ("ipopt", "fatrop")

#: Tolerance [rad, rad/s, rad/s²] below which a bound counts as active in :attr:`ReferenceSolution.active`.
ACTIVE_TOL = 1e-6

#: FATROP's ``bound_relax_factor`` (its default; CasADi's FATROP interface does not accept the option):
#: every inequality ``g ≤ b`` is relaxed to ``g ≤ b + 1e-8 · max(1, |b|)``.
FATROP_BOUND_RELAX = 1e-8


@dataclass(frozen=True, eq=False)
class ReferenceSolution:
    """Solution of the constrained reaching OCP by a reference NLP solver (module docstring).

    Attributes:
        solver: ``"ipopt"`` or ``"fatrop"``.  terminal: ``"soft"`` or ``"constraint"``.
        success: the solver reported success.  status: its return status (string).
        u: (n, nv) controls [rad/s²]; q: (n+1, nq) [rad] and qd: (n+1, nv) [rad/s] the states
            X_k of the NLP (not re-integrated); t: (n+1,) knot times [s] (nv = nq without a free flyer).
        cost: the NLP objective at the solution (soft: ``Σ uᵀRu + eᵀQe + q̇_nᵀQ_v q̇_n``;
            constraint: ``Σ uᵀRu + q̇_nᵀQ_v q̇_n``).
        cost_rollout: ``ocp.cost(u)`` — the soft cost of Eq 53 of the controls, re-integrated
            by :meth:`ReachingOCP.rollout` (comparable across solvers and with iLQR).
        error_vector: (7,) e(q_n) from ``task.graph.error_expression``; terminal_error: its norm.
        violations: largest violation of each bound family over the knots —
            ``{"position" [rad], "velocity" [rad/s], "acceleration" [rad/s²]}`` (0 = satisfied);
            max_violation: their maximum.  defect: largest residual of the dynamics equalities.
        active: number of (knot, joint) bound entries within :data:`ACTIVE_TOL` of their bound,
            per family.
        iterations: solver iterations.  solve_time_s / solve_cpu_s: the solver's wall / CPU time
            of the solve [s] (``t_wall_total`` / ``t_proc_total``); wall_time_s: wall time of
            ``opti.solve()`` (includes creating the nlpsol); build_time_s: building the Opti problem.
        limits: the bounds imposed (None: none).  stats: CasADi's solver statistics (scalars).
    """

    solver: str
    terminal: str
    success: bool
    status: str
    u: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    t: np.ndarray
    cost: float
    cost_rollout: float
    error_vector: np.ndarray
    terminal_error: float
    violations: dict[str, float]
    max_violation: float
    defect: float
    active: dict[str, int]
    iterations: int
    solve_time_s: float
    solve_cpu_s: float
    wall_time_s: float
    build_time_s: float
    limits: JointLimits | None
    stats: dict[str, Any] = field(default_factory=dict)


def _bound_rows(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices with both bounds finite, only the lower one, only the upper one."""
    flo, fhi = np.isfinite(lo), np.isfinite(hi)
    return np.flatnonzero(flo & fhi), np.flatnonzero(flo & ~fhi), np.flatnonzero(~flo & fhi)


class TangentReachingOCP:
    """The reaching OCP of Eq 53–57 for a task whose system has a free flyer (nq ≠ nv): state ``(q_k, v_k)``.

    Args:
        task: a :class:`coop_ga.CooperativeTask` on a system with a free flyer (any system works).
        q_init: (nq,) initial configuration (a free flyer's [p [m]; unit quaternion x y z w], then the joints).
        target: V_Sd, a :class:`~coop_ga.Similarity` of the task's kind.
        qd_init: (nv,) initial velocity (a free flyer's LOCAL [v; ω], then the joint speeds; default 0).
        horizon: number of knots (as in :class:`~coop_ga.control.ilqr.ReachingOCP`).
        dt: knot spacing [s] (as there).
        Q: terminal error weight (as there).
        limit_mode: how the limits enter (as there).
        R: control weight (scalar, (nv,) or (nv, nv); positive definite).  Qv: terminal velocity weight (nv).

    The dynamics are the double integrator on the configuration manifold, exact zero-order hold::

        q_{k+1} = q_k ⊕ (Δt v_k + ½Δt² u_k),      v_{k+1} = v_k + Δt u_k,

    ``⊕`` being :meth:`System.integrate` (``pinocchio.integrate``: a free flyer's velocity is LOCAL, its
    quaternion stays unit); u_k (nv) [m/s², rad/s²].  The cost is that of ``ReachingOCP`` with nv-sized R, Q_v.
    It carries what :class:`ReferenceProblem` reads (the iLQR does not take it).
    """

    def __init__(
        self,
        task: Any,
        q_init: Any,
        target: SimilarityLike,
        *,
        qd_init: Any = None,
        horizon: int = 50,
        dt: float = 0.02,
        R: Any = DEFAULT_R,
        Q: Any = DEFAULT_Q,
        Qv: Any = DEFAULT_QV,
        limit_mode: str = "enforce",
    ):
        self.task = task
        self.system = task.system
        self.nq, self.nv = int(task.nq), int(task.system.nv)
        self.q_init, self.target = check_problem(task, q_init, target, "q_init")
        self.system.check_quaternions(self.q_init, "q_init")
        self.qd_init = np.zeros(self.nv) if qd_init is None else check_v(task, qd_init, "qd_init")
        self.horizon = validation.integer(horizon, "horizon", minimum=2)
        self.dt = validation.positive(dt, "dt")
        self.h = 0.5 * self.dt * self.dt
        self.R = validation.weight(R, self.nv, "R", definite=True)
        self.Q = validation.weight(Q, 7, "Q", definite=False)
        self.Qv = validation.weight(Qv, self.nv, "Qv", definite=False)
        self.limit_mode = validation.choice(limit_mode, ("enforce", "none"), "limit_mode")

    @property
    def times(self) -> np.ndarray:
        """(n+1,) knot times [s]."""
        return self.dt * np.arange(self.horizon + 1)

    def check_controls(self, u: Any) -> np.ndarray:
        """Controls (n, nv) as a checked float array."""
        return validation.array(u, "controls", shape=(self.horizon, self.nv))

    def rollout(self, u: Any) -> tuple[np.ndarray, np.ndarray]:
        """``u`` (n, nv) → ``q`` (n+1, nq), ``v`` (n+1, nv) by the dynamics above (``System.integrate``)."""
        u = self.check_controls(u)
        v = self.qd_init + np.vstack([np.zeros(self.nv), np.cumsum(self.dt * u, axis=0)])
        q = np.empty((self.horizon + 1, self.nq))
        q[0] = self.q_init
        for k in range(self.horizon):
            q[k + 1] = self.system.integrate(q[k], self.dt * v[k] + self.h * u[k])
        return q, v

    def cost(self, u: Any) -> float:
        """``Σ u_kᵀ R u_k + e(q_n)ᵀ Q e(q_n) + v_nᵀ Q_v v_n`` of the roll-out of u (n, nv)."""
        u = self.check_controls(u)
        q, v = self.rollout(u)
        e = self.task.error(q[-1], self.target)
        return float(np.einsum("ki,ij,kj->", u, self.R, u) + e @ self.Q @ e + v[-1] @ self.Qv @ v[-1])


class ReferenceProblem:
    """The constrained reaching OCP transcribed in :class:`casadi.Opti` (module docstring).

    Args:
        ocp: the :class:`~coop_ga.control.ilqr.ReachingOCP` (task, q_init, q̇_init, target,
            horizon n, Δt, R, Q, Q_v), or a :class:`TangentReachingOCP` (a free flyer).
        limits: the bounds, a :class:`~coop_ga.systems.limits.JointLimits` of the OCP's joints, or None
            (default): ``ocp.task.system.limits``.
        limit_mode: ``"enforce"`` (those bounds), ``"none"`` (no bounds: the unconstrained OCP) or None
            (default): the OCP's own ``limit_mode``.
        terminal: ``"soft"`` (default, Eq 57: ``eᵀQe`` in the cost) or ``"constraint"`` (``e(q_n) = 0``).

    The Opti problem is built once; :meth:`solve` may be called several times (each solver
    creates its nlpsol on its first solve).
    """

    def __init__(
        self, ocp: Any, limits: JointLimits | None = None, *, limit_mode: str | None = None, terminal: str = "soft"
    ):
        import casadi as ca

        t0 = time.perf_counter()
        self.ocp = ocp
        self.terminal = validation.choice(terminal, ("soft", "constraint"), "terminal")
        self.limits: JointLimits | None = _resolve_limits(ocp, limits, limit_mode)
        n, N, nv = ocp.nq, ocp.horizon, _nv(ocp)
        opti = ca.Opti()
        X: list[Any] = []
        U: list[Any] = []
        for _ in range(N):  # stage order x_0, u_0, x_1, u_1, …, x_N (FATROP)
            X.append(opti.variable(n + nv))
            U.append(opti.variable(nv))
        X.append(opti.variable(n + nv))
        x0 = np.concatenate([ocp.q_init, ocp.qd_init])
        # The bound values are Opti parameters (set per solve: FATROP gets them pre-tightened, see solve()).
        self._bounds: list[tuple[Any, np.ndarray, float]] = []  # (parameter, nominal value, sign: +1 upper / −1 lower)
        state_bounds, control_bounds = self._path_constraints(opti, n)
        step = _step_function(ocp)
        for k in range(N):
            xk, uk = X[k], U[k]
            # gap-closing dynamics (Eq 54, exact ZOH), then the path constraints of stage k
            opti.subject_to(X[k + 1] == step(xk, uk))
            if k == 0:
                opti.subject_to(X[0] == x0)
            else:
                state_bounds(xk)
            control_bounds(uk)
        state_bounds(X[N])
        qn, qdn = X[N][:n], X[N][n:]
        e = ocp.task.graph.error_expression(qn, ca.DM(ocp.target.coeffs))
        if self.terminal == "constraint":
            opti.subject_to(e == 0)
        R, Q, Qv = ca.DM(ocp.R), ca.DM(ocp.Q), ca.DM(ocp.Qv)
        J = sum(ca.bilin(R, uk, uk) for uk in U) + ca.bilin(Qv, qdn, qdn)
        if self.terminal == "soft":
            J = J + ca.bilin(Q, e, e)
        opti.minimize(J)
        self.opti, self.X, self.U, self.e, self.J = opti, X, U, e, J
        self._Xall, self._Uall = ca.horzcat(*X), ca.horzcat(*U)
        self.build_time_s = time.perf_counter() - t0

    def _path_constraints(self, opti: Any, n: int) -> tuple[Callable[[Any], None], Callable[[Any], None]]:
        """``(state_bounds(x), control_bounds(u))``: add the bounds of one knot (none without limits); their
        values are Opti parameters recorded in ``self._bounds``."""
        lim = self.limits
        if lim is None:
            return (lambda x: None), (lambda u: None)

        def param(values: np.ndarray, sign: float) -> Any:
            par = opti.parameter(len(values))
            self._bounds.append((par, np.asarray(values, dtype=float), sign))
            return par

        both, lo_only, hi_only = _bound_rows(lim.lower, lim.upper)
        # a bound on velocity row i is one on q[qi[i]] (the identity when nq = nv; −1 for a free flyer's rows)
        qi = _limit_q_index(self.ocp)
        _check_flyer_unbounded(qi, lim)
        v_rows = np.flatnonzero(np.isfinite(lim.velocity))
        a_rows = np.flatnonzero(np.isfinite(lim.acceleration))
        p_lo, p_hi = param(lim.lower[both], -1.0), param(lim.upper[both], 1.0)
        p_lo1, p_hi1 = param(lim.lower[lo_only], -1.0), param(lim.upper[hi_only], 1.0)
        p_v, p_a = param(lim.velocity[v_rows], 1.0), param(lim.acceleration[a_rows], 1.0)

        def state_bounds(x: Any) -> None:
            q, qd = x[:n], x[n:]
            if both.size:
                opti.subject_to(opti.bounded(p_lo, q[qi[both].tolist()], p_hi))
            if lo_only.size:
                opti.subject_to(q[qi[lo_only].tolist()] >= p_lo1)
            if hi_only.size:
                opti.subject_to(q[qi[hi_only].tolist()] <= p_hi1)
            if v_rows.size:
                opti.subject_to(opti.bounded(-p_v, qd[v_rows.tolist()], p_v))

        def control_bounds(u: Any) -> None:
            if a_rows.size:
                opti.subject_to(opti.bounded(-p_a, u[a_rows.tolist()], p_a))

        return state_bounds, control_bounds

    # ------------------------------------------------------------------ solve
    def solve(
        self,
        solver: str = "ipopt",
        *,
        u_init: Any = None,
        tol: float = 1e-10,
        constr_viol_tol: float = 1e-9,
        max_iter: int = 1000,
        solver_options: dict[str, Any] | None = None,
        verbose: bool = False,
    ) -> ReferenceSolution:
        """Solve with ``solver`` (``"ipopt"`` or ``"fatrop"``) from ``u_init`` (n, nv) [rad/s²] (default 0).

        ``tol``: the solver's convergence tolerance (scaled KKT error, both solvers);
        ``constr_viol_tol``: IPOPT's and FATROP's tolerance on the unscaled constraint
        violation; ``max_iter``: iteration cap; ``solver_options``: extra options passed to the
        solver (IPOPT names, or FATROP's inside its ``"fatrop"`` dict); ``verbose``: print the
        solver's log.  A solver that stops without success returns its last iterate with
        ``success=False`` (no exception).
        """
        import casadi as ca

        validation.choice(solver, SOLVERS, "solver")
        validation.positive(tol, "tol")
        validation.positive(constr_viol_tol, "constr_viol_tol")
        validation.integer(max_iter, "max_iter", minimum=0)
        if not ca.has_nlpsol(solver):
            raise InvalidInputError(f"this CasADi ({getattr(ca, '__version__', '?')}) has no '{solver}' plugin")
        ocp, opti = self.ocp, self.opti
        N = ocp.horizon
        u0 = np.zeros((N, _nv(ocp))) if u_init is None else ocp.check_controls(u_init)
        q0, qd0 = ocp.rollout(u0)
        opti.set_initial(self._Xall, np.vstack([q0.T, qd0.T]))
        opti.set_initial(self._Uall, u0.T)
        common = {
            "print_level": 5 if verbose else 0,
            "tol": tol,
            "compl_inf_tol": tol,
            "constr_viol_tol": constr_viol_tol,
            "max_iter": max_iter,
        }
        self._configure(solver, common, dict(solver_options or {}))
        t0 = time.perf_counter()
        sol: Any
        try:
            sol = opti.solve()
            ok = True
        except RuntimeError as ex:  # no convergence (max_iter, restoration failure, …): report the last iterate
            sol = opti.debug
            ok = False
            try:
                opti.stats()
            except RuntimeError:  # the solver never ran (unknown option, plugin error): that is not a result
                raise InvalidInputError(f"{solver} could not be started: {ex}") from ex
        return self._solution(solver, sol, ok, time.perf_counter() - t0)

    def _configure(self, solver: str, common: dict[str, Any], extra: dict[str, Any]) -> None:
        """Set the bound parameters and the solver (module docstring)."""
        opti = self.opti
        # FATROP relaxes every inequality by FATROP_BOUND_RELAX · max(1, |b|) and CasADi's interface does
        # not expose the factor: give it bounds tightened by that amount, so that both solvers solve the
        # same problem (IPOPT's own relaxation is switched off) and FATROP's solution satisfies the bounds.
        for par, value, sign in self._bounds:
            if solver == "fatrop":
                value = value - sign * FATROP_BOUND_RELAX * np.maximum(1.0, np.abs(value))
            opti.set_value(par, value)
        base = {"expand": True, "print_time": False, "record_time": True}
        if solver == "ipopt":
            opti.solver("ipopt", {**base, "ipopt.sb": "yes"}, {**common, "bound_relax_factor": 0.0, **extra})
        else:
            opti.solver(
                "fatrop", {**base, "structure_detection": "auto", "debug": False, "fatrop": {**common, **extra}}
            )

    def _solution(self, solver: str, sol: Any, ok: bool, wall: float) -> ReferenceSolution:
        """The :class:`ReferenceSolution` of a finished solve (``sol``: the Opti solution or its debug view)."""
        ocp, opti = self.ocp, self.opti
        n, N, nv = ocp.nq, ocp.horizon, _nv(ocp)
        raw = opti.stats()
        stats = {k: v for k, v in raw.items() if isinstance(v, (bool, int, float, str))}
        for k, v in raw.get("fatrop", {}).items() if isinstance(raw.get("fatrop"), dict) else ():
            if isinstance(v, (bool, int, float, str)):
                stats[f"fatrop.{k}"] = v  # FATROP's own breakdown (compute_sd_time, eval_hess_time, …)
        Xv = np.array(sol.value(self._Xall), dtype=float).reshape(n + nv, N + 1)
        Uv = np.array(sol.value(self._Uall), dtype=float).reshape(nv, N)
        q, qd, u = Xv[:n].T.copy(), Xv[n:].T.copy(), Uv.T.copy()
        e = np.array(sol.value(self.e), dtype=float).reshape(-1)
        cost = float(sol.value(self.J))
        return ReferenceSolution(
            solver=solver,
            terminal=self.terminal,
            success=ok and bool(raw.get("success", False)),
            status=str(raw.get("return_status", "?")),
            u=u,
            q=q,
            qd=qd,
            t=ocp.dt * np.arange(N + 1),
            cost=cost,
            cost_rollout=float(ocp.cost(u)),
            error_vector=e,
            terminal_error=float(np.linalg.norm(e)),
            **check_trajectory(ocp, self.limits, q, qd, u),
            iterations=int(raw.get("iter_count", -1)),
            solve_time_s=float(raw.get("t_wall_total", wall)),
            solve_cpu_s=float(raw.get("t_proc_total", np.nan)),
            wall_time_s=wall,
            build_time_s=self.build_time_s,
            limits=self.limits,
            stats=stats,
        )


def _nv(ocp: Any) -> int:
    """The OCP's number of velocities (controls): ``ocp.nv`` (a :class:`TangentReachingOCP`) or ``ocp.nq``."""
    return int(getattr(ocp, "nv", ocp.nq))


def _step_function(ocp: Any) -> Callable[[Any, Any], Any]:
    """``x_{k+1}(x_k, u_k)`` (CasADi): Eq 54 when nq = nv, else ``q ⊕ (Δt v + ½Δt² u)`` by the exact symbolic
    ``pinocchio.integrate`` (:func:`~coop_ga.kinematics.chains.integrate_symbolic`) and ``v + Δt u``."""
    import casadi as ca

    n, nv, dt = ocp.nq, _nv(ocp), ocp.dt
    h = 0.5 * dt * dt
    if nv == n:
        return lambda xk, uk: ca.vertcat(xk[:n] + dt * xk[n:] + h * uk, xk[n:] + dt * uk)
    qs, vs = ca.SX.sym("q", n), ca.SX.sym("v", nv)
    model = ocp.task.system.model
    integrate = ca.Function("integrate", [qs, vs], [integrate_symbolic(model, qs, vs)])
    return lambda xk, uk: ca.vertcat(integrate(xk[:n], dt * xk[n:] + h * uk), xk[n:] + dt * uk)


def _limit_q_index(ocp: Any) -> np.ndarray:
    """For each velocity row of the limits, the q index of its 1-DOF joint's coordinate (−1: a free flyer's)."""
    model = ocp.task.system.model
    if model.nq == model.nv:
        return np.arange(ocp.nq)
    idx = np.full(model.nv, -1)
    for j in range(1, model.njoints):
        if model.nqs[j] == 1 and model.nvs[j] == 1:
            idx[model.idx_vs[j]] = model.idx_qs[j]
    return idx


def _check_flyer_unbounded(qi: np.ndarray, lim: JointLimits) -> None:
    """Refuse position bounds on a free flyer's rows: its coordinates are not a box (limits bound joints only)."""
    rows = np.flatnonzero((qi < 0) & (np.isfinite(lim.lower) | np.isfinite(lim.upper)))
    if rows.size:
        raise InvalidInputError(
            f"limits bound the free flyer's velocity rows {rows.tolist()} in position; a floating base has no box "
            "on its coordinates: make those lower/upper entries infinite (velocity and acceleration bounds stay)"
        )


def _resolve_limits(ocp: Any, limits: JointLimits | None, limit_mode: str | None) -> JointLimits | None:
    """The bounds of the problem (None: none): ``limits`` (None: the system's) checked against the OCP's joints,
    unless the limit mode (None: the OCP's) is ``"none"``."""
    if limit_mode is None:
        limit_mode = getattr(ocp, "limit_mode", "enforce")
    if validation.choice(limit_mode, ("enforce", "none"), "limit_mode") == "none":
        return None
    if limits is None:
        return ocp.task.system.limits
    if isinstance(limits, JointLimits):
        own = tuple(ocp.task.system.limits.joint_names)
        if limits.nq != _nv(ocp) or tuple(limits.joint_names) != own:
            raise InvalidInputError(
                f"limits are for the joints {list(limits.joint_names)[:3]}… ({limits.nq}), "
                f"the OCP's task has {list(own)[:3]}… ({_nv(ocp)}): they must match in order"
            )
        return limits
    raise InvalidInputError(
        f"limits must be a JointLimits or None, got {type(limits).__name__} (limit_mode='none' drops the bounds)"
    )


def check_trajectory(ocp: Any, lim: JointLimits | None, q: np.ndarray, qd: np.ndarray, u: np.ndarray) -> dict[str, Any]:
    """Bound violations, active-bound counts and the dynamics defect of any trajectory of ``ocp``.

    q, qd: (n+1, nq), (n+1, nv) knot states [rad, rad/s]; u: (n, nv) controls [rad/s²]; lim: the bounds
    (None: none).  Bounds are checked where the problem imposes them (q, q̇ at k = 1 … n, u at
    k = 0 … n−1).  Returns ``{"violations": {"position", "velocity", "acceleration"},
    "max_violation", "defect", "active": {…}}`` as in :class:`ReferenceSolution` (``defect``:
    largest residual of Eq 54 and of the initial state; with a free flyer the step's residual is
    ``difference(q_k ⊕ (Δt v_k + ½Δt² u_k), q_{k+1})`` and the position bounds are checked on
    ``System.limit_coordinates``).  Used for the iLQR rows of
    ``benchmarks/ocp.py`` as well.
    """
    dt, h = ocp.dt, 0.5 * ocp.dt * ocp.dt
    if _nv(ocp) == ocp.nq:
        dq = q[1:] - (q[:-1] + dt * qd[:-1] + h * u)
    else:  # on the manifold: the velocity that closes each step's gap (0 when q_{k+1} = q_k ⊕ …)
        s = ocp.task.system
        dq = np.array([s.difference(s.integrate(q[k], dt * qd[k] + h * u[k]), q[k + 1]) for k in range(len(u))])
    dv = qd[1:] - (qd[:-1] + dt * u)
    x0 = np.concatenate([q[0] - ocp.q_init, qd[0] - ocp.qd_init])
    defect = float(max(np.max(np.abs(dq)), np.max(np.abs(dv)), np.max(np.abs(x0))))
    if lim is None:
        viol = {"position": 0.0, "velocity": 0.0, "acceleration": 0.0}
        active = {"position": 0, "velocity": 0, "acceleration": 0}
    else:
        qk, vk = q[1:], qd[1:]
        if _nv(ocp) != ocp.nq:  # the bounds are on the joints' coordinates, in q̇ order
            qk = ocp.task.system.limit_coordinates(qk)
        viol = {
            "position": lim.position_violation(qk),
            "velocity": lim.velocity_violation(vk),
            "acceleration": lim.acceleration_violation(u),
        }
        with np.errstate(invalid="ignore"):
            active = {
                "position": int(
                    np.count_nonzero((np.abs(qk - lim.lower) <= ACTIVE_TOL) | (np.abs(qk - lim.upper) <= ACTIVE_TOL))
                ),
                "velocity": int(np.count_nonzero(np.abs(np.abs(vk) - lim.velocity) <= ACTIVE_TOL)),
                "acceleration": int(np.count_nonzero(np.abs(np.abs(u) - lim.acceleration) <= ACTIVE_TOL)),
            }
    return {"violations": viol, "max_violation": float(max(viol.values())), "defect": defect, "active": active}


def solve_reference(
    ocp: Any,
    limits: JointLimits | None = None,
    solver: str = "ipopt",
    *,
    limit_mode: str | None = None,
    terminal: str = "soft",
    u_init: Any = None,
    tol: float = 1e-10,
    constr_viol_tol: float = 1e-9,
    max_iter: int = 1000,
    solver_options: dict[str, Any] | None = None,
    verbose: bool = False,
) -> ReferenceSolution:
    """Solve the constrained reaching OCP (module docstring) with IPOPT or FATROP through CasADi Opti.

    Args:
        ocp: a :class:`~coop_ga.control.ilqr.ReachingOCP` (the problem data, Eq 53–57), or a
            :class:`TangentReachingOCP` for a system with a free flyer (a ReachingOCP of one is refused:
            :class:`UnsupportedJointError`).
        limits: a :class:`~coop_ga.systems.limits.JointLimits`, or None (default: ``ocp.task.system.limits``).
        limit_mode: ``"enforce"``, ``"none"`` (no bounds) or None (default: the OCP's ``limit_mode``).
        solver: ``"ipopt"`` or ``"fatrop"``.
        terminal: ``"soft"`` (Eq 57, the OCP's cost) or ``"constraint"`` (``e(q_n) = 0``).
        u_init: (n, nv) initial control guess [rad/s²] (default 0); the initial states are its roll-out.
        tol: see :meth:`ReferenceProblem.solve`.
        constr_viol_tol: see :meth:`ReferenceProblem.solve`.
        max_iter: see :meth:`ReferenceProblem.solve`.
        solver_options: see :meth:`ReferenceProblem.solve`.
        verbose: see :meth:`ReferenceProblem.solve`.

    Returns:
        :class:`ReferenceSolution` (trajectories, cost, terminal error, bound violations,
        iterations, times, status).
    """
    if ocp.task.system.nv != ocp.nq and not isinstance(ocp, TangentReachingOCP):
        raise UnsupportedJointError(
            f"solve_reference: task '{ocp.task.name}' has a free flyer (nq = {ocp.nq}, nv = {ocp.task.system.nv}) "
            "and a ReachingOCP's double integrator adds q̇ to q; build the problem as TangentReachingOCP(task, q_init, "
            "target, ...) (state (q, v), q_{k+1} = q_k ⊕ (Δt v_k + ½Δt² u_k))"
        )
    problem = ReferenceProblem(ocp, limits, limit_mode=limit_mode, terminal=terminal)
    return problem.solve(
        solver,
        u_init=u_init,
        tol=tol,
        constr_viol_tol=constr_viol_tol,
        max_iter=max_iter,
        solver_options=solver_options,
        verbose=verbose,
    )
