"""What every controller shares: the result base class, options handling and input checks.

Every solver of :mod:`coop_ga.control` is called as
``solver(task, q_init, target, options=None, **overrides)``: problem data are arguments,
settings live in one frozen options dataclass per solver (``GaussNewtonOptions``,
``DiffIKOptions``, ``ILQROptions``, ``ImpedanceOptions``, ``NullspaceOptions``) whose
``__post_init__`` validates every field; keyword ``overrides`` replace fields of
``options`` (``gauss_newton_ik(task, q, V, max_iter=20)``) and unknown names are refused.

Names mean one thing everywhere:

* ``damping`` is λ of a damped least-squares inverse, ``Jᵀ(J Jᵀ + λ² I)⁻¹`` or
  ``(JᵀJ + λ² I)⁻¹Jᵀ`` — never λ², never an eigenvalue cut-off (that is ``rcond``);
* ``tol`` is the threshold on the task error ‖e‖ (7-vector norm) below which a result
  is ``converged``;
* ``q`` of a result is the final configuration (nq,); ``trajectory`` is (T, nq) where
  the solver produces one;
* ``error`` is the final ‖e‖; ``iterations`` the number of steps/iterations taken;
  ``message`` says why the solver stopped; ``warnings`` counts each warning condition
  that occurred during the call (each is emitted once, see :mod:`coop_ga.diagnostics`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np

from .. import validation
from ..diagnostics import collect_warnings
from ..errors import ChartError, InvalidInputError
from ..geometry.groups import SimilarityLike

__all__ = ["SolverResult", "resolve_options"]

O = TypeVar("O")


@dataclass(frozen=True, kw_only=True)
class SolverResult:
    """Fields every controller result has (module docstring).

    Attributes:
        converged: True iff the final error is below the solver's ``tol`` (and, for solvers
            with limits, the limits hold).
        error: final ‖e‖, e the 7-vector task error (mixed units: rad, log-scale, body length).
        iterations: iterations or steps taken.
        message: why the solver stopped.
        q: (nq,) final configuration [rad or m].
        warnings: ``{condition: count}`` of the warnings that occurred during the call.
    """

    converged: bool
    error: float
    iterations: int
    message: str
    q: np.ndarray
    warnings: dict[str, int] = field(default_factory=dict)


def resolve_options(cls: type[O], options: O | None, overrides: dict[str, Any], solver: str) -> O:
    """``options`` (default ``cls()``) with ``overrides`` applied; unknown names raise."""
    if options is None:
        options = cls()
    elif not isinstance(options, cls):
        raise InvalidInputError(f"{solver}: options must be a {cls.__name__}, got {type(options).__name__}")
    if overrides:
        names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
        unknown = sorted(set(overrides) - names)
        if unknown:
            raise InvalidInputError(f"{solver}: unknown option(s) {unknown}; {cls.__name__} has {sorted(names)}")
        options = dataclasses.replace(options, **overrides)  # type: ignore[type-var]
    return options


#: start configurations whose primitive axis is this close to the chart's antipode are refused [rad]
CHART_FLIP_ANGLE = np.deg2rad(179.0)


def check_problem(task: Any, q: Any, target: SimilarityLike, what: str = "q_init") -> tuple[np.ndarray, Any]:
    """The checks every reaching controller makes before it starts: q (nq,) and the target as a
    :class:`~coop_ga.Similarity` (:meth:`~coop_ga.CooperativeTask.check_target`: refused if it lies across
    the chart's half-turn), and a start that is not at the half-turn itself (there e = log(Ṽ_Sc V_Sd)
    jumps and no descent direction means anything): :class:`~coop_ga.errors.ChartError` with the fix."""
    qv = check_q(task, q, what)
    V = task.check_target(target)
    with collect_warnings(silent=True):  # the solver's own first evaluation reports the start's warnings
        theta = task.chart_angle(qv)
    if theta >= CHART_FLIP_ANGLE:
        raise ChartError(
            f"{what}: the {task.kind}'s axis is {np.degrees(theta):.1f}° from the chart axis of task '{task.name}', "
            "where V_Sc jumps by a half-turn; build the task with chart_axis='auto' (the default) or "
            "task.with_chart(<the primitive's axis at q_init>), or reorder the end points (points=...)"
        )
    return qv, V


def check_q(task: Any, q: Any, what: str = "q") -> np.ndarray:
    """A configuration of ``task`` (nq,) as a new float array (:func:`coop_ga.validation.configuration`); a free
    flyer's quaternion must be unit (:meth:`~coop_ga.systems.System.check_quaternions`: a controller would
    otherwise start from a pose Pinocchio silently normalises)."""
    qv = validation.configuration(q, task.nq, what, owner=f"task '{task.name}'")
    system = getattr(task, "system", None)
    if system is not None and system.nq != system.nv:
        system.check_quaternions(qv, what)
    return qv


def check_v(task: Any, v: Any, what: str = "velocity") -> np.ndarray:
    """A joint velocity of ``task`` (nv,) as a new float array (nv = nq without a free flyer)."""
    return validation.configuration(v, getattr(task, "nv", task.nq), what, owner=f"task '{task.name}'")


def bounds(task: Any) -> tuple[np.ndarray, np.ndarray]:
    """Joint position limits ``(lower, upper)`` (nq,) of the task's system [rad or m] (``system.limits``)."""
    lim = task.system.limits
    return lim.lower, lim.upper
