"""coop_ga's cooperative similarity error as a crocoddyl residual (loco-3d/crocoddyl): optimal control with FDDP.

:class:`SimilarityResidual` is a ``crocoddyl.ResidualModelAbstract`` whose residual is coop_ga's cooperative
similarity error ``r(x) = e(q) = log(Ṽ_Sc(q) V_Sd)`` (Eq 44; 7-vector on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``) with
its exact Jacobian ``∂e/∂q`` (Eq 47), both from the task's compiled error function in one call.  The residual
depends on q only: ``Rx = [∂e/∂q, 0]`` (7 × 2nv) and ``Ru = 0``.  A crocoddyl cost is put on it with
``CostModelResidual`` (and any activation).

:func:`reach_problem` builds the reach of coop_ga's iLQR (:func:`coop_ga.control.ilqr_reach`) as a crocoddyl
``ShootingProblem`` on the robot's rigid-body dynamics (``DifferentialActionModelFreeFwdDynamics``, gravity on,
every joint actuated: ``ActuationModelFull``), integrated by explicit Euler:

* running cost ``w_u ‖τ − g(q)‖² + w_x ‖x − x_0‖²`` (torque about gravity compensation, state about the start);
* terminal cost ``w_e ‖e(q_n)‖² + w_v ‖q̇_n‖²`` (the similarity error and rest).

``crocoddyl.SolverBoxFDDP`` then keeps the torques within the model's effort limits.  coop_ga's iLQR solves the
kinematic problem (a double integrator, Eq 53–57); the two reach the same primitive, not the same trajectory.

:func:`double_integrator_problem` is coop_ga's iLQR's own problem instead (:class:`~coop_ga.control.ilqr.ReachingOCP`:
the double integrator with exact zero-order hold, ``Σ uᵀRu + e(q_n)ᵀQe(q_n) + q̇_nᵀQ_vq̇_n`` with the terminal error
through :class:`SimilarityResidual`, the acceleration bounds as the control box of ``SolverBoxFDDP``, the position
and velocity bounds as an optional quadratic-barrier penalty): the crocoddyl row of ``benchmarks/ocp.py``.

Versions: crocoddyl 3.2.1 (the last on the package index) is built against Pinocchio 4.0; with Pinocchio 4.1 it
imports but its free forward dynamics disagree with ``pin.aba`` and its frame costs crash, so the ``crocoddyl``
extra pins ``pin==4.0.0``.  The systems of coop_ga have revolute and prismatic joints only (nq = nv).
"""

from __future__ import annotations

from typing import Any

import crocoddyl
import numpy as np
import pinocchio as pin

from .. import validation
from ..errors import InvalidInputError

__all__ = ["SimilarityResidual", "SimilarityResidualData", "double_integrator_problem", "reach_problem"]


class SimilarityResidual(crocoddyl.ResidualModelAbstract):
    """The cooperative similarity error e(q) (7,) of a coop_ga task as a crocoddyl residual (module docstring).

    Args:
        state: a ``crocoddyl.StateMultibody`` on the task's system (nq = nv = the task's nq).
        task: a :class:`~coop_ga.CooperativeTask`.
        target: V_Sd, a :class:`~coop_ga.Similarity` in the task's chart (e.g. from
            :func:`~coop_ga.control.displaced_target`).
        nu: the control dimension of the action model the residual is used in (default ``state.nv``).

    Raises:
        InvalidInputError: a state whose nq or nv is not the task's nq; a target that is not a similarity.
    """

    def __init__(self, state: Any, task: Any, target: Any, nu: int | None = None):
        nq = int(task.nq)
        if int(state.nq) != nq or int(state.nv) != nq:
            raise InvalidInputError(
                f"the crocoddyl state has nq = {state.nq}, nv = {state.nv}, the coop_ga task '{task.name}' nq = nv = "
                f"{nq}: build it with crocoddyl.StateMultibody on the task's system model"
            )
        crocoddyl.ResidualModelAbstract.__init__(
            self, state, 7, int(state.nv if nu is None else nu), True, False, False
        )
        self.task = task
        self.target = task.check_target(target)

    def calc(self, data: Any, x: Any, u: Any = None) -> None:
        """``data.r ← e(q)`` (7,); the Jacobian of the same compiled call is kept for :meth:`calcDiff`."""
        q = np.asarray(x, dtype=float)[: self.task.nq]
        e, J = self.task.error_and_jacobian(q, self.target)
        data.r[:] = e
        data.J[:] = J
        data.q[:] = q

    def calcDiff(self, data: Any, x: Any, u: Any = None) -> None:
        """``data.Rx ← [∂e/∂q, 0]`` (7, 2nv); crocoddyl calls :meth:`calc` at the same x first (recomputed if not)."""
        q = np.asarray(x, dtype=float)[: self.task.nq]
        if not np.array_equal(data.q, q):
            self.calc(data, x, u)
        data.Rx[:, : self.task.nq] = data.J

    def createData(self, collector: Any) -> SimilarityResidualData:
        """The residual's data (crocoddyl asks the model for it)."""
        return SimilarityResidualData(self, collector)

    def __repr__(self) -> str:
        return f"SimilarityResidual(task={self.task.name!r}, nr=7, nu={self.nu})"


class SimilarityResidualData(crocoddyl.ResidualDataAbstract):
    """crocoddyl's residual data plus the Jacobian ``J`` (7, nq) of the last :meth:`SimilarityResidual.calc` and
    its configuration ``q`` (nq,)."""

    def __init__(self, model: SimilarityResidual, collector: Any):
        crocoddyl.ResidualDataAbstract.__init__(self, model, collector)
        nq = int(model.task.nq)
        self.J = np.zeros((7, nq))
        self.q = np.full(nq, np.nan)  # no calc yet


def reach_problem(
    task: Any,
    q_init: Any,
    target: Any,
    *,
    horizon: int = 100,
    dt: float = 0.02,
    w_error: float = 1e5,
    w_rest: float = 1e1,
    w_control: float = 1e-3,
    w_state: float = 1e-2,
) -> crocoddyl.ShootingProblem:
    """The reach of ``task`` from rest at ``q_init`` to ``target`` as a crocoddyl shooting problem (module docstring).

    Args:
        task: a :class:`~coop_ga.CooperativeTask` (its system's Pinocchio model is copied: gravity on).
        q_init: (nq,) start configuration [rad], at rest.
        target: V_Sd, a :class:`~coop_ga.Similarity` in the task's chart.
        horizon: number of running nodes n (≥ 1); dt: the Euler step [s] (> 0).
        w_error: weight of ‖e(q_n)‖² (terminal); w_rest: of ‖q̇_n‖² [1/(rad/s)²] (terminal).
        w_control: of ‖τ − g(q)‖² [1/(N m)²]; w_state: of ‖x − x_0‖² (running).

    Returns:
        a ``crocoddyl.ShootingProblem`` (x = [q; q̇] (2nq,), u = τ (nq,) [N m]); solve it with
        ``crocoddyl.SolverBoxFDDP`` (torques within the model's effort limits) or ``SolverFDDP``.

    Raises:
        InvalidInputError: a wrong q_init, horizon, dt or weight, or a target that is not a similarity.
    """
    nq = int(task.nq)
    q0 = validation.configuration(q_init, nq, "q_init", owner=f"task '{task.name}'")
    n = validation.integer(horizon, "horizon", minimum=1)
    step = validation.positive(dt, "dt")
    w = {
        k: validation.nonnegative(v, k)
        for k, v in dict(w_error=w_error, w_rest=w_rest, w_control=w_control, w_state=w_state).items()
    }
    state = crocoddyl.StateMultibody(pin.Model(task.system.model))
    actuation = crocoddyl.ActuationModelFull(state)
    nu = int(actuation.nu)
    x0 = np.concatenate([q0, np.zeros(nq)])

    running = crocoddyl.CostModelSum(state, nu)
    running.addCost(
        "control", crocoddyl.CostModelResidual(state, crocoddyl.ResidualModelControlGrav(state, nu)), w["w_control"]
    )
    running.addCost(
        "state", crocoddyl.CostModelResidual(state, crocoddyl.ResidualModelState(state, x0, nu)), w["w_state"]
    )
    terminal = crocoddyl.CostModelSum(state, nu)
    terminal.addCost(
        "similarity", crocoddyl.CostModelResidual(state, SimilarityResidual(state, task, target, nu)), w["w_error"]
    )
    rest = crocoddyl.ActivationModelWeightedQuad(np.concatenate([np.zeros(nq), np.ones(nq)]))
    terminal.addCost(
        "rest", crocoddyl.CostModelResidual(state, rest, crocoddyl.ResidualModelState(state, x0, nu)), w["w_rest"]
    )

    def model(costs: Any, h: float) -> Any:
        dam = crocoddyl.DifferentialActionModelFreeFwdDynamics(state, actuation, costs)
        return crocoddyl.IntegratedActionModelEuler(dam, h)

    return crocoddyl.ShootingProblem(x0, [model(running, step)] * n, model(terminal, 0.0))


class _DoubleIntegrator(crocoddyl.ActionModelAbstract):
    """One knot of :func:`double_integrator_problem`: ``x⁺ = A x + B u`` (exact ZOH, or x⁺ = x at the terminal
    node) and the cost of a ``crocoddyl.CostModelSum``."""

    def __init__(self, state: Any, costs: Any, A: np.ndarray, B: np.ndarray, terminal: bool):
        crocoddyl.ActionModelAbstract.__init__(self, state, int(B.shape[1]), int(costs.nr))
        self.costs, self.A, self.B, self.terminal = costs, A, B, terminal
        self._zero = np.zeros(int(B.shape[1]))

    def calc(self, data: Any, x: Any, u: Any = None) -> None:
        u = self._zero if u is None or self.terminal else u
        self.costs.calc(data.costs, x, u)
        data.cost = data.costs.cost
        data.xnext[:] = x if self.terminal else self.A @ x + self.B @ u

    def calcDiff(self, data: Any, x: Any, u: Any = None) -> None:
        u = self._zero if u is None or self.terminal else u
        self.costs.calcDiff(data.costs, x, u)
        c = data.costs
        data.Lx[:], data.Lxx[:] = c.Lx, c.Lxx
        if not self.terminal:
            data.Fx[:], data.Fu[:] = self.A, self.B
            data.Lu[:], data.Luu[:], data.Lxu[:] = c.Lu, c.Luu, c.Lxu

    def createData(self) -> Any:
        return _DoubleIntegratorData(self)


class _DoubleIntegratorData(crocoddyl.ActionDataAbstract):
    def __init__(self, model: _DoubleIntegrator):
        crocoddyl.ActionDataAbstract.__init__(self, model)
        self.collector = crocoddyl.DataCollectorAbstract()
        self.costs = model.costs.createData(self.collector)


def _diagonal(W: np.ndarray, what: str) -> np.ndarray:
    """The diagonal of a weight matrix that must be diagonal (crocoddyl's weighted activations)."""
    d = np.diag(W).copy()
    if not np.allclose(W, np.diag(d)):
        raise InvalidInputError(f"{what} must be diagonal for crocoddyl's weighted quadratic activation")
    return d


def double_integrator_problem(ocp: Any, *, state_bounds: float | None = None) -> crocoddyl.ShootingProblem:
    """coop_ga's reaching OCP (Eq 53–57, :class:`~coop_ga.control.ilqr.ReachingOCP`) as a crocoddyl shooting problem
    on the same double integrator: the same knots, dynamics (x = [q; q̇], u = q̈, exact ZOH), cost and control box.

    * running nodes k = 0 … n−1: ``u_kᵀ R u_k`` (``ResidualModelControl``, weights 2R) and x⁺ = A x + B u;
    * terminal node: ``e(q_n)ᵀ Q e(q_n)`` (:class:`SimilarityResidual`, weights 2Q) + ``q̇_nᵀ Q_v q̇_n``;
    * the acceleration bounds ``|u_k| ≤ a`` as the action models' control limits (``u_lb``, ``u_ub``): exact for
      ``crocoddyl.SolverBoxFDDP``;
    * the position and velocity bounds at the knots 1 … n (FDDP has no state constraints): with ``state_bounds``
      (a weight) a ``ActivationModelQuadraticBarrier`` penalty ``weight · ½ dist(x, box)²`` — not a constraint, so
      its solution may violate them (measure it); None (default): left out.

    R, Q, Q_v must be diagonal (crocoddyl's weighted activations).  The problem holds Python action models (one
    call per knot per pass), as a crocoddyl user of this residual would write them.

    Raises:
        InvalidInputError: a non-diagonal weight, or a task whose system has nq ≠ nv.
    """
    task, n = ocp.task, int(ocp.nq)
    state = crocoddyl.StateMultibody(pin.Model(task.system.model))
    r2, q2, qv2 = (2.0 * _diagonal(W, name) for W, name in ((ocp.R, "R"), (ocp.Q, "Q"), (ocp.Qv, "Qv")))
    x0 = np.concatenate([ocp.q_init, ocp.qd_init])
    running = crocoddyl.CostModelSum(state, n)
    ctrl = crocoddyl.ResidualModelControl(state, n)
    running.addCost("control", crocoddyl.CostModelResidual(state, crocoddyl.ActivationModelWeightedQuad(r2), ctrl), 1.0)
    lo = np.concatenate([ocp.q_lower, -ocp.v_max])
    hi = np.concatenate([ocp.q_upper, ocp.v_max])
    if state_bounds is not None and np.any(np.isfinite(lo) | np.isfinite(hi)):
        big = 1e10  # crocoddyl's bounds must be finite
        act = crocoddyl.ActivationModelQuadraticBarrier(
            crocoddyl.ActivationBounds(np.maximum(lo, -big), np.minimum(hi, big))
        )
        res = crocoddyl.ResidualModelState(state, np.zeros(2 * n), n)
        bounds = crocoddyl.CostModelResidual(state, act, res)
        running.addCost("bounds", bounds, validation.positive(state_bounds, "state_bounds"))
    terminal = crocoddyl.CostModelSum(state, n)
    sim = SimilarityResidual(state, task, ocp.target, n)
    terminal.addCost(
        "similarity", crocoddyl.CostModelResidual(state, crocoddyl.ActivationModelWeightedQuad(q2), sim), 1.0
    )
    rest = crocoddyl.ActivationModelWeightedQuad(np.concatenate([np.zeros(n), qv2]))
    zero = crocoddyl.ResidualModelState(state, np.zeros(2 * n), n)  # x itself: its q̇ part is q̇_n
    terminal.addCost("rest", crocoddyl.CostModelResidual(state, rest, zero), 1.0)
    if state_bounds is not None:
        terminal.addCost("bounds", bounds, state_bounds)  # the bound at knot n as well
    A, B = np.asarray(ocp.A, float), np.asarray(ocp.B, float)
    models = []
    for _ in range(ocp.horizon):
        m = _DoubleIntegrator(state, running, A, B, terminal=False)
        if np.all(np.isfinite(ocp.a_max)):
            m.u_lb, m.u_ub = -ocp.a_max, ocp.a_max.copy()
        models.append(m)
    return crocoddyl.ShootingProblem(x0, models, _DoubleIntegrator(state, terminal, A, B, terminal=True))
