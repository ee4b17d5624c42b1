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

__all__ = ["SimilarityResidual", "SimilarityResidualData", "reach_problem"]


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
