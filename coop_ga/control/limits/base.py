"""The :class:`Limit` protocol: linear inequalities on the joint velocity q̇ of one step.

As mink's and pink's limits (``mink/limits/limit.py``: ``compute_qp_inequalities(configuration, dt)
→ (G, h)``), written on q̇ [rad/s] instead of Δq, and with joint boxes kept as boxes: a limit returns
:class:`Inequalities` ``(lower, upper, G, h, labels)`` meaning

    lower ≤ q̇ ≤ upper   (nq,) each, or None,       G q̇ ≤ h   (m, nq), (m,), or None,

which :func:`~coop_ga.control.solve_step` intersects (boxes elementwise, rows stacked) and hands to
the QP as simple bounds and rows (an active-set solver handles simple bounds at no cost).  A limit
with ``relaxable = True`` (the acceleration limit) may be dropped on a step where the others leave it
no feasible point; the step reports it, and the run's measured violation says by how much.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple, Protocol, runtime_checkable

import numpy as np

__all__ = ["Inequalities", "Limit", "UserConstraints"]


class Inequalities(NamedTuple):
    """``lower ≤ q̇ ≤ upper`` and ``G q̇ ≤ h`` (module docstring); ``labels`` name the rows of G."""

    lower: np.ndarray | None = None
    upper: np.ndarray | None = None
    G: np.ndarray | None = None
    h: np.ndarray | None = None
    labels: tuple[str, ...] = ()


@runtime_checkable
class Limit(Protocol):
    """What :func:`~coop_ga.control.solve_step` needs of a limit (module docstring)."""

    name: str

    def inequalities(self, configuration: Any, dt: float) -> Inequalities:
        """The inequalities on q̇ [rad/s] of a step of ``dt`` [s] from the configuration."""
        ...


class UserConstraints:
    """User rows ``G q̇ ≤ h`` as a :class:`Limit`: a :class:`~coop_ga.control.LinearConstraint`, a ``(G, h)``
    pair or a sequence of them (stacked once), or a function ``q → such rows`` evaluated at every step's q
    (e.g. obstacle half-spaces that depend on q).  Rows are labelled ``name[r]`` (``constraint k[r]``)."""

    relaxable = False
    name = "constraints"

    def __init__(self, constraints: Any, nq: int):
        from ..qp import LinearConstraint, stack_constraints

        self.nq = nq
        self.function: Callable[[np.ndarray], Any] | None = None
        self.rows: tuple[np.ndarray, np.ndarray, tuple[str, ...]] | None = None
        if callable(constraints) and not isinstance(constraints, LinearConstraint):
            self.function = constraints
        else:
            self.rows = stack_constraints(constraints, nq)

    def inequalities(self, configuration: Any, dt: float) -> Inequalities:
        from ..qp import stack_constraints

        if self.function is not None:
            G, h, labels = stack_constraints(self.function(configuration.q.copy()), self.nq)
        else:
            assert self.rows is not None  # static constraints: stacked once
            G, h, labels = self.rows
        return Inequalities(None, None, G, h, labels)
