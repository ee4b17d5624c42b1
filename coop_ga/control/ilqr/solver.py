"""The solver: :func:`ilqr_reach` (checks, the certificate, the solve and its restart) and the AL / iLQR loops."""

from __future__ import annotations

import copy
import dataclasses
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...diagnostics import collect_warnings
from ...errors import DegeneratePrimitiveError, InvalidInputError
from ...geometry.groups import SimilarityLike
from ..base import resolve_options
from .chart import FlyerChart, chart_problem, chart_reach, to_manifold
from .feasibility import reference_controls, restore
from .lq import Condensation, LQStep, add_state_hessian, controls_to, lq_step, second_order_correction
from .merit import Evaluation, Merit, StateTerms, gauss_newton_hessian, multiplier_estimate, terminal_model
from .options import ILQROptions
from .problem import ClearanceRows, ReachingOCP
from .reachability import bounded_stationarity, unreachable
from .results import ILQRIteration, ILQRResult, Progress, finish

__all__ = ["STALL_DECREASE", "STALL_FLOOR", "STALL_STATIONARITY", "STALL_WINDOW", "RecedingReach", "ilqr_reach"]

# The stall test (package docstring, "Fast honest failure"): a solve stops once, over the last STALL_WINDOW iterations,
# ‖e‖ fell by less than the fraction STALL_DECREASE, while it is above STALL_FLOOR × tol, the trajectory is inside the
# bounds and the end configuration is a stationary point of ‖e‖ within the limits (bounded_stationarity below
# STALL_STATIONARITY).  Measured on 1202 solves (10 systems × 6 kinds × 4 displacement sizes × 3 targets, from rest
# and moving): it never holds on the way of the 834 that converge, even with the decrease test 30× looser or the
# stationarity test left out; the two limits each guard the other.
STALL_WINDOW = 3
STALL_DECREASE = 1e-2
STALL_STATIONARITY = 1e-2
STALL_FLOOR = 100.0


def ilqr_reach(
    task: Any,
    q_init: Any,
    target: SimilarityLike,
    options: ILQROptions | None = None,
    *,
    qd_init: Any = None,
    u_init: Any = None,
    **overrides: Any,
) -> ILQRResult:
    """Reach the target similarity ``V_Sd`` within the joint limits by iLQR on Eq 53–57 (:mod:`coop_ga.control.ilqr`).

    Args:
        task: a :class:`coop_ga.CooperativeTask`.
        q_init: (nq,) initial configuration [rad]; the system starts at rest unless ``qd_init``.
        target: V_Sd, a :class:`~coop_ga.Similarity` of the task's kind (e.g. from :func:`displaced_target`).
        options: :class:`ILQROptions` (problem and solver settings); keyword ``overrides``
            replace its fields (``ilqr_reach(task, q, V, max_iter=20)``).
        qd_init: (nq,) initial joint velocity [rad/s] (default 0).
        u_init: (n, nq) initial control guess [rad/s²] (default: rest, or braking to rest).

    A system with a free flyer (nq ≠ nv) is solved in a local chart centred at q_init (:mod:`.chart`: why, and what
    its bounds mean); ``qd_init`` and ``u_init`` then have nv columns, and the result's ``trajectory`` is (n+1, nq)
    on the manifold, its ``qd`` the tangent velocities (n+1, nv) and its ``u`` the chart's accelerations (n, nv).

    Returns:
        :class:`ILQRResult`; every returned trajectory satisfies the bounds (package docstring).  A target
            certified unreachable (package docstring, "Fast honest failure") returns before any iteration.

    Raises:
        InvalidInputError: wrong shapes or values (q_init size, weights, horizon, target, …), or
            (``limit_mode="enforce"``) a start state outside the limits.
        NonFiniteError: NaN/inf in q_init, qd_init, u_init or an option.
        DegeneratePrimitiveError: the primitive is degenerate at ``q_init``.

    Timing: before the clock starts, the task's compiled error function is evaluated once
    at ``q_init`` (generated and compiled by gcc on the first call per task — ~1–2 s, cached
    on disk — which also validates the inputs), and the Newton model's second-order function
    is built (~0.2 s, once per task and process); ``solve_time_s`` covers everything else.
    """
    o = resolve_options(ILQROptions, options, overrides, "ilqr_reach")
    if task.nq != getattr(task, "nv", task.nq):  # a free flyer: the same solve in a chart (module .chart)
        return chart_reach(task, q_init, target, o, qd_init, u_init)
    ocp = _problem(task, q_init, target, qd_init, o)
    with collect_warnings() as caught:
        reason = unreachable(ocp, o.tol)
        if reason is not None:  # certified: no iteration can help
            t_start = time.perf_counter()
            u_ref = reference_controls(ocp)
            return finish(ocp, o, u_ref, u_ref, Progress(t_start=t_start, message=reason), caught.counts)
        res = _Solve(ocp, o, u_init).run(caught.counts)
        # restart only a solve that stalled (not one that ran out of its iteration budget, not an
        # unreachable tol = 0, not a user's own initial guess)
        stalled = "max_iter" not in res.message and res.iterations < o.max_iter
        if res.converged or u_init is not None or not o.restart or not stalled or o.tol == 0:
            return res
        return _restart(ocp, o, res, caught.counts)


def _problem(task: Any, q_init: Any, target: SimilarityLike, qd_init: Any, o: ILQROptions) -> ReachingOCP:
    """The checked problem; with ``limit_mode="enforce"`` a start outside the position or velocity limits is refused."""
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
        limit_mode=o.limit_mode,
        clearance=o.clearance,
    )
    if o.limit_mode == "enforce":
        lim = task.system.limits
        if lim.position_violation(ocp.q_init) > 1e-9:
            raise InvalidInputError(
                f"q_init is outside the joint limits ({lim.describe(ocp.q_init, 1e-9)}); move it "
                "inside, or pass limit_mode='none' to solve without bounds"
            )
        if lim.velocity_violation(ocp.qd_init) > 1e-9:
            raise InvalidInputError("qd_init exceeds the velocity limits; lower it, or pass limit_mode='none'")
    return ocp


def _restart(ocp: ReachingOCP, o: ILQROptions, res: ILQRResult, warning_counts: dict[str, int]) -> ILQRResult:
    """Globalisation of a stalled solve ``res``.

    A failed solve usually stalls on a local minimum of the bounded terminal problem (joints pressed on their limits,
    ‖e‖ ~ 1e-2).  The bounded Gauss–Newton IK reaches the target inside the limits more often from q_init; restart
    from the minimum-energy controls to its answer (rest-to-rest they are cubics, monotone between the bounds) and
    keep the better result (both solves in its statistics and histories).  The IK ignores the clearance cost: a
    restart whose trajectory has a negative clearance is rejected unless the first solve's had one too.
    """
    from ..gauss_newton import gauss_newton_ik

    with collect_warnings(silent=True):
        ik = gauss_newton_ik(ocp.task, ocp.q_init, ocp.target, limit_mode=o.limit_mode)
    if not ik.converged:
        return res
    u_guess = controls_to(ocp, ik.q)
    if o.limit_mode == "enforce" and ocp.violation(*ocp.rollout(u_guess), u_guess) > 0:
        blended = restore(ocp, u_guess, reference_controls(ocp))  # e.g. a moving start overshoots a bound
        if blended is not None:
            u_guess = blended[0]
    o2 = dataclasses.replace(o, max_iter=max(o.max_iter - res.iterations, 1))
    res2 = _Solve(ocp, o2, u_guess).run(warning_counts)
    # the IK knows no obstacle: a restart that ends through one (where the first solve did not) is not better,
    # however small its error (finish() already refuses to call it converged)
    through = res2.min_clearance < 0.0 <= res.min_clearance
    if through or not (res2.converged or res2.error < res.error):
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


class RecedingReach:
    """:func:`ilqr_reach` re-solved many times for one task and one set of options (a receding horizon,
    :mod:`coop_ga.control.mpc`): the same solve from each new start state and target, without its per-call set-up.

    The first :meth:`solve` is :func:`ilqr_reach`'s problem with all its checks (shapes, weights, horizon, the
    target's chart, the start inside the limits) and compiles the task's functions; every later one reuses that
    checked problem with the new start (q, q̇) and target, and the Gramian data of the condensed steps (they
    depend only on n, Δt and R).  Left out of every solve (not only the later ones):

    * the unreachability certificate — a receding horizon must move toward a target that is momentarily out of
      reach rather than stop; the controller reports ‖e‖ of every tick instead
      (:class:`~coop_ga.control.mpc.MPCTick`), so an unreachable target shows as a large error, never as success;
    * the restart from the bounded Gauss–Newton IK (the caller warm-starts), and the list of active bounds in the
      message (``active_constraints`` is empty: the bound *violations* are still measured and reported).

    The iterations, the final feasibility blend (every returned plan is inside the bounds) and the result's
    numbers are those of :func:`ilqr_reach` with ``restart=False`` on the same input (tested).

    The caller checks the later inputs: ``q_init``, ``qd_init`` finite (nq,) inside the position and velocity
    limits and ``target`` a checked :class:`~coop_ga.Similarity` of the task's kind (``task.check_target``) —
    :class:`~coop_ga.control.mpc.CooperativeMPC` does at every tick; a wrong shape or a non-finite state still
    raises :class:`~coop_ga.errors.InvalidInputError` / :class:`~coop_ga.errors.NonFiniteError`.
    """

    def __init__(self, task: Any, options: ILQROptions | None = None, **overrides: Any):
        self.task = task
        self.o = resolve_options(ILQROptions, options, overrides, "RecedingReach")
        self.chart: FlyerChart | None = None
        if task.nq != getattr(task, "nv", task.nq):  # a free flyer: each solve in the chart re-centred at its start
            self.chart, self.task, self.o = chart_problem(task, task.system.q0, self.o)
        self._ocp: ReachingOCP | None = None
        self._cond: Condensation | None = None

    def _problem(self, q_init: Any, target: SimilarityLike, qd_init: Any) -> ReachingOCP:
        if self._ocp is None:
            self._ocp = _problem(self.task, q_init, target, qd_init, self.o)
            self._cond = Condensation.of(self._ocp)
            return self._ocp
        ocp = copy.copy(self._ocp)  # shares the checked weights, bounds and dynamics (never modified)
        n = ocp.nq
        ocp.q_init = _state(q_init, n, "q_init")
        ocp.qd_init = np.zeros(n) if qd_init is None else _state(qd_init, n, "qd_init")
        ocp.target = target
        return ocp

    def solve(self, q_init: Any, target: SimilarityLike, *, qd_init: Any = None, u_init: Any = None) -> ILQRResult:
        """One solve from (``q_init``, ``qd_init``) (nq,) [rad, rad/s] toward ``target``, starting from the controls
        ``u_init`` (n, nq) [rad/s²] (default: rest, or braking to rest); see the class docstring.  With a free flyer
        the chart is re-centred at q_init (:mod:`.chart`; ``qd_init``, ``u_init`` with nv columns, the result mapped
        back to the manifold as :func:`ilqr_reach`'s)."""
        if self.chart is not None:
            self.chart.recentre(q_init)
            q_init = self.chart.c
        ocp = self._problem(q_init, target, qd_init)
        with collect_warnings() as caught:
            res = _Solve(ocp, self.o, u_init, self._cond).run(caught.counts, describe=False)
        return res if self.chart is None else to_manifold(res, self.chart)


def _state(x: Any, n: int, what: str) -> np.ndarray:
    """A finite (n,) float array (the cheap check of :class:`RecedingReach`'s later solves)."""
    from ... import validation

    return validation.array(x, what, shape=(n,))


@dataclass(frozen=True)
class _Model:
    """The LQ models of one iteration: the terminal model (gradient vx, Hessian Hf_b with the knot-n state terms), the
    state terms at the knots, whether the Newton model is used, and the (model, damping) pairs to try in order."""

    newton: bool
    vx: np.ndarray
    Hf_b: np.ndarray
    hscale: float
    lx: np.ndarray
    lxx: np.ndarray
    state_active: bool
    tries: list[tuple[str, float]]
    riccati: bool = False  # a state term that only the Riccati pass knows (AL terms, or unlisted clearance rows)
    rows: ClearanceRows | None = None
    row_pairs: np.ndarray | None = None


@dataclass(frozen=True)
class _Accepted:
    """An accepted step: its length, the evaluation there, the model's predicted change, the roll-outs it took, the
    α = 1 travel, and the model that produced it."""

    alpha: float
    ev: Evaluation
    expected: float
    trials: int
    travel: float
    backward_passes: int = 0
    mode: str = "gauss_newton"
    mu: float = 0.0
    kind: str = "riccati"


class _Solve:
    """One augmented-Lagrangian iLQR solve from a control guess (package docstring, "Solver").

    The outer loop updates the AL multipliers and penalty and the terminal shift; the inner loop takes iLQR steps on
    the augmented merit, each from a list of terminal models (Newton, then Gauss–Newton, with growing
    Levenberg–Marquardt damping) with an Armijo line search capped by the joint-travel trust region.
    """

    def __init__(self, ocp: ReachingOCP, o: ILQROptions, u_init: Any, cond: Condensation | None = None):
        self.ocp, self.o = ocp, o
        task = ocp.task
        self.u_ref = reference_controls(ocp)
        u = self.u_ref.copy() if u_init is None else ocp.check_controls(u_init).copy()
        if u_init is not None and ocp.u_bounded:
            u = np.clip(u, -ocp.a_max, ocp.a_max)
        if cond is None:  # a first solve (a RecedingReach passes the Gramian data of its earlier ones)
            task.error_and_jacobian(ocp.q_init, ocp.target)  # build/compile once, outside the timed solve
            if o.hessian == "newton":
                task.graph.error_hessian_function  # noqa: B018  (built once per task, outside the timed solve)
            if ocp.clearance is not None:  # the collision model's batched kinematics (compiled once per horizon)
                ocp.clearance_cost(ocp.rollout(u)[0])

        t_start = time.perf_counter()
        self.cond = Condensation.of(ocp) if cond is None else cond
        self.eye2 = np.eye(2 * ocp.nq)
        bounded = o.limit_mode == "enforce" and bool(np.any(np.isfinite(ocp.q_lower)) or np.any(np.isfinite(ocp.v_max)))
        # AL terms from the start: zero while feasible, a penalty as soon as a bound is crossed
        self.merit = Merit(ocp, o.al_penalty if bounded else 0.0)
        ev = self.merit.evaluate(u)
        if ev is None:
            q_g, _ = ocp.rollout(u)
            task.error_and_jacobian(q_g[-1], ocp.target)  # re-raises the task's degeneracy error
            raise DegeneratePrimitiveError("the initial guess reaches a degenerate primitive")
        self.u, self.ev = u, ev
        self.progress = Progress(t_start=t_start, costs=[ev.cost], errs=[float(np.linalg.norm(ev.e))])
        self.rho_x = 0.0  # LM damping of the state deviations in the Riccati pass (adapted by the step quality)
        self.lm = 0.0  # LM damping of the terminal model (adapted by the step quality)
        self.prev_violation = np.inf
        self.blocked = False  # the stall test held (_blocked): the solve ends
        self.start_clearance: float | None = None  # min clearance at q_init (with a clearance cost; once)

    # ------------------------------------------------------------------ tests on an evaluation
    def _reached(self, ev: Evaluation) -> bool:
        return float(np.linalg.norm(ev.e)) < self.o.tol

    def _done(self, ev: Evaluation) -> bool:
        # a violation ≤ al_violation is removed exactly by the final blend with the feasible reference
        done = float(np.linalg.norm(ev.e)) < self.o.tol and ev.violation <= self.o.al_violation
        # the clearance cost is a penalty: a trajectory through an obstacle (e.g. the restart's guess, which the IK
        # planned without obstacles) is not done even at ‖e‖ < tol; iterate on (finish() would refuse it anyway)
        return done and not self._penetrates(ev)

    def _penetrates(self, ev: Evaluation) -> bool:
        """Whether the trajectory has a negative clearance at a knot (False without a clearance cost): the pairs below
        0 of the knots 1 … n (the merit's pair list of the same trajectory, reused) and of the start."""
        ocp = self.ocp
        if ocp.clearance is None:
            return False
        if self.start_clearance is None:
            self.start_clearance = ocp.min_clearance(ev.q[:1])
        return self.start_clearance < 0.0 or ocp.min_clearance(ev.q[1:], 0.0) < 0.0

    # ------------------------------------------------------------------ outer loop
    def run(self, warning_counts: dict[str, int], describe: bool = True) -> ILQRResult:
        """Solve, then :func:`~coop_ga.control.ilqr.results.finish` (feasibility blend, verdict; ``describe=False``:
        without the list of active bounds)."""
        o, p = self.o, self.progress
        finished = self._done(self.ev)
        if finished:
            p.message = "initial guess already within tol"
        while not finished and p.outer < o.max_outer:
            finished, inner_stalled = self._inner()
            if finished or self.blocked or p.iterations >= o.max_iter:
                if not (finished or self.blocked):
                    p.message = f"max_iter ({o.max_iter}) reached"
                break
            if not self._outer_update(inner_stalled):
                break
        else:
            if not finished:
                p.message = f"max_outer ({o.max_outer}) outer iterations reached"
        return finish(self.ocp, o, self.u, self.u_ref, p, warning_counts, describe=describe)

    def _outer_update(self, inner_stalled: bool) -> bool:
        """Multipliers, penalty and terminal shift after an inner solve; False (with the reason) if nothing changed."""
        o, p, merit, ev = self.o, self.progress, self.merit, self.ev
        p.outer += 1
        changed = False
        viol = ev.violation
        if merit.mu > 0:
            new_lam = np.maximum(0.0, merit.lam + merit.mu * ev.c)
            changed = not np.allclose(new_lam, merit.lam, rtol=0.0, atol=1e-12)
            merit.lam = new_lam
            if viol > o.al_violation and viol > 0.25 * self.prev_violation and merit.mu < o.al_max_penalty:
                merit.mu = min(merit.mu * o.al_growth, o.al_max_penalty)
                changed = True
        self.prev_violation = viol
        if o.terminal == "constraint" and not self._reached(ev):
            merit.shift = merit.shift + ev.e
            changed = True
        if not changed:
            if inner_stalled and o.terminal == "soft":
                p.message = (
                    "stationary: the optimum of the soft terminal cost (Eq 57) keeps ‖e‖ above tol; use "
                    "terminal='constraint' (the default) or raise Q relative to R"
                )
            elif inner_stalled:
                p.message = (
                    "stationary: the optimum within the limits is reached but the terminal error stays above "
                    "tol (the target is not reachable inside the limits from here)"
                )
            return False
        ev_new = merit.evaluate(self.u)
        assert ev_new is not None  # the same trajectory
        self.ev = ev_new
        return True

    # ------------------------------------------------------------------ inner loop
    def _inner(self) -> tuple[bool, bool]:
        """iLQR iterations on the augmented merit: ``(finished, stalled)``."""
        o, p = self.o, self.progress
        while p.iterations < o.max_iter:
            t_it = time.perf_counter()
            e_norm = float(np.linalg.norm(self.ev.e))
            st = self.merit.state_terms(self.ev)
            # the multiplier estimate ignores the clearance cost: neither the Newton model nor the terminal shift
            # estimated from it while a clearance row is active (measured: the shift then stalls the obstacle scene
            # of tests/control/test_avoidance.py short of tol); rows only near activation have no gradient, and
            # Gauss–Newton there (the terminal error's curvature missing) cut the obstacle scene's late steps
            g = st.clearance_gradient
            clearance_active = g is not None and bool(np.any(g))
            newton = o.hessian == "newton" and e_norm < o.newton_switch and not clearance_active
            w = multiplier_estimate(self.ocp, self.ev, self.cond.ck) if newton else None
            shift_estimated = self._estimate_shift(w, e_norm)
            model = self._model(w, newton, st)
            acc = self._search(model)
            if acc is None:
                p.message = (
                    "no descent step found (stationary point of the merit or line-search failure): the "
                    "terminal error cannot be reduced further from here"
                )
                return False, True
            decrease = self.ev.merit - acc.ev.merit
            self._adapt_damping(acc, decrease, model.hscale)
            self._record(acc, decrease, t_it)
            stop = self._stop(decrease, model.newton, shift_estimated)
            if stop is not None:
                return stop == "done", stop in ("stalled", "blocked")
        return False, False

    def _estimate_shift(self, w: np.ndarray | None, e_norm: float) -> bool:
        """Near the target, set the terminal shift from the multiplier estimate w; whether it was tried.

        The penalty's optimum keeps e = (2Q)⁻¹λ_e − s; with w ≈ λ_e, the shift s = (2Q)⁻¹w puts that optimum at e = 0
        now instead of after a stalled inner solve.
        """
        o = self.o
        if w is None or o.terminal != "constraint" or not e_norm < 100.0 * o.tol or self.ev.violation != 0.0:
            return False
        s_new = np.linalg.lstsq(2.0 * self.ocp.Q, w, rcond=1e-12)[0]
        if np.all(np.isfinite(s_new)):
            self.merit.shift = s_new
            ev_s = self.merit.evaluate(self.u)
            assert ev_s is not None  # the same trajectory
            self.ev = ev_s
        return True

    def _model(self, w: np.ndarray | None, newton: bool, st: StateTerms) -> _Model:
        """The terminal model (Newton with multiplier w, or Gauss–Newton while a state term is active), the state
        terms ``st`` (LM-damped on the states in the Riccati pass), and the (model, damping) pairs to try."""
        ocp, ev, cond = self.ocp, self.ev, self.cond
        gf, Hf = terminal_model(ocp, ev, w)
        lx, lxx = st.lx, st.lxx
        if st.al or (st.active and st.rows is None):
            # the multiplier estimate ignores the AL terms: Gauss–Newton while a bound is active (and while a
            # clearance cost that cannot list its rows is near: the Riccati pass takes those steps)
            newton = False
            gf, Hf = terminal_model(ocp, ev, None)
        if st.active and self.rho_x > 0:
            # Levenberg–Marquardt on the states (a trust region on δx at every knot)
            lxx = lxx + self.rho_x if lxx.ndim == 2 else lxx + self.rho_x * self.eye2
        vx = gf + lx[-1]
        Hf_b = Hf.copy()
        add_state_hessian(Hf_b, lxx[-1])
        hscale = max(float(np.linalg.norm(Hf_b, 2)), 1e-12)
        lm, wmin = self.lm, cond.wmin
        tries: list[tuple[str, float]] = []
        if newton:
            # convexify: the condensed Hessian W⁻¹ + H_f must be positive definite; lift its smallest
            # eigenvalue to λ_min(W⁻¹) (the running cost's own stiffness at x_n) where it is not
            lmin = float(np.linalg.eigvalsh(cond.Winv + Hf_b)[0])
            base = max(0.0, wmin - lmin)
            tries += [("newton", base + lm), ("newton", base + lm + wmin), ("newton", base + lm + 16.0 * wmin)]
        tries += [("gauss_newton", lm)]
        tries += [("gauss_newton", lm + 10.0**p * hscale) for p in range(-6, 3)]
        riccati = st.al or st.rows is None
        return _Model(newton, vx, Hf_b, hscale, lx, lxx, st.active, tries, riccati, st.rows, st.row_pairs)

    def _search(self, model: _Model) -> _Accepted | None:
        """The first (model, damping) whose LQ step passes the line search."""
        ocp, ev = self.ocp, self.ev
        n_back = 0
        for mode, mu in model.tries:
            H = model.Hf_b if mode == "newton" or not model.newton else gauss_newton_hessian(ocp, ev, model.lxx[-1])
            Vxx = H + mu * self.eye2
            n_back += 1
            condensed = self.o.backward == "auto" and not (model.state_active and model.riccati)
            rows = model.rows if model.state_active else None
            step = lq_step(
                ocp,
                self.cond,
                self.u,
                ev.q,
                ev.qd,
                Vxx,
                model.vx,
                model.lx,
                model.lxx,
                condensed=condensed,
                rows=rows,
                max_travel=self.o.max_travel,
            )
            if step is None or not step.d1 < 0:
                continue
            rows_soc = condensed and ocp.clearance is not None and (rows is None or model.row_pairs is not None)
            acc = self._line_search(step, (model, Vxx) if rows_soc else None)
            if acc is not None:
                return dataclasses.replace(acc, backward_passes=n_back, mode=mode, mu=mu, kind=step.kind)
        return None

    def _line_search(self, step: LQStep, rows_model: tuple[_Model, np.ndarray] | None = None) -> _Accepted | None:
        """Armijo backtracking on the merit from α ≤ max_travel / (the α = 1 step's joint travel), with a
        second-order correction of a rejected full closed-form step (with a clearance cost and ``rows_model`` = the
        step's (model, V_xx): first :meth:`_rows_corrected`)."""
        o, ev = self.o, self.ev
        # trust region on joint travel: the α = 1 step's largest joint motion along the trajectory
        u1 = step.trial(1.0)
        q1, _ = self.ocp.rollout(u1)
        travel = float(np.max(np.abs(q1 - ev.q)))
        alpha = min(1.0, o.max_travel / travel) if travel > 0 else 1.0
        trials = 0
        for b in range(o.max_backtracks + 1):
            trials += 1
            u_t = u1 if alpha == 1.0 else step.trial(alpha)
            ev_t = self.merit.evaluate(u_t)  # None: degenerate
            expected = alpha * step.d1 + alpha * alpha * step.d2
            if ev_t is not None and ev_t.merit <= ev.merit + o.armijo * min(expected, 0.0):
                return _Accepted(alpha, ev_t, expected, trials, travel)
            # the rows' correction where the clearance cost grew along the step (else the terminal one alone)
            first = b == 0 and o.soc and step.kind == "condensed"
            if first and rows_model is not None and ev_t is not None and ev_t.clearance > ev.clearance:
                trials += 1
                ev_c = self._rows_corrected(ev_t, alpha, expected, *rows_model)
                if ev_c is not None:
                    return _Accepted(alpha, ev_c, expected, trials, travel)
            if b == 0 and o.soc and ev_t is not None and step.kind == "condensed":
                trials += 1
                ev_c = self._corrected(ev_t, expected)
                if ev_c is not None:
                    return _Accepted(alpha, ev_c, expected, trials, travel)
            alpha *= 0.5
        return None

    def _corrected(self, ev_t: Evaluation, expected: float) -> Evaluation | None:
        """The second-order correction of a rejected trial point, if it passes the Armijo test without more violation.

        The Maratos effect: the stiff terminal penalty rejects good steps whose error is second order; the
        minimum-energy change of u that cancels the linearised terminal error at the trial point and keeps q̇_n, in
        closed form (:func:`~coop_ga.control.ilqr.lq.second_order_correction`).
        """
        o, ev = self.o, self.ev
        u_c = second_order_correction(self.ocp, self.cond, ev_t.u, ev_t.Je, ev_t.es)
        ev_c = self.merit.evaluate(u_c) if u_c is not None else None
        if (
            ev_c is not None
            and ev_c.violation <= ev.violation
            and ev_c.merit <= ev.merit + o.armijo * min(expected, 0.0)
        ):
            return ev_c
        return None

    def _rows_corrected(
        self, ev_t: Evaluation, alpha: float, expected: float, model: _Model, Vxx: np.ndarray
    ) -> Evaluation | None:
        """The second-order correction of a rejected trial point ``ev_t`` (step length α) of a closed-form step with
        a clearance cost, if it passes the Armijo test without more violation.

        The clearance rows and the terminal error are linear in the LQ model, but the distances and e(q_n) change
        to second order along a step (a 0.3 m link turned by 0.08 rad moves ~1 mm off its tangent, which the
        hinge's weight 1e4 prices at ~5e-3 per row and knot: measured, these rejected the obstacle scene's late
        steps, whose predicted decrease was 1e-2 … 1e-4).  The step is solved again from the same point with the
        model that matches the trial point to first order: every row within the look-ahead at the trial point,
        linearised there (``v_r + J_r Δq_k`` with Δq the trial's displacement; rows the trial does not list keep
        their model), and the terminal gradient shifted by the second-order part of e along the step; the new
        step is tried at the same α.
        """
        ocp, ev, merit, o = self.ocp, self.ev, self.merit, self.o
        rt, pt = merit.rows_with_pairs(ev_t.q, merit.lookahead)
        if rt is None or pt is None:
            return None
        dq = ev_t.q - ev.q
        k, J, v = rt.knots, rt.J, rt.v + np.einsum("ri,ri->r", rt.J, dq[rt.knots])
        rows = model.rows if model.state_active else None
        if rows is not None and model.row_pairs is not None:
            span = int(max(np.max(pt, initial=0), np.max(model.row_pairs, initial=0))) + 1
            keep = ~np.isin(rows.knots * span + model.row_pairs, k * span + pt)
            k, J, v = (
                np.concatenate([k, rows.knots[keep]]),
                np.vstack([J, rows.J[keep]]),
                np.concatenate([v, rows.v[keep]]),
            )
        n = ocp.nq
        de = ev_t.e - ev.e - ev.Je @ dq[-1]
        vx = model.vx.copy()
        vx[:n] += 2.0 * ev.Je.T @ (ocp.Q @ de)
        step = lq_step(
            ocp,
            self.cond,
            self.u,
            ev.q,
            ev.qd,
            Vxx,
            vx,
            model.lx,
            model.lxx,
            condensed=True,
            rows=ClearanceRows(k, J, v, rt.w),
            max_travel=o.max_travel,
        )
        if step is None or step.kind != "condensed":
            return None
        ev_c = merit.evaluate(step.trial(alpha))
        if ev_c is None or ev_c.violation > ev.violation or not ev_c.merit <= ev.merit + o.armijo * min(expected, 0.0):
            return None
        return ev_c

    def _adapt_damping(self, acc: _Accepted, decrease: float, hscale: float) -> None:
        """Levenberg–Marquardt updates from the step quality (actual / predicted decrease, cut steps)."""
        wmin = self.cond.wmin
        # on the terminal model (a trust region in x_n): a step whose decrease is far below the model's, or that had
        # to be cut, asks for more damping; a good full step for less
        ratio_t = decrease / max(-acc.expected, 1e-300)
        if ratio_t < 0.25 or acc.alpha < 1.0:
            self.lm = max(4.0 * self.lm, wmin) if self.lm < 1e6 * hscale else self.lm
        elif ratio_t > 0.75:
            self.lm = self.lm / 4.0 if self.lm / 4.0 >= wmin else 0.0
        if acc.kind == "riccati":
            ratio = decrease / max(-acc.expected, 1e-300)
            if acc.alpha < 1.0 or ratio < 0.25:  # a poor model: damp the state deviations more
                self.rho_x = max(4.0 * self.rho_x, wmin)
            elif ratio > 0.5:
                self.rho_x = self.rho_x / 4.0 if self.rho_x / 4.0 >= wmin else 0.0

    def _record(self, acc: _Accepted, decrease: float, t_it: float) -> None:
        """Move to the accepted point and append its history entries and statistics."""
        p = self.progress
        self.ev = ev = acc.ev
        self.u = ev.u
        p.iterations += 1
        p.costs.append(ev.cost)
        p.errs.append(float(np.linalg.norm(ev.e)))
        p.stats.append(
            ILQRIteration(
                cost=ev.cost,
                error=p.errs[-1],
                alpha=acc.alpha,
                mu=acc.mu,
                expected_decrease=-acc.expected,
                actual_decrease=decrease,
                line_search_trials=acc.trials,
                backward_passes=acc.backward_passes,
                time_s=time.perf_counter() - t_it,
                model=acc.mode,
                merit=ev.merit,
                outer=p.outer,
                violation=ev.violation,
                travel=acc.alpha * acc.travel,
                backward=acc.kind,
            )
        )

    def _stop(self, decrease: float, newton: bool, shift_estimated: bool) -> str | None:
        """Why the inner loop stops after a step: ``"done"``, ``"stalled"``, ``"update"`` (go to the outer update),
        or None (go on)."""
        o, ev, errs = self.o, self.ev, self.progress.errs
        if self._done(ev):
            return "done"
        if self._blocked():
            return "blocked"
        if decrease <= o.ftol * max(abs(ev.merit), 1e-300):
            return "stalled"
        # near the target the penalty's own optimum keeps e ≈ λ_e/(2Q): once a Newton step no longer halves
        # ‖e‖, shift the terminal target (the multiplier update) instead of creeping toward that optimum
        near = o.terminal == "constraint" and newton and errs[-1] < 100.0 * o.tol
        if near and errs[-1] > 0.5 * errs[-2] and ev.violation <= o.al_violation and not shift_estimated:
            return "update"
        # the AL subproblem is solved well enough: update the multipliers now (the penalty optimum keeps a
        # violation ~ λ*/μ that only the outer update removes)
        if ev.violation > o.al_violation and (self._reached(ev) or decrease <= o.al_inner_tol * abs(ev.merit)):
            return "update"
        return None

    def _blocked(self) -> bool:
        """The stall test (module constants; package docstring, "Fast honest failure"); sets the message when it holds.

        Only a run that cannot converge stops here: ‖e‖ no longer decreases while the limits block every first-order
        descent direction of ‖e‖ at the end configuration (or none is left), so neither more iterations nor the
        AL's terminal shift move it; :func:`ilqr_reach` then tries its restart from the bounded Gauss–Newton IK.
        """
        errs, ev = self.progress.errs, self.ev
        # errs[0] is the initial guess's error: the window holds accepted iterations only
        if len(errs) < STALL_WINDOW + 2 or ev.violation > 0.0 or not errs[-1] > STALL_FLOOR * self.o.tol:
            return False
        if errs[-1] < (1.0 - STALL_DECREASE) * errs[-1 - STALL_WINDOW]:
            return False
        kkt = bounded_stationarity(self.ocp, ev.q[-1], ev.e, ev.Je)
        if not kkt < STALL_STATIONARITY:
            return False
        self.blocked = True
        self.progress.message = (
            f"stationary: ‖e‖ fell by less than {100 * STALL_DECREASE:g} % over the last {STALL_WINDOW} iterations and "
            "the end configuration is a stationary point of ‖e‖ within the limits (every descent direction blocked by "
            f"a limit, or none left: projected gradient {kkt:.1e} of its scale), so the target is not reachable "
            "inside the limits from this start"
        )
        return True
