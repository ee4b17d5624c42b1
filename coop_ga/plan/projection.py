"""Projection of a configuration onto a residual's zero set, inside the joint limits (bounded Gauss–Newton).

:func:`project` solves ``r(q) = 0`` for any residual of :mod:`coop_ga.plan.regions` (a region, a sampled
target, the rigid grasp, a stack of them) with the solver the cooperative IK uses,
:func:`~coop_ga.control.gauss_newton_ik`: Levenberg-damped Gauss–Newton steps with the *exact* Jacobian
(Eq 45–46), as a bounded least-squares QP (DAQP) whenever the step would leave the joint limits, with
Armijo backtracking; a trial point where the primitive degenerates is a rejected step.  The residual is
handed to that solver through :class:`_ResidualTask`, which presents it as a task whose error is r(q): one
solver, one set of options (:class:`~coop_ga.control.GaussNewtonOptions`).

Never NaN: a start where the primitive is degenerate (the task's guard raises
:class:`~coop_ga.errors.DegeneratePrimitiveError`) or a solve that does not reach ``tol`` is returned as
``converged=False`` with the solver's message; the configuration returned is always inside the limits.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..control.gauss_newton import GaussNewtonOptions, gauss_newton_ik
from ..diagnostics import collect_warnings
from ..errors import DegeneratePrimitiveError, InvalidInputError
from ..geometry.groups import Similarity

__all__ = ["PROJECTION_OPTIONS", "Projection", "project"]

#: defaults of a projection: a residual below 1e-8 (m, rad, log-scale), few iterations (a planner projects
#: many samples and gives up on a hard one rather than iterate), steps of at most 0.3 rad
PROJECTION_OPTIONS = GaussNewtonOptions(max_iter=40, tol=1e-8, max_step=0.3, stall_window=6, ftol=1e-4)


@dataclass(frozen=True)
class Projection:
    """Result of :func:`project`: ``converged`` (‖r‖ < tol inside the limits), the configuration ``q`` (nq,),
    the final ``error`` ‖r‖, ``iterations`` and the solver's ``message``."""

    converged: bool
    q: np.ndarray
    error: float
    iterations: int
    message: str


#: the target argument of the solver, which a residual does not use
_UNUSED_TARGET = Similarity.from_parts()


class _ResidualTask:
    """A residual presented as a task to :func:`~coop_ga.control.gauss_newton_ik`: its error is r(q), its
    Jacobian ∂r/∂q, its limits the system's (the target argument is unused)."""

    kind = "region"

    def __init__(self, residual: Any, system: Any) -> None:
        self.residual, self.system = residual, system
        self.nq = int(residual.nq)
        # with a free flyer (nv < nq) the residual's Jacobian is along q ⊕ v and the solver steps by integrate
        self.nv = int(getattr(residual, "nv", self.nq))
        self.name = f"{getattr(system, 'name', 'system')} region residual"

    def check_target(self, target: Any) -> Any:
        return target

    def chart_angle(self, q: Any) -> float:
        return 0.0  # a residual has no chart: nothing jumps

    def error_and_jacobian(self, q: Any, target: Any) -> tuple[np.ndarray, np.ndarray]:
        return self.residual.evaluate(q)


def project(
    residual: Any, system: Any, q_init: Any, options: GaussNewtonOptions | None = None, **overrides: Any
) -> Projection:
    """Move ``q_init`` (nq,) onto ``r(q) = 0`` inside ``system``'s joint limits (module docstring).

    Args:
        residual: anything with ``nq``, ``dim`` and ``evaluate(q) → (r, J)`` (:mod:`coop_ga.plan.regions`).
        system: the :class:`~coop_ga.systems.System` whose ``limits`` bound q.
        q_init: (nq,) start [rad or m]; outside the limits it is clipped onto them first.  The solver's warnings
            (degenerate trial points, a start outside the limits) are silenced: a planner projects many
            configurations, and the outcome is in the result.
        options: :class:`~coop_ga.control.GaussNewtonOptions` (default :data:`PROJECTION_OPTIONS`);
            keyword ``overrides`` replace fields.

    Returns:
        A :class:`Projection`; ``converged=False`` (never NaN) when the start is degenerate or the solver
        stops above ``tol``.

    With a free flyer (nq ≠ nv) the residual's Jacobian has nv columns along ``q ⊕ v`` and the Gauss–Newton
    steps move q by ``system.integrate`` (the quaternion stays unit); the limits bound the joints only.

    Raises:
        InvalidInputError: the residual's nq/nv are not the system's.
    """
    q0 = validation.configuration(q_init, int(residual.nq), "q_init")
    if (int(residual.nq), int(getattr(residual, "nv", residual.nq))) != (system.nq, system.nv):
        raise InvalidInputError(
            f"the residual has nq = {residual.nq}, nv = {getattr(residual, 'nv', residual.nq)}; system "
            f"'{getattr(system, 'name', '?')}' has nq = {system.nq}, nv = {system.nv}: build it from that system's task"
        )
    opts = options if options is not None else PROJECTION_OPTIONS
    task = _ResidualTask(residual, system)
    try:
        with collect_warnings(silent=True):
            res = gauss_newton_ik(task, q0, _UNUSED_TARGET, opts, **overrides)
    except DegeneratePrimitiveError as exc:
        return Projection(False, system.clip(q0), float("inf"), 0, f"degenerate primitive: {exc}")
    return Projection(bool(res.converged), np.asarray(res.q, float), float(res.error), int(res.iterations), res.message)
