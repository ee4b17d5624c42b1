"""The solver registry: one table of the public runners, read by every caller that dispatches on a name.

Every runner of :mod:`coop_ga.control` is registered with its options dataclass, its call signature and
the problem data it accepts besides the options (:class:`SolverEntry`):

* ``signature='reach'``: ``fn(task, q_init, target, options=None, **problem, **overrides)`` with a
  :class:`~coop_ga.Similarity` target (Gauss–Newton IK, differential IK, iLQR, impedance, avoidance);
* ``signature='point'``: ``fn(task, q_init, index, target_point, options=None, **problem, **overrides)``
  (an end point reaching a point: the nullspace and constrained runners of §4.2.5 and §4.3).

:func:`get_solver` resolves a name or alias (``'gn'``, ``'diffik'``, ``'ilqr'``, …);
:meth:`SolverEntry.solve` calls the runner with options as keywords; :func:`register_solver` adds one
(a user's runner with the same signature).  ``benchmarks/robustness.py``, the API conformance tests and
(through :func:`get_solver`) a sweep's job dispatch read this table, so a new runner is registered once::

    from coop_ga.control import SOLVERS, get_solver
    res = get_solver("diffik").solve(task, q0, target, steps=100)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from ..errors import InvalidInputError, UnknownNameError

__all__ = ["SOLVERS", "SolverEntry", "get_solver", "register_solver", "solver_names"]

SIGNATURES = ("reach", "point")


@dataclass(frozen=True)
class SolverEntry:
    """One registered runner.

    name: the canonical name (the function's).  function: the runner.  options: its options dataclass.
    signature: ``'reach'`` or ``'point'`` (module docstring).  aliases: other names it answers to.
    problem: keyword problem data it accepts besides the options (e.g. ``('qd_init',)``); required:
    those among them it cannot run without (``('collision_model',)``).
    quick: option overrides for a cheap call (a few steps), for warm-ups and conformance tests.
    """

    name: str
    function: Callable[..., Any]
    options: type
    signature: str = "reach"
    aliases: tuple[str, ...] = ()
    problem: tuple[str, ...] = ()
    required: tuple[str, ...] = ()
    quick: Mapping[str, Any] = field(default_factory=dict)

    @property
    def initial_velocity(self) -> bool:
        """Whether the runner starts from a given joint velocity (``qd_init``)."""
        return "qd_init" in self.problem

    def solve(self, *args: Any, **kwargs: Any) -> Any:
        """Call the runner: the positional problem of its signature, then problem data and option overrides."""
        return self.function(*args, **kwargs)


SOLVERS: dict[str, SolverEntry] = {}
_ALIASES: dict[str, str] = {}


def register_solver(
    name: str,
    fn: Callable[..., Any],
    options_cls: type,
    *,
    signature: str = "reach",
    aliases: tuple[str, ...] = (),
    problem: tuple[str, ...] = (),
    required: tuple[str, ...] = (),
    quick: Mapping[str, Any] | None = None,
    replace: bool = False,
) -> SolverEntry:
    """Register ``fn`` under ``name`` (and ``aliases``) with its options class; returns the entry.

    Raises:
        InvalidInputError: a name or alias already taken (unless ``replace``), an unknown signature, a
            non-callable function or an options class that is not a class.
    """
    if signature not in SIGNATURES:
        raise InvalidInputError(f"signature must be one of {SIGNATURES}, got {signature!r}")
    if not callable(fn) or not isinstance(options_cls, type):
        raise InvalidInputError(f"register_solver({name!r}): fn must be callable and options_cls a class")
    for n in (name, *aliases):
        owner = _ALIASES.get(n)
        if owner is not None and owner != name and not replace:
            raise InvalidInputError(f"solver name {n!r} is already registered for {owner!r}")
    if name in SOLVERS and not replace:
        raise InvalidInputError(f"solver {name!r} is already registered (pass replace=True to replace it)")
    entry = SolverEntry(
        name, fn, options_cls, signature, tuple(aliases), tuple(problem), tuple(required), dict(quick or {})
    )
    SOLVERS[name] = entry
    for n in (name, *aliases):
        _ALIASES[n] = name
    return entry


def get_solver(name: str) -> SolverEntry:
    """The entry of a solver name or alias; :class:`~coop_ga.errors.UnknownNameError` lists the known ones."""
    canonical = _ALIASES.get(name) if isinstance(name, str) else None
    if canonical is None:
        raise UnknownNameError(f"unknown solver {name!r}; registered: {', '.join(solver_names(aliases=True))}")
    return SOLVERS[canonical]


def solver_names(signature: str | None = None, *, aliases: bool = False) -> tuple[str, ...]:
    """The registered names (of one signature, or all), with their aliases if asked."""
    out: list[str] = []
    for e in SOLVERS.values():
        if signature is None or e.signature == signature:
            out += [e.name, *e.aliases] if aliases else [e.name]
    return tuple(out)


def _register_builtin() -> None:
    from .avoidance import AvoidanceOptions, avoidance_reach
    from .constrained import ConstrainedReachOptions, constrained_point_reach
    from .diffik import DiffIKOptions, diff_ik_reach
    from .gauss_newton import GaussNewtonOptions, gauss_newton_ik
    from .ilqr import ILQROptions, ilqr_reach
    from .impedance import ImpedanceOptions, simulate_impedance
    from .nullspace import NullspaceOptions, nullspace_point_reach

    register_solver(
        "gauss_newton_ik", gauss_newton_ik, GaussNewtonOptions, aliases=("gauss_newton", "gn"), quick={"max_iter": 2}
    )
    register_solver(
        "diff_ik_reach", diff_ik_reach, DiffIKOptions, aliases=("diff_ik", "diffik"), problem=("constraints",),
        quick={"steps": 2},
    )  # fmt: skip
    register_solver(
        "ilqr_reach", ilqr_reach, ILQROptions, aliases=("ilqr",), problem=("qd_init", "u_init"),
        quick={"max_iter": 1, "horizon": 5},
    )  # fmt: skip
    register_solver(
        "simulate_impedance", simulate_impedance, ImpedanceOptions, aliases=("impedance",), problem=("qd_init",),
        quick={"duration": 0.002},
    )  # fmt: skip
    register_solver(
        "avoidance_reach", avoidance_reach, AvoidanceOptions, aliases=("avoidance",), problem=("collision_model",),
        required=("collision_model",), quick={"steps": 2},
    )  # fmt: skip
    register_solver(
        "nullspace_point_reach", nullspace_point_reach, NullspaceOptions, signature="point", aliases=("nullspace",),
        problem=("V_hold", "constraints"), quick={"duration": 0.02},
    )  # fmt: skip
    register_solver(
        "constrained_point_reach", constrained_point_reach, ConstrainedReachOptions, signature="point",
        aliases=("constrained",), problem=("constraints",), quick={"steps": 2},
    )  # fmt: skip


_register_builtin()
