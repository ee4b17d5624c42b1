"""Bad-input campaign: the error contract of ``coop_ga.collision``, ``linkages``, ``legged``, ``systems`` and ``sweep``.

Every case calls one public function with one bad argument — NaN or inf, a wrong shape, a wrong type
(``None``, a string, a bool, a complex number, a dict, a ragged list), an out-of-range value (a negative
radius, a zero step, a huge count, a crank range too long to track) — and the rest valid.  The contract
(``coop_ga.errors``): such a call raises a :class:`~coop_ga.errors.CoopGAError` whose message names the
argument; it never returns NaN or inf, never accepts the bad value, never hangs and never modifies an input.

Each case's outcome is one of

* ``refused`` — a ``CoopGAError`` (the contract);
* ``other_exception`` — any other exception (``ValueError`` from numpy, ``TypeError``, ``AttributeError``, ...);
* ``nonfinite`` — the call returned, with NaN or inf somewhere in its result;
* ``accepted_invalid`` — the call returned a finite result for an invalid input;
* ``hang`` — the call did not return within ``--time-limit`` seconds (a SIGALRM in the worker; a worker that
  does not answer a few seconds later is killed and restarted at the next case);

and two flags: ``mutated`` (an argument changed during the call) and ``unnamed`` (a ``CoopGAError`` whose
message does not name the bad argument).  Cases run in one spawned worker process (address space capped at
``--memory-gb``, so a huge allocation is a ``MemoryError``, not a frozen machine); a case whose set-up itself
fails is a ``setup_error`` (a bug of this script).

Prints one summary row per module (cases, refused, non-CoopGAError, NaN/inf, accepted-invalid, hangs, mutated,
unnamed) and the failing cases; writes ``<out>/bad_inputs.json`` (config, per-case records, summary).  The
exit status is 0 if every module named in ``--require`` has no failure, 1 otherwise.

    python benchmarks/bad_inputs.py                 # every case (≥ 300)
    python benchmarks/bad_inputs.py --ci            # the first two cases of every function
    python benchmarks/bad_inputs.py --modules collision linkages --list
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import math
import multiprocessing as mp
import os
import re
import signal
import sys
import tempfile
import time
import types
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _timing import print_table

MODULES = ("collision", "linkages", "legged", "systems", "sweep")
OUTCOMES = ("refused", "other_exception", "nonfinite", "accepted_invalid", "hang", "setup_error")
FAILURES = ("other_exception", "nonfinite", "accepted_invalid", "hang", "setup_error")
NAN, INF = float("nan"), float("inf")


# ============================================================================ cases
@dataclass(frozen=True)
class Case:
    """One call with one bad argument.

    ``make(fixtures)`` returns ``(function, args, kwargs)``; ``arg`` is the argument the error message must
    name (a word, matched case-insensitively at word boundaries); ``bad`` says what is wrong with it.
    """

    module: str
    function: str
    arg: str
    bad: str
    make: Callable[[Fixtures], tuple[Callable[..., Any], tuple[Any, ...], dict[str, Any]]]

    @property
    def id(self) -> str:
        return f"{self.module}.{self.function}: {self.arg} = {self.bad}"


class Fixtures:
    """Valid objects the cases need, built lazily once per worker (cheap systems: no meshes, no compilation)."""

    @cached_property
    def np(self) -> Any:
        import numpy

        return numpy

    # ---------------------------------------------------------------- systems
    @cached_property
    def cart(self) -> Any:
        from coop_ga.systems import cartesian_points

        return cartesian_points(3)

    @cached_property
    def hexapod(self) -> Any:
        from coop_ga import systems

        return systems.load("hexapod")

    @cached_property
    def urdf(self) -> str:
        from coop_ga.systems import ROBOTS_DIR

        return str(ROBOTS_DIR / "hexapod" / "hexapod.urdf")

    @cached_property
    def tmp(self) -> Path:
        return Path(tempfile.mkdtemp(prefix="bad_inputs_"))

    def file(self, name: str, text: str) -> str:
        p = self.tmp / name
        p.write_text(text)
        return str(p)

    # ---------------------------------------------------------------- collision
    @cached_property
    def sphere(self) -> Any:
        from coop_ga.collision import Sphere

        return Sphere([0.0, 0.0, 0.5], 0.1)

    @cached_property
    def plane(self) -> Any:
        from coop_ga.collision import Plane

        return Plane([0.0, 0.0, 1.0], 0.0)

    @cached_property
    def capsules(self) -> tuple[Any, ...]:
        from coop_ga.collision import Capsule

        return tuple(Capsule(f"tip{i}", [0.0, 0.0, 0.0], [0.0, 0.0, 0.1], 0.05, chain=i) for i in range(3))

    @cached_property
    def cm(self) -> Any:
        from coop_ga.collision import CollisionModel

        return CollisionModel(self.cart, [self.sphere, self.plane], capsules=self.capsules)

    @cached_property
    def obstacle(self) -> Any:
        from coop_ga.collision.potential import obstacle

        return obstacle([0.5, 0.0, 0.0], 0.1)

    # ---------------------------------------------------------------- linkages
    @cached_property
    def fourbar(self) -> Any:
        from coop_ga.linkages import four_bar

        return four_bar(2.0, 0.5, 2.0, 1.5)

    def links(self, **change: Any) -> tuple[list[Any], list[Any]]:
        """The links and joints of a valid 4-bar, with ``change`` = {"link.point": value} applied."""
        from coop_ga.linkages import Link, Revolute

        pts = {
            "ground": {"O": [0.0, 0.0], "D": [2.0, 0.0]},
            "crank": {"O": [0.0, 0.0], "A": [0.5, 0.0]},
            "coupler": {"A": [0.5, 0.0], "B": [1.9, 1.2]},
            "rocker": {"D": [2.0, 0.0], "B": [1.9, 1.2]},
        }
        for k, v in change.items():
            ln, pn = k.split("__")
            pts[ln][pn] = v
        links = [Link(n, p) for n, p in pts.items()]
        joints = [
            Revolute(("crank", "A"), ("coupler", "A")),
            Revolute(("coupler", "B"), ("rocker", "B")),
            Revolute(("rocker", "D"), ("ground", "D")),
        ]
        return links, joints

    @cached_property
    def linkage(self) -> Any:
        from coop_ga.linkages import Linkage

        return Linkage(*self.links())

    # ---------------------------------------------------------------- legged
    @cached_property
    def legs(self) -> Any:
        from coop_ga.legged import hexapod_legs

        return hexapod_legs()

    @cached_property
    def state(self) -> Any:
        from coop_ga.legged import BodyState

        return BodyState([0.0, 0.0, 0.1], self.np.eye(3), self.legs.q_stand)

    @cached_property
    def feet(self) -> Any:
        return self.legs.fk(self.legs.q_stand)

    @cached_property
    def gait(self) -> Any:
        from coop_ga.legged import phase_table

        return phase_table("tripod")

    @cached_property
    def terrain(self) -> Any:
        from coop_ga.legged import Terrain

        return Terrain.flat()

    def plan(self, T: int = 3) -> dict[str, Any]:
        """A valid (tiny) contact_rollout plan: standing still for T samples."""
        np = self.np
        body = np.tile([0.0, 0.0, 0.0993, 0.0, 0.0, 0.0, 1.0], (T, 1))
        return {
            "t": np.arange(T) * 0.01,
            "q": np.tile(self.legs.q_stand, (T, 1)),
            "body": body,
            "stance": np.ones((T, 6), bool),
        }

    # ---------------------------------------------------------------- sweep
    @cached_property
    def job(self) -> dict[str, Any]:
        return {"system": "cartesian3", "kind": "circle", "controller": "gauss_newton"}


#: bad 3-vectors [m] (the wrong-type entries are shared by every vector argument)
BAD_VEC3: dict[str, Any] = {
    "NaN": [NAN, 0.0, 0.0],
    "inf": [0.0, INF, 0.0],
    "4 entries": [0.0, 0.0, 0.0, 0.0],
    "a string": "abc",
    "None": None,
    "complex": [1j, 0.0, 0.0],
    "bools": [True, False, True],
    "ragged": [[0.0, 1.0], [2.0]],
}
BAD_VEC2: dict[str, Any] = {"NaN": [NAN, 0.0], "inf": [INF, 0.0], "3 entries": [0.0, 0.0, 0.0], "a string": "ab"}
#: bad real numbers (for an argument that must be finite; ranges are added per argument)
BAD_REAL: dict[str, Any] = {"NaN": NAN, "inf": INF, "a string": "1.0", "None": None, "complex": 1j, "a list": [1.0]}
BAD_INT: dict[str, Any] = {"a float": 2.5, "a bool": True, "a string": "3", "None": None, "NaN": NAN}


def _is_fixture(a: Any) -> bool:
    """A function of one parameter named ``fx``: a value computed from the :class:`Fixtures` at run time."""
    code = getattr(a, "__code__", None)
    return isinstance(a, types.FunctionType) and code is not None and code.co_varnames[: code.co_argcount] == ("fx",)


def _at(a: Any, fx: Fixtures) -> Any:
    return a(fx) if _is_fixture(a) else a


def _call(f: Any, *args: Any, **kwargs: Any) -> Callable[[Fixtures], Any]:
    """A ``make`` for fixed arguments; ``f`` and the arguments may be fixtures (``lambda fx: ...``)."""

    def make(fx: Fixtures) -> tuple[Callable[..., Any], tuple[Any, ...], dict[str, Any]]:
        return _at(f, fx), tuple(_at(a, fx) for a in args), {k: _at(v, fx) for k, v in kwargs.items()}

    return make


def lazy(get: Callable[[Fixtures], Callable[..., Any]]) -> Callable[[Fixtures], Callable[..., Any]]:
    """A function looked up on the fixtures at run time (e.g. a bound method of a fixture)."""
    return get


def method(fixture: str, name: str) -> Callable[[Fixtures], Callable[..., Any]]:
    """The bound method ``name`` of the fixture ``fixture``, looked up at run time."""

    def get(fx: Fixtures) -> Callable[..., Any]:
        return getattr(getattr(fx, fixture), name)

    return get


class Builder:
    """Collects cases: ``b.add(function_name, arg, bad, f, *args, **kwargs)``; ``b.vary(...)`` for families."""

    def __init__(self, module: str):
        self.module = module
        self.cases: list[Case] = []

    def add(self, function: str, arg: str, bad: str, f: Any, *args: Any, **kwargs: Any) -> None:
        self.cases.append(Case(self.module, function, arg, bad, _call(f, *args, **kwargs)))

    def vary(
        self, function: str, arg: str, values: dict[str, Any], f: Any, build: Callable[[Any], tuple[tuple, dict]]
    ) -> None:
        """One case per bad value: ``build(value)`` gives the (args, kwargs) of the call."""
        for bad, v in values.items():
            args, kwargs = build(v)
            self.add(function, arg, bad, f, *args, **kwargs)


# ---------------------------------------------------------------------------- collision
def _collision_obstacles(b: Builder) -> None:
    """Bad inputs to coop_ga.collision: obstacles."""
    from coop_ga import collision as C

    z3 = [0.0, 0.0, 0.0]
    e3 = [0.0, 0.0, 1.0]
    b.vary("Sphere", "center", BAD_VEC3, C.Sphere, lambda v: ((v, 0.1), {}))
    b.vary("Sphere", "radius", {**BAD_REAL, "negative": -0.1, "zero": 0.0}, C.Sphere, lambda v: ((z3, v), {}))
    b.add("Sphere", "name", "an int", C.Sphere, z3, 0.1, name=3)
    b.vary("Plane", "normal", {**BAD_VEC3, "zero": z3}, C.Plane, lambda v: ((v, 0.0), {}))
    b.vary("Plane", "offset", BAD_REAL, C.Plane, lambda v: ((e3, v), {}))
    b.add("as_obstacle", "obstacle", "an int", C.as_obstacle, 5)
    b.add("as_obstacle", "obstacle", "a string", C.as_obstacle, "sphere")
    b.add("as_obstacle", "center", "NaN in a dict", C.as_obstacle, {"center": [NAN, 0, 0], "radius": 0.1})
    b.add("as_obstacle", "radius", "a string in a dict", C.as_obstacle, {"center": z3, "radius": "r"})
    b.add("as_obstacle", "obstacle", "a dict without fields", C.as_obstacle, {"x": 1})
    b.add("as_obstacle", "name", "a list", C.as_obstacle, {"center": z3, "radius": 0.1}, name=[1])


def _collision_point_measures(b: Builder) -> None:
    """Bad inputs to coop_ga.collision: point measures."""
    from coop_ga import collision as C

    sph = lambda fx: fx.sphere  # noqa: E731
    pln = lambda fx: fx.plane  # noqa: E731
    z3 = [0.0, 0.0, 0.0]
    e3 = [0.0, 0.0, 1.0]
    for name, f, other in (
        ("conformal_point", C.conformal_point, ()),
        ("point_sphere_product", C.point_sphere_product, (sph,)),
        ("point_sphere_distance", C.point_sphere_distance, (sph,)),
        ("point_plane_distance", C.point_plane_distance, (pln,)),
    ):
        b.vary(name, "x", BAD_VEC3, f, lambda v, other=other: ((v, *other), {}))
        b.add(name, "x", "1e200 (overflows |x|²)", f, [1e200, 0.0, 0.0], *other)
    b.add("point_sphere_distance", "sphere", "None", C.point_sphere_distance, z3, None)
    b.add("point_sphere_distance", "sphere", "a Plane", C.point_sphere_distance, z3, pln)
    b.add("point_plane_distance", "plane", "a dict", C.point_plane_distance, z3, {"normal": e3})
    b.add("point_sphere_product", "sphere", "a string", C.point_sphere_product, z3, "sphere")


def _collision_segments_and_capsules(b: Builder) -> None:
    """Bad inputs to coop_ga.collision: segments and capsules."""
    from coop_ga import collision as C

    sph = lambda fx: fx.sphere  # noqa: E731
    pln = lambda fx: fx.plane  # noqa: E731
    z3 = [0.0, 0.0, 0.0]
    e3 = [0.0, 0.0, 1.0]
    b.vary("segment_point_parameter", "a", BAD_VEC3, C.segment_point_parameter, lambda v: ((v, e3, z3), {}))
    b.add("segment_point_parameter", "c", "NaN", C.segment_point_parameter, z3, e3, [0.0, NAN, 0.0])
    b.vary("capsule_sphere_distance", "b", BAD_VEC3, C.capsule_sphere_distance, lambda v: ((z3, v, 0.05, sph), {}))
    b.vary(
        "capsule_sphere_distance",
        "radius",
        {**BAD_REAL, "negative": -0.05},
        C.capsule_sphere_distance,
        lambda v: ((z3, e3, v, sph), {}),
    )
    b.add("capsule_sphere_distance", "sphere", "a Plane", C.capsule_sphere_distance, z3, e3, 0.05, pln)
    b.vary("capsule_plane_distance", "a", BAD_VEC3, C.capsule_plane_distance, lambda v: ((v, e3, 0.05, pln), {}))
    b.add("capsule_plane_distance", "radius", "NaN", C.capsule_plane_distance, z3, e3, NAN, pln)
    b.add("capsule_plane_distance", "plane", "a Sphere", C.capsule_plane_distance, z3, e3, 0.05, sph)
    b.vary("segment_segment_closest", "q1", BAD_VEC3, C.segment_segment_closest, lambda v: ((z3, e3, [1, 0, 0], v), {}))
    b.vary(
        "capsule_capsule_distance",
        "a0",
        BAD_VEC3,
        C.capsule_capsule_distance,
        lambda v: ((v, e3, 0.05, [1, 0, 0], [1, 0, 1], 0.05), {}),
    )
    b.vary(
        "capsule_capsule_distance",
        "rb",
        {**BAD_REAL, "negative": -1.0},
        C.capsule_capsule_distance,
        lambda v: ((z3, e3, 0.05, [1, 0, 0], [1, 0, 1], v), {}),
    )
    b.add("capsule_capsule_distance", "b1", "1e200", C.capsule_capsule_distance, z3, e3, 0.0, z3, [1e200, 0, 0], 0.0)
    b.vary(
        "seed002_link_sphere_distance",
        "p_i",
        BAD_VEC3,
        C.seed002_link_sphere_distance,
        lambda v: ((v, e3, 0.02, sph), {}),
    )
    b.add("seed002_link_sphere_distance", "r2", "NaN", C.seed002_link_sphere_distance, z3, e3, NAN, sph)
    b.add("seed002_link_sphere_distance", "p_j", "equal to p_i", C.seed002_link_sphere_distance, z3, z3, 0.02, sph)


def _collision_capsules(b: Builder) -> None:
    """Bad inputs to coop_ga.collision: capsules."""
    from coop_ga import collision as C

    z3 = [0.0, 0.0, 0.0]
    e3 = [0.0, 0.0, 1.0]
    b.vary("Capsule", "a", BAD_VEC3, C.Capsule, lambda v: (("tip0", v, e3, 0.05), {}))
    b.vary("Capsule", "radius", {**BAD_REAL, "negative": -1.0}, C.Capsule, lambda v: (("tip0", z3, e3, v), {}))
    b.add("Capsule", "chain", "a string", C.Capsule, "tip0", z3, e3, 0.05, chain="arm")
    b.add("Capsule", "chain", "a float", C.Capsule, "tip0", z3, e3, 0.05, chain=1.5)
    b.add("Capsule", "frame", "an int", C.Capsule, 3, z3, e3, 0.05)
    b.add("Capsule", "link", "an int", C.Capsule, "tip0", z3, e3, 0.05, link=3)
    cap = lambda fx: fx.capsules[0]  # noqa: E731
    b.add("Capsule.point_distance", "points", "NaN", lazy(lambda fx: fx.capsules[0].point_distance), [[NAN, 0, 0]])
    b.add("Capsule.point_distance", "points", "(2, 2)", lazy(lambda fx: fx.capsules[0].point_distance), [[0, 0]] * 2)
    b.add("Capsule.point_distance", "points", "a string", lazy(lambda fx: fx.capsules[0].point_distance), "abc")
    b.add("Capsule.contains", "tol", "NaN", lazy(lambda fx: fx.capsules[0].contains), [z3], NAN)
    b.add("Capsule.contains", "tol", "negative", lazy(lambda fx: fx.capsules[0].contains), [z3], -1.0)
    del cap
    b.add("fit_capsule", "vertices", "NaN", C.fit_capsule, [[NAN, 0, 0], [1, 0, 0]])
    b.add("fit_capsule", "vertices", "a string", C.fit_capsule, "abc")
    b.add("fit_capsule", "vertices", "empty", C.fit_capsule, [])
    b.add("fit_capsule", "vertices", "(4, 2)", C.fit_capsule, [[0, 0], [1, 0], [0, 1], [1, 1]])
    b.add("fit_capsule", "vertices", "1e200", C.fit_capsule, [[1e200, 0, 0], [0, 1e200, 0], [0, 0, 0]])
    b.add("fit_capsules", "system", "None", C.fit_capsules, None)
    b.add("fit_capsules", "source", "'mesh'", C.fit_capsules, lambda fx: fx.hexapod, "mesh")
    b.add("fit_capsules", "links", "a string", C.fit_capsules, lambda fx: fx.hexapod, links="base_link")
    b.add("fit_capsules", "links", "an int", C.fit_capsules, lambda fx: fx.hexapod, links=3)
    b.add("link_meshes", "system", "a string", C.link_meshes, "hexapod")
    b.add("link_meshes", "source", "None", C.link_meshes, lambda fx: fx.hexapod, None)
    b.add("capsule_chain", "frame", "an int", C.capsule_chain, lambda fx: fx.hexapod, 3)
    b.add("capsule_chain", "frame", "unknown", C.capsule_chain, lambda fx: fx.hexapod, "nope")
    b.add("capsule_chain", "system", "None", C.capsule_chain, None, "base_link")


def _collision_model(b: Builder) -> None:
    """Bad inputs to coop_ga.collision: the CollisionModel."""
    from coop_ga import collision as C

    z3 = [0.0, 0.0, 0.0]
    e3 = [0.0, 0.0, 1.0]
    CM = C.CollisionModel
    b.add("CollisionModel", "system", "None", CM, None, capsules=lambda fx: fx.capsules)
    b.add("CollisionModel", "system", "a string", CM, "cartesian3", capsules=lambda fx: fx.capsules)
    b.vary(
        "CollisionModel",
        "margin",
        {**BAD_REAL, "negative": -0.01},
        CM,
        lambda v: ((lambda fx: fx.cart,), {"capsules": lambda fx: fx.capsules, "margin": v}),
    )
    b.add("CollisionModel", "capsules", "a string", CM, lambda fx: fx.cart, capsules="tip0")
    b.add("CollisionModel", "capsules", "unknown frame", CM, lambda fx: fx.cart, capsules=[C.Capsule("x", z3, e3, 0.1)])
    b.add("CollisionModel", "obstacles", "an int", CM, lambda fx: fx.cart, 5, capsules=lambda fx: fx.capsules)
    b.add(
        "CollisionModel",
        "obstacles",
        "NaN centre",
        CM,
        lambda fx: fx.cart,
        [{"center": [NAN, 0, 0], "radius": 1}],
        capsules=lambda fx: fx.capsules,
    )
    b.add(
        "CollisionModel",
        "self_collision",
        "a string",
        CM,
        lambda fx: fx.cart,
        capsules=lambda fx: fx.capsules,
        self_collision="yes",
    )
    for meth in ("distances", "distances_and_jacobian", "min_clearance", "closest", "capsule_segments"):
        f = method("cm", meth)
        b.add(f"CollisionModel.{meth}", "q", "NaN", f, [NAN] + [0.0] * 8)
        b.add(f"CollisionModel.{meth}", "q", "a string", f, "abc")
        b.add(f"CollisionModel.{meth}", "q", "8 entries", f, [0.0] * 8)
        b.add(f"CollisionModel.{meth}", "q", "None", f, None)
    b.add("CollisionModel.distances", "q", "batch with inf", lazy(lambda fx: fx.cm.distances), [[0.0] * 9, [INF] * 9])
    b.add("CollisionModel.min_clearance", "kind", "'arm'", lazy(lambda fx: fx.cm.min_clearance), [0.0] * 9, "arm")
    b.add("CollisionModel.mask", "kind", "None", lazy(lambda fx: fx.cm.mask), None)
    b.add("CollisionModel.symbolic", "q", "a numpy array", lazy(lambda fx: fx.cm.symbolic), [0.0] * 9)


def _collision_potential_fields(b: Builder) -> None:
    """Bad inputs to coop_ga.collision: potential fields."""
    from coop_ga.collision import potential as pot

    z3 = [0.0, 0.0, 0.0]
    b.vary("obstacle", "radius", {**BAD_REAL, "zero": 0.0}, pot.obstacle, lambda v: (([0, 0, 0], v), {}))
    b.vary("obstacle", "center", BAD_VEC3, pot.obstacle, lambda v: ((v, 0.1), {}))
    b.add("dual_sphere", "S", "a string", pot.dual_sphere, "S")
    b.add("safety_sphere", "margin", "NaN", pot.safety_sphere, lambda fx: fx.obstacle, NAN)
    b.add("safety_sphere", "margin", "negative", pot.safety_sphere, lambda fx: fx.obstacle, -1.0)
    b.vary(
        "signed_squared_distance", "x", BAD_VEC3, pot.signed_squared_distance, lambda v: ((v, pot.obstacle(z3, 1)), {})
    )
    b.add("charges", "security_radii", "negative", pot.charges, [-0.5], [[1, 0, 0]], z3)
    b.add("charges", "security_radii", "NaN", pot.charges, [NAN], [[1, 0, 0]], z3)
    b.add("charges", "centers", "(1, 2)", pot.charges, [0.1], [[1, 0]], z3)
    b.add("charges", "goal", "NaN", pot.charges, [0.1], [[1, 0, 0]], [NAN, 0, 0])
    b.add("charges", "rule", "'coulomb'", pot.charges, [0.1], [[1, 0, 0]], z3, "coulomb")
    b.add("equilibrium_distance", "q", "NaN", pot.equilibrium_distance, NAN, 1.0)
    b.add("equilibrium_distance", "q", "≥ 1", pot.equilibrium_distance, 1.5, 1.0)
    b.add("equilibrium_distance", "D", "a string", pot.equilibrium_distance, 0.1, "1")
    b.add("coulomb_potential", "x", "at a charge", pot.coulomb_potential, [1, 0, 0], [[1, 0, 0]], [0.1], z3)
    b.add("coulomb_potential", "x", "at the goal", pot.coulomb_potential, z3, [[1, 0, 0]], [0.1], z3)
    b.add("coulomb_potential", "x", "NaN", pot.coulomb_potential, [NAN, 0, 0], [[1, 0, 0]], [0.1], z3)
    b.add(
        "coulomb_potential",
        "q",
        "2 charges for 1 centre",
        pot.coulomb_potential,
        [0, 1, 0],
        [[1, 0, 0]],
        [0.1, 0.2],
        z3,
    )
    b.add("coulomb_field", "x", "at a charge", pot.coulomb_field, [1, 0, 0], [[1, 0, 0]], [0.1], z3)
    b.add("coulomb_field", "x", "at the goal", pot.coulomb_field, z3, [[1, 0, 0]], [0.1], z3)
    b.add("coulomb_field", "q", "NaN", pot.coulomb_field, [0, 1, 0], [[1, 0, 0]], [NAN], z3)
    b.add("coulomb_field", "centers", "a string", pot.coulomb_field, [0, 1, 0], "c", [0.1], z3)
    b.add("additive_split", "P", "a string", pot.additive_split, "P")
    b.add("additive_split", "P", "a point pair", pot.additive_split, lambda fx: _point_pair())
    pp = pot.potential_path
    b.vary("potential_path", "start", BAD_VEC3, pp, lambda v: ((v, [1, 0, 0]), {}))
    b.vary(
        "potential_path",
        "step",
        {**BAD_REAL, "zero": 0.0, "negative": -0.01},
        pp,
        lambda v: ((z3, [1, 0, 0]), {"step": v}),
    )
    b.add("potential_path", "tol", "NaN", pp, z3, [1, 0, 0], tol=NAN)
    b.add("potential_path", "tol", "≥ the start–goal distance", pp, z3, [1, 0, 0], tol=2.0)
    b.add("potential_path", "step", "≥ the start–goal distance (default tol)", pp, z3, [1, 0, 0], step=100.0)
    b.add("potential_path", "max_iter", "a float", pp, z3, [1, 0, 0], max_iter=10.5)
    b.add("potential_path", "max_iter", "10¹²", pp, z3, [1, 0, 0], max_iter=10**12, step=1e-9)
    b.add("potential_path", "obstacles", "an int", pp, z3, [1, 0, 0], 5)
    b.add("potential_path", "obstacles", "a string", pp, z3, [1, 0, 0], "sphere")
    b.add("potential_path", "margin", "inf", pp, z3, [1, 0, 0], margin=INF)
    b.add("potential_path", "charge_rule", "None", pp, z3, [1, 0, 0], charge_rule=None)
    b.add("potential_path", "window", "1", pp, z3, [1, 0, 0], window=1)
    b.add("potential_path", "escape", "NaN", pp, z3, [1, 0, 0], escape=NAN)
    b.add("potential_path", "start", "inside a safety sphere", pp, [0.5, 0, 0], [2, 0, 0], lambda fx: [fx.obstacle])
    b.add("random_scene", "rng", "an int", pot.random_scene, 3, 2)
    b.add(
        "random_scene",
        "n_obstacles",
        "10⁶ (never fits)",
        pot.random_scene,
        lambda fx: fx.np.random.default_rng(0),
        10**6,
    )
    b.add("random_scene", "n_obstacles", "negative", pot.random_scene, lambda fx: fx.np.random.default_rng(0), -1)
    b.add("random_scene", "margin", "NaN", pot.random_scene, lambda fx: fx.np.random.default_rng(0), 1, margin=NAN)


def collision_cases() -> list[Case]:
    b = Builder("collision")
    _collision_obstacles(b)
    _collision_point_measures(b)
    _collision_segments_and_capsules(b)
    _collision_capsules(b)
    _collision_model(b)
    _collision_potential_fields(b)
    return b.cases


# ---------------------------------------------------------------------------- linkages
def _linkage_four_bar(b: Builder) -> None:
    """Bad inputs to coop_ga.linkages: four_bar and FourBar."""
    from coop_ga import linkages as L

    fb = lambda name: lazy(lambda fx: getattr(fx.fourbar, name))  # noqa: E731
    lengths = {**BAD_REAL, "zero": 0.0, "negative": -1.0, "1e300": 1e300}
    b.vary("four_bar", "crank", lengths, L.four_bar, lambda v: ((2.0, v, 2.0, 1.5), {}))
    b.add("four_bar", "branch", "a bool", L.four_bar, 2.0, 0.5, 2.0, 1.5, branch=True)
    b.add("four_bar", "branch", "a float", L.four_bar, 2.0, 0.5, 2.0, 1.5, branch=1.0)
    b.add("four_bar", "branch", "0", L.four_bar, 2.0, 0.5, 2.0, 1.5, branch=0)
    b.add("four_bar", "rocker", "cannot assemble", L.four_bar, 10.0, 0.5, 1.0, 1.0)
    b.vary("FourBar", "coupler_point", BAD_VEC2, L.FourBar, lambda v: ((2.0, 0.5, 2.0, 1.5), {"coupler_point": v}))
    huge = [0.0, 1e6]
    b.add("FourBar.simulate", "crank_angles", "[0, 1e6] rad", fb("simulate"), huge)
    b.add("FourBar.solve", "crank_angles", "[0, 1e6] rad", fb("solve"), huge)
    b.add("FourBar.simulate", "crank_angles", "NaN", fb("simulate"), [0.0, NAN])
    b.add("FourBar.simulate", "crank_angles", "a string", fb("simulate"), "abc")
    b.add("FourBar.simulate", "crank_angles", "empty", fb("simulate"), [])
    b.add("FourBar.simulate", "crank_angles", "(2, 2)", fb("simulate"), [[0.0, 0.1], [0.2, 0.3]])
    b.add("FourBar.simulate", "max_step", "zero", fb("simulate"), [0.0, 0.5], max_step=0.0)
    b.add("FourBar.simulate", "min_step", "zero", fb("simulate"), [0.0, 0.5], min_step=0.0)
    b.add("FourBar.simulate", "tol", "negative", fb("simulate"), [0.0, 0.5], tol=-1.0)
    b.add("FourBar.simulate", "max_iter", "a float", fb("simulate"), [0.0, 0.5], max_iter=2.5)
    b.add("FourBar.simulate", "guard", "a string", fb("simulate"), [0.0, 0.5], guard="no")
    b.add("FourBar.simulate", "options", "unknown keyword", fb("simulate"), [0.0, 0.5], speed=2.0)
    b.vary("FourBar.closed_form", "phi", BAD_REAL, fb("closed_form"), lambda v: ((v,), {}))
    b.vary("FourBar.assembled", "phi", {"NaN": NAN, "a string": "0"}, fb("assembled"), lambda v: ((v,), {}))


def _linkage_generic_model(b: Builder) -> None:
    """Bad inputs to coop_ga.linkages: the generic model (Linkage)."""
    from coop_ga import linkages as L

    lk = lambda name: lazy(lambda fx: getattr(fx.linkage, name))  # noqa: E731
    huge = [0.0, 1e6]
    b.add("Linkage.track", "crank_angles", "[0, 1e6] rad", lk("track"), huge)
    b.add("Linkage.track", "crank_angles", "inf", lk("track"), [0.0, INF])
    b.add("Linkage.track", "motors", "NaN", lk("track"), [0.0, 0.1], [NAN] * 8)
    b.add("Linkage.track", "motors", "a string", lk("track"), [0.0, 0.1], "m")
    b.add("Linkage.track", "max_step", "NaN", lk("track"), [0.0, 0.1], max_step=NAN)
    b.add("Linkage.track", "min_step", "above max_step", lk("track"), [0.0, 0.1], min_step=1.0, max_step=0.1)
    b.add("Linkage.newton", "motors", "(3,)", lk("newton"), [1.0, 0.0, 0.0], 0.0)
    b.add("Linkage.newton", "motors", "NaN", lk("newton"), [NAN] * 8, 0.0)
    b.add("Linkage.newton", "phi", "NaN", lk("newton"), [1.0, 0.0, 0.0, 0.0] * 2, NAN)
    b.add("Linkage.newton", "tol", "zero", lk("newton"), [1.0, 0.0, 0.0, 0.0] * 2, 0.0, tol=0.0)
    b.add("Linkage.newton", "max_iter", "negative", lk("newton"), [1.0, 0.0, 0.0, 0.0] * 2, 0.0, max_iter=-1)
    b.add("Linkage.residual", "motors", "(3,)", lk("residual"), [1.0, 0.0, 0.0], 0.0)
    b.add("Linkage.residual", "motors", "a string", lk("residual"), "abc", 0.0)
    b.add("Linkage.residual", "phi", "inf", lk("residual"), [1.0, 0.0, 0.0, 0.0] * 2, INF)
    b.add("Linkage.positions", "motors", "NaN", lk("positions"), [NAN] * 8, 0.0)
    b.add("Linkage.positions", "phi", "a string", lk("positions"), [1.0, 0.0, 0.0, 0.0] * 2, "0")
    b.add("Linkage.motors_from_points", "guess", "NaN", lk("motors_from_points"), {"coupler": {"A": [NAN, 0.0]}})
    b.add("Linkage.motors_from_points", "guess", "unknown point", lk("motors_from_points"), {"coupler": {"Z": [0, 0]}})
    b.add("Linkage.motors_from_points", "guess", "unknown link", lk("motors_from_points"), {"wheel": {"A": [0, 0]}})
    b.add("Linkage.motors_from_points", "guess", "a list", lk("motors_from_points"), [1, 2])
    b.add("LinkageMotion.point", "name", "an int", lazy(lambda fx: fx.fourbar.solve([0.0, 0.1]).point), 3)

    def linkage(**change: Any) -> Callable[[Fixtures], Any]:
        """A Linkage of the valid 4-bar's links with one point changed (the Link itself refuses it)."""

        def make(fx: Fixtures) -> tuple[Callable[..., Any], tuple[Any, ...], dict[str, Any]]:
            return (lambda: L.Linkage(*fx.links(**change))), (), {}

        return make

    for bad, v in BAD_VEC2.items():
        b.cases.append(Case("linkages", "Linkage", "points", bad, linkage(coupler__B=v)))
    b.cases.append(Case("linkages", "Linkage", "points", "a one-letter string", linkage(rocker__D="D")))
    b.cases.append(Case("linkages", "Linkage", "points", "None", linkage(crank__A=None)))
    b.add("Linkage", "links", "an int", L.Linkage, 5, [])
    b.add("Linkage", "links", "strings", L.Linkage, ["ground", "crank"], [])
    b.add("Linkage", "joints", "an int", L.Linkage, lambda fx: fx.links()[0], 5)
    b.add("Linkage", "joints", "strings", L.Linkage, lambda fx: fx.links()[0], ["A", "B", "D"])
    b.add("Linkage", "name", "an int", L.Linkage, lambda fx: fx.links()[0], lambda fx: fx.links()[1], name=3)
    b.add("Linkage", "ground", "None", L.Linkage, lambda fx: fx.links()[0], lambda fx: fx.links()[1], ground=None)
    b.add(
        "Linkage",
        "allow_redundant",
        "a string",
        L.Linkage,
        lambda fx: fx.links()[0],
        lambda fx: fx.links()[1],
        allow_redundant="yes",
    )
    b.add("Link", "name", "an int", L.Link, 3, {"A": [0.0, 0.0]})
    b.add("Link", "points", "a list", L.Link, "bar", [[0.0, 0.0]])
    b.add("Link", "points", "NaN", L.Link, "bar", {"A": [NAN, 0.0]})
    b.add("Revolute", "a", "a string", L.Revolute, "crank.A", ("coupler", "A"))
    b.add("Prismatic", "guide", "two names", L.Prismatic, ("s", "S"), ("g", "G1"))
    b.add(
        "Linkage",
        "guide",
        "coincident guide points",
        L.Linkage,
        [
            L.Link("ground", {"O": (0, 0), "G1": (0, 3), "G2": (0, 3)}),
            L.Link("crank", {"O": (0, 0), "A": (1, 0)}),
            L.Link("rod", {"A": (1, 0), "S": (0, 3.873)}),
            L.Link("slider", {"S": (0, 3.873)}),
        ],
        [
            L.Revolute(("crank", "A"), ("rod", "A")),
            L.Revolute(("rod", "S"), ("slider", "S")),
            L.Prismatic(("slider", "S"), ("ground", "G1", "G2")),
        ],
    )


def _linkage_closed_forms(b: Builder) -> None:
    """Bad inputs to coop_ga.linkages: closed forms."""
    from coop_ga import linkages as L

    lengths = {**BAD_REAL, "zero": 0.0, "negative": -1.0, "1e300": 1e300}
    b.vary("grashof", "ground", lengths, L.grashof, lambda v: ((v, 0.5, 2.0, 1.5), {}))
    b.vary("freudenstein_output", "coupler", lengths, L.freudenstein_output, lambda v: ((2.0, 0.5, v, 1.5, 0.0), {}))
    b.add("freudenstein_output", "theta2", "NaN", L.freudenstein_output, 2.0, 0.5, 2.0, 1.5, [0.0, NAN])
    b.add("freudenstein_output", "theta2", "a string", L.freudenstein_output, 2.0, 0.5, 2.0, 1.5, "0")
    b.add("freudenstein_output", "theta2", "unassemblable", L.freudenstein_output, 1.0, 0.8, 0.5, 0.45, [0.0, 3.14])
    b.vary("crank_limits", "crank", lengths, L.crank_limits, lambda v: ((2.0, v, 2.0, 1.5), {}))
    b.vary("dyad", "p", BAD_VEC2, L.dyad, lambda v: ((v, [1.0, 0.0], 1.0, 1.0), {}))
    b.vary("dyad", "r_p", {**BAD_REAL, "negative": -1.0}, L.dyad, lambda v: (([0, 0], [1, 0], v, 1.0), {}))
    b.add("dyad", "branch", "2", L.dyad, [0, 0], [1, 0], 1.0, 1.0, 2)
    b.add("dyad", "branch", "a bool", L.dyad, [0, 0], [1, 0], 1.0, 1.0, True)
    b.vary("slider_crank", "rod", {**BAD_REAL, "shorter than the crank": 0.5}, L.slider_crank, lambda v: ((1.0, v), {}))
    b.vary("watt_six_bar", "phi0", BAD_REAL, L.watt_six_bar, lambda v: ((v,), {}))
    b.vary("ten_bar", "phi0", BAD_REAL, L.ten_bar, lambda v: ((v,), {}))


def _linkage_planar_motors(b: Builder) -> None:
    """Bad inputs to coop_ga.linkages: planar motors."""
    from coop_ga.linkages import planar

    b.add("motor_pose", "m", "NaN", planar.motor_pose, [NAN, 0.0, 0.0, 0.0])
    b.add("motor_pose", "m", "zero", planar.motor_pose, [0.0, 0.0, 0.0, 0.0])
    b.add("motor_pose", "m", "a string", planar.motor_pose, "abcd")
    b.add("motor_pose", "m", "(3,)", planar.motor_pose, [1.0, 0.0, 0.0])


def linkage_cases() -> list[Case]:
    b = Builder("linkages")
    _linkage_four_bar(b)
    _linkage_generic_model(b)
    _linkage_closed_forms(b)
    _linkage_planar_motors(b)
    return b.cases


# ---------------------------------------------------------------------------- legged
def _legged_leg_model(b: Builder) -> None:
    """Bad inputs to coop_ga.legged: LegModel and hexapod_legs."""
    from coop_ga import legged as G

    lm = lambda name: lazy(lambda fx: getattr(fx.legs, name))  # noqa: E731
    q18 = lambda fx: fx.legs.q_stand  # noqa: E731
    feet = lambda fx: fx.feet  # noqa: E731
    bad_q = {"NaN": [NAN] * 18, "17 entries": [0.0] * 17, "a string": "q", "None": None, "complex": [1j] * 18}
    for meth in ("fk", "jacobians", "per_leg", "within_limits", "branch_of"):
        b.vary(f"LegModel.{meth}", "q", bad_q, lm(meth), lambda v: ((v,), {}))
    b.add("LegModel.within_limits", "tol", "negative", lm("within_limits"), q18, -1.0)
    bad_feet = {"NaN": [[NAN, 0.0, 0.0]] * 6, "(5, 3)": [[0.1, 0.0, -0.1]] * 5, "a string": "feet", "None": None}
    for meth in ("ik", "ik_candidates", "workspace_margin"):
        b.vary(f"LegModel.{meth}", "feet", bad_feet, lm(meth), lambda v: ((v,), {}))
    b.add("LegModel.ik", "branch", "'up'", lm("ik"), feet, "up")
    b.add("LegModel.ik", "branch", "an int", lm("ik"), feet, 1)
    b.add("LegModel.ik", "check_limits", "a string", lm("ik"), feet, check_limits="yes")
    b.add("LegModel.ik", "feet", "out of reach", lm("ik"), lambda fx: fx.feet * 10.0)
    b.vary("LegModel.dls_ik", "q_init", bad_q, lm("dls_ik"), lambda v: ((feet, v), {}))
    b.add("LegModel.dls_ik", "damping", "NaN", lm("dls_ik"), feet, q18, damping=NAN)
    b.add("LegModel.dls_ik", "max_iter", "a float", lm("dls_ik"), feet, q18, max_iter=3.5)
    b.add("LegModel.dls_ik", "max_iter", "10¹²", lm("dls_ik"), lambda fx: fx.feet * 10.0, q18, max_iter=10**12)
    b.add("LegModel.fk_motors", "leg", "'xx'", lm("fk_motors"), [0.0, 0.0, 0.0], "xx")
    b.add("LegModel.fk_motors", "q_leg", "NaN", lm("fk_motors"), [NAN, 0.0, 0.0], "lf")
    b.add("LegModel.foot_point", "q_leg", "(2,)", lm("foot_point"), [0.0, 0.0], "lf")
    b.add("LegModel.fk_via_motors", "q", "inf", lm("fk_via_motors"), [INF] * 18)
    b.add("LegModel.from_legs", "q_legs", "(6, 2)", lm("from_legs"), [[0.0, 0.0]] * 6)
    b.add("LegModel.from_legs", "q_legs", "NaN", lm("from_legs"), [[NAN, 0.0, 0.0]] * 6)
    b.add("LegModel.leg_index", "leg", "an int", lm("leg_index"), 0)
    b.add("LegModel.from_system", "system", "a string", G.LegModel.from_system, "hexapod")
    b.add("LegModel.from_system", "legs", "a string", G.LegModel.from_system, lambda fx: fx.hexapod, "lf")
    b.add("hexapod_legs", "system", "an int", G.hexapod_legs, 3)
    b.add("hexapod_legs", "system", "the cartesian system", G.hexapod_legs, lambda fx: fx.cart)


def _legged_body(b: Builder) -> None:
    """Bad inputs to coop_ga.legged: body."""
    from coop_ga import legged as G
    from coop_ga.legged import body as Bd

    q18 = lambda fx: fx.legs.q_stand  # noqa: E731
    b.vary("BodyState", "position", BAD_VEC3, G.BodyState, lambda v: ((v, lambda fx: fx.np.eye(3), q18), {}))
    b.add("BodyState", "rotation", "not a rotation", G.BodyState, [0, 0, 0], [[1, 0, 0], [0, 1, 0], [0, 0, 2]], q18)
    b.add("BodyState", "rotation", "NaN", G.BodyState, [0, 0, 0], [[NAN, 0, 0], [0, 1, 0], [0, 0, 1]], q18)
    b.add("BodyState", "q", "NaN", G.BodyState, [0, 0, 0], lambda fx: fx.np.eye(3), [NAN] * 18)
    b.add("BodyState.from_rpy", "rpy", "inf", G.BodyState.from_rpy, [0, 0, 0], [0, INF, 0], q18)
    b.add("BodyState.from_quaternion", "quaternion", "zero", G.BodyState.from_quaternion, [0, 0, 0], [0] * 4, q18)
    b.add("BodyState.from_quaternion", "quaternion", "NaN", G.BodyState.from_quaternion, [0, 0, 0], [NAN, 0, 0, 1], q18)
    b.add("BodyState.from_free_flyer_q", "q", "24 entries", G.BodyState.from_free_flyer_q, [0.0] * 24)
    b.add("BodyState.from_free_flyer_q", "q", "zero quaternion", G.BodyState.from_free_flyer_q, [0.0] * 25)
    st = lambda name: lazy(lambda fx: getattr(fx.state, name))  # noqa: E731
    b.add("BodyState.moved", "dt", "NaN", st("moved"), [0.1, 0, 0], [0, 0, 0], NAN)
    b.add("BodyState.moved", "dt", "a string", st("moved"), [0.1, 0, 0], [0, 0, 0], "0.1")
    b.add("BodyState.moved", "dt", "inf", st("moved"), [0.1, 0, 0], [0, 0, 0], INF)
    b.add("BodyState.moved", "omega", "NaN", st("moved"), [0.1, 0, 0], [NAN, 0, 0], 0.1)
    b.add("BodyState.moved", "q", "17 entries", st("moved"), [0.1, 0, 0], [0, 0, 0], 0.1, [0.0] * 17)
    for meth, arg in (("to_world", "points_B"), ("to_body", "points_W")):
        b.add(f"BodyState.{meth}", arg, "NaN", st(meth), [[NAN, 0, 0]])
        b.add(f"BodyState.{meth}", arg, "(2, 2)", st(meth), [[0, 0], [1, 1]])
        b.add(f"BodyState.{meth}", arg, "a string", st(meth), "abc")
    b.add("BodyState.feet_world", "legs", "None", st("feet_world"), None)
    b.add("BodyState.feet_body", "legs", "a string", st("feet_body"), "hexapod")
    b.add("rotation_from_rpy", "rpy", "NaN", Bd.rotation_from_rpy, [NAN, 0, 0])
    b.add("rpy_from_rotation", "R", "not a rotation", Bd.rpy_from_rotation, [[2, 0, 0], [0, 1, 0], [0, 0, 1]])
    b.add("rpy_from_rotation", "R", "NaN", Bd.rpy_from_rotation, [[NAN, 0, 0], [0, 1, 0], [0, 0, 1]])
    b.add("body_tangent", "omega", "a string", Bd.body_tangent, [0, 0, 0], "w")
    mask5 = lambda fx: fx.np.ones(5, bool)  # noqa: E731
    b.vary(
        "stance_indices",
        "stance_legs",
        {
            "a string": "lf",
            "unknown leg": ["lx"],
            "an index 6": [6],
            "a float": [1.5],
            "a (5,) mask": mask5,
            "None": None,
        },
        Bd.stance_indices,
        lambda v: ((v,), {}),
    )


def _legged_gait(b: Builder) -> None:
    """Bad inputs to coop_ga.legged: gait."""
    from coop_ga import legged as G

    b.vary(
        "phase_table", "gait", {"'gallop'": "gallop", "None": None, "an int": 3}, G.phase_table, lambda v: ((v,), {})
    )
    b.vary(
        "phase_table",
        "n_legs",
        {**BAD_INT, "3": 3, "odd for the tripod": 5},
        G.phase_table,
        lambda v: (("tripod", v), {}),
    )
    duty = {k: v for k, v in BAD_REAL.items() if v is not None}  # (None is the gait's default duty)
    b.vary("phase_table", "duty", {**duty, "1": 1.0, "0": 0.0}, G.phase_table, lambda v: (("wave",), {"duty": v}))
    b.vary("phase_table", "period", {**BAD_REAL, "zero": 0.0}, G.phase_table, lambda v: (("wave",), {"period": v}))
    gt = lambda name: lazy(lambda fx: getattr(fx.gait, name))  # noqa: E731
    for meth in ("phase", "stance", "swing_progress", "stance_progress"):
        b.add(f"GaitTable.{meth}", "t", "NaN", gt(meth), NAN)
        b.add(f"GaitTable.{meth}", "t", "a string", gt(meth), "0.5")
    b.add("GaitTable.min_stance", "samples", "10¹²", gt("min_stance"), 10**12)
    b.add("GaitTable.diagram", "samples", "10¹²", gt("diagram"), 10**12)
    b.add("GaitTable.diagram", "samples", "a float", gt("diagram"), 100.5)
    b.add("GaitTable", "offsets", "NaN", G.GaitTable, "tripod", ("a", "b"), [NAN, 0.5], 0.5)
    b.add("GaitTable", "duty", "1.5", G.GaitTable, "tripod", ("a", "b"), [0.0, 0.5], 1.5)
    b.vary("swing_arc", "p0", BAD_VEC3, G.swing_arc, lambda v: ((v, [0.1, 0, 0], 0.03, 0.5), {}))
    b.vary(
        "swing_arc",
        "lift",
        {**BAD_REAL, "negative": -0.01},
        G.swing_arc,
        lambda v: (([0, 0, 0], [0.1, 0, 0], v, 0.5), {}),
    )
    b.add("swing_arc", "s", "1.5", G.swing_arc, [0, 0, 0], [0.1, 0, 0], 0.03, 1.5)
    b.add("swing_arc", "s", "NaN", G.swing_arc, [0, 0, 0], [0.1, 0, 0], 0.03, NAN)


def _legged_stance(b: Builder) -> None:
    """Bad inputs to coop_ga.legged: stance."""
    from coop_ga import legged as G
    from coop_ga.legged import stance as St

    b.vary(
        "stance_primitive",
        "points",
        {
            "NaN": [[NAN, 0, 0]] * 4,
            "(4, 2)": [[0, 0]] * 4,
            "2 feet": [[0, 0, 0], [1, 0, 0]],
            "a string": "feet",
            "collinear": [[0, 0, 0], [1, 0, 0], [2, 0, 0]],
        },
        G.stance_primitive,
        lambda v: ((v,), {}),
    )
    sq = [[0.1, 0.1, -0.1], [-0.1, 0.1, -0.1], [-0.1, -0.1, -0.1], [0.1, -0.1, -0.05]]
    b.add("stance_primitive", "w_min", "NaN", G.stance_primitive, sq, w_min=NAN)
    b.add("stance_primitive", "r_max", "zero", G.stance_primitive, sq, r_max=0.0)
    b.add("stance_primitive", "kind", "'cube'", G.stance_primitive, sq, kind="cube")
    b.add("stance_task", "system", "None", G.stance_task, None, ["lf", "lm", "lr"])
    b.add("stance_task", "system", "an int", G.stance_task, 5, ["lf", "lm", "lr"])
    b.add("stance_task", "stance_legs", "2 legs", G.stance_task, "hexapod", ["lf", "lm"])
    b.add("stance_task", "kind", "'torus'", G.stance_task, "hexapod", ["lf", "lm", "lr"], "torus")
    b.add("stance_task", "codegen", "'yes'", G.stance_task, "hexapod", ["lf", "lm", "lr"], codegen="yes")
    b.add("stance_order", "stance_legs", "a dict", St.stance_order, {"lf": 1})


def _legged_terrain(b: Builder) -> None:
    """Bad inputs to coop_ga.legged: terrain."""
    from coop_ga import legged as G

    T = G.Terrain
    b.vary("Terrain.flat", "height", BAD_REAL, T.flat, lambda v: ((v,), {}))
    b.vary("Terrain.slope", "angle_rad", {**BAD_REAL, "π/2": math.pi / 2}, T.slope, lambda v: ((v,), {}))
    b.add("Terrain.slope", "direction", "zero", T.slope, 0.1, [0.0, 0.0])
    b.add("Terrain.steps", "n_steps", "10¹²", T.steps, n_steps=10**12)
    b.add("Terrain.steps", "n_steps", "a float", T.steps, n_steps=2.5)
    b.add("Terrain.steps", "step_length", "zero", T.steps, step_length=0.0)
    b.add("Terrain.random", "tile", "1e-9", T.random, tile=1e-9)
    b.add("Terrain.random", "seed", "negative", T.random, seed=-1)
    b.add("Terrain.make", "kind", "'lava'", T.make, "lava")
    tr = lambda name: lazy(lambda fx: getattr(fx.terrain, name))  # noqa: E731
    for meth in ("height", "normal", "land", "plane_params"):
        b.add(f"Terrain.{meth}", "xy", "NaN", tr(meth), [NAN, 0.0])
        b.add(f"Terrain.{meth}", "xy", "(3,)", tr(meth), [0.0, 0.0, 0.0])
    b.add("Terrain.plane_at", "xy", "a string", tr("plane_at"), "xy")
    b.add("Terrain.signed_distance", "points", "inf", tr("signed_distance"), [[0.0, 0.0, INF]])
    b.add("Terrain.in_contact", "tol", "negative", tr("in_contact"), [[0.0, 0.0, 0.0]], -1.0)
    b.add("Terrain.max_height", "samples", "10¹²", tr("max_height"), [0, 0], [1, 0], 10**12)
    b.add("Terrain.max_height", "xy1", "NaN", tr("max_height"), [0, 0], [NAN, 0])
    b.add("Terrain.from_arrays", "d", "an int", T.from_arrays, 5)
    b.add("Terrain.from_arrays", "d", "an empty dict", T.from_arrays, {})
    b.add("Terrain", "planes", "NaN", T, "flat", [], [], [[[0.0, 0.0, 1.0, NAN]]])
    b.add("Terrain", "kind", "'lava'", T, "lava", [], [], [[[0.0, 0.0, 1.0, 0.0]]])


def _legged_posture(b: Builder) -> None:
    """Bad inputs to coop_ga.legged: posture."""
    from coop_ga import legged as G

    b.vary("PostureOptions", "dt", {**BAD_REAL, "zero": 0.0}, G.PostureOptions, lambda v: ((), {"dt": v}))
    b.add("PostureOptions", "limit_gain", "2", G.PostureOptions, limit_gain=2.0)
    b.add("PostureOptions", "max_steps", "a float", G.PostureOptions, max_steps=2.5)
    b.add("PostureOptions", "kind", "'cube'", G.PostureOptions, kind="cube")
    b.add("PostureOptions", "frame", "'world'", G.PostureOptions, frame="world")
    legs3 = ["lf", "lr", "rm"]
    b.add("posture_step", "state", "a dict", G.posture_step, {"q": 0}, legs3, [0.0] * 7)
    b.add("posture_step", "command_twist_B", "NaN", G.posture_step, lambda fx: fx.state, legs3, [NAN] * 7)
    b.add("posture_step", "command_twist_B", "(6,)", G.posture_step, lambda fx: fx.state, legs3, [0.0] * 6)
    b.add("posture_step", "stance_legs", "2 legs", G.posture_step, lambda fx: fx.state, ["lf", "lr"], [0.0] * 7)
    b.add("posture_step", "legs", "a string", G.posture_step, lambda fx: fx.state, legs3, [0.0] * 7, "hexapod")
    b.add("posture_step", "options", "a dict", G.posture_step, lambda fx: fx.state, legs3, [0.0] * 7, options={"dt": 1})
    b.add(
        "posture_step",
        "nullspace_twist",
        "NaN",
        G.posture_step,
        lambda fx: fx.state,
        legs3,
        [0.0] * 7,
        nullspace_twist=[NAN] * 6,
    )
    b.add("posture_step", "swing_q", "a list", G.posture_step, lambda fx: fx.state, legs3, [0.0] * 7, swing_q=[0.0] * 3)
    b.add(
        "posture_step",
        "swing_q",
        "NaN",
        G.posture_step,
        lambda fx: fx.state,
        legs3,
        [0.0] * 7,
        swing_q={"lm": [NAN, 0.0, 0.0]},
    )
    b.add(
        "posture_step",
        "swing_feet_W",
        "NaN",
        G.posture_step,
        lambda fx: fx.state,
        legs3,
        [0.0] * 7,
        swing_feet_W={"lm": [NAN, 0.0, 0.0]},
    )
    b.add("posture_to", "state", "None", G.posture_to, None, legs3, lambda fx: _identity_similarity())
    b.add("posture_to", "target", "a string", G.posture_to, lambda fx: fx.state, legs3, "target")
    b.add(
        "posture_to",
        "options",
        "an int",
        G.posture_to,
        lambda fx: fx.state,
        legs3,
        lambda fx: _identity_similarity(),
        options=3,
    )


def _legged_posture_tasks(b: Builder) -> None:
    """Bad inputs to coop_ga.legged: posture tasks."""
    from coop_ga.legged import posture as Po

    q18 = lambda fx: fx.legs.q_stand  # noqa: E731
    legs3 = ["lf", "lr", "rm"]
    b.add("feet_field", "points_B", "NaN", Po.feet_field, [0.0] * 7, [[NAN, 0, 0]])
    b.add("feet_field", "points_B", "a string", Po.feet_field, [0.0] * 7, "p")
    b.add("feet_field", "command_B", "inf", Po.feet_field, [INF] + [0.0] * 6, [[0, 0, 0]])
    b.add("command_from_body_twist", "v", "NaN", Po.command_from_body_twist, [NAN, 0, 0], [0, 0, 0])
    b.add(
        "body_motion_target",
        "rotation",
        "not a rotation",
        Po.body_motion_target,
        lambda fx: _identity_similarity(),
        [0, 0, 0],
        [[2, 0, 0], [0, 1, 0], [0, 0, 1]],
    )
    b.add(
        "body_motion_target",
        "rotation",
        "a string",
        Po.body_motion_target,
        lambda fx: _identity_similarity(),
        [0, 0, 0],
        "R",
    )
    b.add(
        "body_motion_target",
        "translation",
        "NaN",
        Po.body_motion_target,
        lambda fx: _identity_similarity(),
        [NAN, 0, 0],
    )
    b.add("adjoint", "V", "a string", Po.adjoint, "V")
    b.add("stance_posture_task", "legs", "None", Po.stance_posture_task, None, q18, legs3)
    b.add("stance_posture_task", "q", "NaN", Po.stance_posture_task, lambda fx: fx.legs, [NAN] * 18, legs3)
    b.add("stance_posture_task", "w_min", "NaN", Po.stance_posture_task, lambda fx: fx.legs, q18, legs3, w_min=NAN)


def _legged_walking(b: Builder) -> None:
    """Bad inputs to coop_ga.legged: walking."""
    from coop_ga import legged as G

    W = importlib.import_module("coop_ga.legged.walk")  # (coop_ga.legged.walk is also the function walk)

    q18 = lambda fx: fx.legs.q_stand  # noqa: E731
    legs3 = ["lf", "lr", "rm"]
    b.vary("WalkOptions", "dt", {**BAD_REAL, "zero": 0.0, "1e-12": 1e-12}, G.WalkOptions, lambda v: ((), {"dt": v}))
    b.add("WalkOptions", "speed", "NaN", G.WalkOptions, speed=(NAN, 0, 0))
    b.add("WalkOptions", "gait", "'gallop'", G.WalkOptions, gait="gallop")
    b.add("WalkOptions", "use_posture", "a string", G.WalkOptions, use_posture="no")
    b.add("WalkOptions", "duty", "1.5", G.WalkOptions, duty=1.5)
    b.add("WalkOptions", "cycle_time", "inf", G.WalkOptions, cycle_time=INF)
    b.add("walk", "terrain", "a string", G.walk, "flat", duration=0.1)
    b.add("walk", "options", "a dict", G.walk, lambda fx: fx.terrain, {"gait": "tripod"}, duration=0.1)
    b.add("walk", "distance", "NaN", G.walk, lambda fx: fx.terrain, distance=NAN)
    b.add("walk", "distance", "1e9 m", G.walk, lambda fx: fx.terrain, distance=1e9)
    b.add("walk", "duration", "negative", G.walk, lambda fx: fx.terrain, duration=-1.0)
    b.add("WalkOptions", "dt", "5 s (longer than a sixth of the cycle)", G.WalkOptions, dt=5.0)
    b.add("walk", "legs", "a string", G.walk, lambda fx: fx.terrain, duration=0.1, legs="hexapod")
    b.add("static_stability_margin", "com_xy", "NaN", G.static_stability_margin, [NAN, 0], [[0, 0], [1, 0], [0, 1]])
    b.add("static_stability_margin", "support_xy", "(3, 3)", G.static_stability_margin, [0, 0], [[0, 0, 0]] * 3)
    b.add("static_stability_margin", "support_xy", "inf", G.static_stability_margin, [0, 0], [[INF, 0], [1, 0], [0, 1]])
    b.add("convex_hull", "points_xy", "a string", W.convex_hull, "pts")
    b.add("static_torques", "mass", "negative", G.static_torques, lambda fx: fx.state, legs3, lambda fx: fx.legs, -1.0)
    b.add("static_torques", "state", "None", G.static_torques, None, legs3, lambda fx: fx.legs, 2.0)
    b.add("static_torques", "legs", "a string", G.static_torques, lambda fx: fx.state, legs3, "legs", 2.0)
    b.add("robot_com", "q", "NaN", W.robot_com, [NAN] * 18, lambda fx: fx.legs)
    b.add("robot_com", "legs", "None", W.robot_com, q18, None)
    b.add("robot_mass", "legs", "an int", W.robot_mass, 3)


def _legged_dynamics(b: Builder) -> None:
    """Bad inputs to coop_ga.legged: dynamics."""
    from coop_ga import legged as G
    from coop_ga.legged import dynamics as Dy

    b.vary("RolloutOptions", "dt", {**BAD_REAL, "zero": 0.0}, G.RolloutOptions, lambda v: ((), {"dt": v}))
    b.add("RolloutOptions", "baumgarte", "NaN", G.RolloutOptions, baumgarte=(NAN, 1.0))
    b.add("RolloutOptions", "baumgarte", "a float", G.RolloutOptions, baumgarte=1.0)
    b.add("RolloutOptions", "kp", "negative", G.RolloutOptions, kp=-1.0)
    b.add("RolloutOptions", "feedforward", "a string", G.RolloutOptions, feedforward="yes")

    def rollout(**change: Any) -> Callable[[Fixtures], Any]:
        def make(fx: Fixtures) -> tuple[Callable[..., Any], tuple[Any, ...], dict[str, Any]]:
            p = fx.plan()
            opts = change.get("options")
            p.update({k: v for k, v in change.items() if k != "options"})
            return G.contact_rollout, (p["t"], p["q"], p["body"], p["stance"]), ({"options": opts} if opts else {})

        return make

    np_ = __import__("numpy")
    for arg, bad, v in (
        ("t", "NaN", [0.0, NAN, 0.02]),
        ("t", "decreasing", [0.0, 0.02, 0.01]),
        ("t", "a 10⁹ s span", [0.0, 1e9, 2e9]),
        ("q", "NaN", np_.full((3, 18), NAN)),
        ("q", "(3, 17)", np_.zeros((3, 17))),
        ("body", "zero quaternion", np_.zeros((3, 7))),
        ("stance", "floats", np_.ones((3, 6))),
    ):
        b.cases.append(Case("legged", "contact_rollout", arg, bad, rollout(**{arg: v})))
    b.cases.append(Case("legged", "contact_rollout", "options", "a dict", rollout(options={"dt": 1e-3})))
    b.cases.append(Case("legged", "contact_rollout", "dt", "1e-12 s", rollout(options=G.RolloutOptions(dt=1e-12))))
    b.add(
        "plan_to_free_flyer_q",
        "body",
        "zero quaternion",
        Dy.plan_to_free_flyer_q,
        np_.zeros((2, 18)),
        np_.zeros((2, 7)),
    )
    b.add(
        "plan_to_free_flyer_q",
        "q",
        "NaN",
        Dy.plan_to_free_flyer_q,
        np_.full((2, 18), NAN),
        np_.tile([0, 0, 0, 0, 0, 0, 1.0], (2, 1)),
    )


def legged_cases() -> list[Case]:
    b = Builder("legged")
    _legged_leg_model(b)
    _legged_body(b)
    _legged_gait(b)
    _legged_stance(b)
    _legged_terrain(b)
    _legged_posture(b)
    _legged_posture_tasks(b)
    _legged_walking(b)
    _legged_dynamics(b)
    return b.cases


def _identity_similarity() -> Any:
    from coop_ga.geometry.groups import Similarity

    return Similarity.identity()


def _point_pair() -> Any:
    import coop_ga as cg

    return cg.point([0.0, 0.0, 0.0]) ^ cg.point([1.0, 0.0, 0.0])


# ---------------------------------------------------------------------------- systems
def _systems_from_urdf(b: Builder) -> None:
    """Bad inputs to coop_ga.systems: from_urdf and from_model."""
    import coop_ga.systems as S

    model = lambda fx: fx.cart.model  # noqa: E731
    tips = ["tip0", "tip1", "tip2"]
    ur = lambda fx: fx.urdf  # noqa: E731
    feet = ["lf_foot", "lm_foot", "lr_foot"]
    b.vary(
        "from_urdf",
        "q0",
        {
            "NaN": [NAN] * 18,
            "inf": [INF] * 18,
            "17 entries": [0.0] * 17,
            "a string": "q0",
            "outside the limits": [10.0] * 18,
        },
        S.from_urdf,
        lambda v: ((ur, feet), {"q0": v}),
    )
    b.add("from_urdf", "urdf_path", "None", S.from_urdf, None, feet)
    b.add("from_urdf", "urdf_path", "missing file", S.from_urdf, "/nonexistent/robot.urdf", feet)
    b.add("from_urdf", "urdf_path", "not a URDF", S.from_urdf, lambda fx: fx.file("x.urdf", "<robot><oops"), feet)
    b.add("from_urdf", "urdf_path", "a directory", S.from_urdf, lambda fx: str(fx.tmp), feet)
    b.add("from_urdf", "end_frames", "a string", S.from_urdf, ur, "lf_foot")
    b.add("from_urdf", "end_frames", "unknown", S.from_urdf, ur, ["nope"])
    b.add("from_urdf", "end_frames", "empty", S.from_urdf, ur, [])
    b.add("from_urdf", "locked_joints", "a string", S.from_urdf, ur, feet, "lf_coxa_joint")
    b.add("from_urdf", "locked_joints", "unknown", S.from_urdf, ur, feet, ["nope"])
    b.add("from_urdf", "q_lock", "NaN", S.from_urdf, ur, feet, ["rf_coxa_joint"], q_lock=[NAN] * 18)
    b.add("from_urdf", "q_lock", "3 entries", S.from_urdf, ur, feet, ["rf_coxa_joint"], q_lock=[0.0] * 3)
    b.add("from_urdf", "name", "an int", S.from_urdf, ur, feet, name=3)
    b.add("from_urdf", "package_dirs", "an int", S.from_urdf, ur, feet, package_dirs=3)
    b.add("from_model", "model", "None", S.from_model, None, tips)
    b.add("from_model", "model", "a string", S.from_model, "cartesian3", tips)
    b.vary(
        "from_model",
        "q0",
        {"NaN": [NAN] * 9, "(9, 1)": [[0.0]] * 9, "complex": [1j] * 9},
        S.from_model,
        lambda v: ((model, tips), {"q0": v}),
    )
    b.add("from_model", "locked_joints", "an int", S.from_model, model, tips, locked_joints=3)
    b.add("from_model", "visual_model", "a string", S.from_model, model, tips, visual_model="meshes")
    b.add("from_model", "visuals", "strings", S.from_model, model, tips, visuals=["a.urdf"])


def _systems_append_robots(b: Builder) -> None:
    """Bad inputs to coop_ga.systems: append_robots and prefixed."""
    import coop_ga.systems as S

    model = lambda fx: fx.cart.model  # noqa: E731
    pin = lambda fx: __import__("pinocchio")  # noqa: E731
    twice = lambda fx: [(fx.cart.model, pin(fx).SE3.Identity()), (fx.cart.model, pin(fx).SE3.Identity())]  # noqa: E731

    def same_frames(fx: Fixtures) -> list[Any]:
        p = pin(fx)
        m2 = p.Model(fx.cart.model)
        for i in range(1, m2.njoints):
            m2.names[i] = "b_" + m2.names[i]
        return [(fx.cart.model, p.SE3.Identity()), (m2, p.SE3.Identity())]

    b.add("append_robots", "parts", "a model appended to itself", S.append_robots, twice)
    b.add("append_robots", "parts", "two models with one frame name", S.append_robots, same_frames)
    b.add("append_robots", "parts", "an int", S.append_robots, 3)
    b.add("append_robots", "parts", "a model without placement", S.append_robots, lambda fx: [fx.cart.model])
    b.add("append_robots", "placement", "a string", S.append_robots, lambda fx: [(fx.cart.model, "origin")])
    b.add("append_robots", "model", "a string", S.append_robots, lambda fx: [("robot", pin(fx).SE3.Identity())])
    b.add("prefixed", "prefix", "an int", S.prefixed, model, 3)
    b.add("prefixed", "model", "None", S.prefixed, None, "a_")


def _systems_system(b: Builder) -> None:
    """Bad inputs to coop_ga.systems: System."""
    import coop_ga.systems as S

    model = lambda fx: fx.cart.model  # noqa: E731
    tips = ["tip0", "tip1", "tip2"]
    Sys = S.System
    b.add("System", "model", "None", Sys, "s", None, tips, [0.0] * 9)
    b.vary(
        "System",
        "q0",
        {"NaN": [NAN] * 9, "inf": [INF] * 9, "a string": "q0", "8 entries": [0.0] * 8},
        Sys,
        lambda v: (("s", model, tips, v), {}),
    )
    b.add("System", "name", "an int", Sys, 3, model, tips, [0.0] * 9)
    b.add("System", "labels", "2 labels for 3 chains", Sys, "s", model, tips, [0.0] * 9, labels=("a", "b"))
    b.add("System", "labels", "ints", Sys, "s", model, tips, [0.0] * 9, labels=(1, 2, 3))
    b.add("System", "description", "an int", Sys, "s", model, tips, [0.0] * 9, description=5)
    b.add("System", "limits", "a dict", Sys, "s", model, tips, [0.0] * 9, limits={"lower": 0})
    b.add("System", "visuals", "a string", Sys, "s", model, tips, [0.0] * 9, visuals="robot.urdf")
    sy = lambda name: lazy(lambda fx: getattr(fx.cart, name))  # noqa: E731
    for meth in ("check_q", "end_points", "frame_motors"):
        b.vary(
            f"System.{meth}",
            "q",
            {"NaN": [NAN] * 9, "8 entries": [0.0] * 8, "a string": "q", "None": None},
            sy(meth),
            lambda v: ((v,), {}),
        )
    b.add("System.check_q", "warn_limits", "a string", sy("check_q"), [0.0] * 9, warn_limits="no")
    b.add("System.random_q", "rng", "an int", sy("random_q"), 3)
    b.add("System.random_q", "scale", "NaN", sy("random_q"), lambda fx: fx.np.random.default_rng(0), NAN)
    b.add("System.random_q", "scale", "negative", sy("random_q"), lambda fx: fx.np.random.default_rng(0), -1.0)
    b.add(
        "System.random_q",
        "scale",
        "2 (outside the limits)",
        sy("random_q"),
        lambda fx: fx.np.random.default_rng(0),
        2.0,
    )
    b.add("System.with_limits", "position", "lower > upper", sy("with_limits"), position={"c0_px": (1.0, -1.0)})
    b.add("System.with_limits", "position", "NaN", sy("with_limits"), position={"c0_px": (NAN, 1.0)})
    b.add("System.with_limits", "position", "a list", sy("with_limits"), position=[(0.0, 1.0)])
    b.add("System.with_limits", "velocity", "negative", sy("with_limits"), velocity=-1.0)
    b.add("System.with_limits", "velocity", "unknown joint", sy("with_limits"), velocity={"nope": 1.0})
    b.add("System.with_limits", "name", "an int", sy("with_limits"), name=3)


def _systems_limits(b: Builder) -> None:
    """Bad inputs to coop_ga.systems: limits."""
    import coop_ga.systems as S

    model = lambda fx: fx.cart.model  # noqa: E731
    lim = lambda name: lazy(lambda fx: getattr(fx.cart.limits, name))  # noqa: E731
    for meth in ("position_violation", "velocity_violation", "acceleration_violation", "effort_violation", "clip"):
        b.add(
            f"JointLimits.{meth}",
            "q"
            if meth in ("position_violation", "clip")
            else {"velocity_violation": "qd", "acceleration_violation": "qdd", "effort_violation": "tau"}[meth],
            "NaN",
            lim(meth),
            [NAN] * 9,
        )
        b.add(
            f"JointLimits.{meth}",
            "q"
            if meth in ("position_violation", "clip")
            else {"velocity_violation": "qd", "acceleration_violation": "qdd", "effort_violation": "tau"}[meth],
            "4 entries",
            lim(meth),
            [0.0] * 4,
        )
    b.add("JointLimits.describe", "q", "a string", lim("describe"), "q")
    b.add("JointLimits.describe", "tol", "NaN", lim("describe"), [0.0] * 9, NAN)
    b.add(
        "JointLimits.trajectory_velocity_violation",
        "dt",
        "zero",
        lim("trajectory_velocity_violation"),
        [[0.0] * 9] * 2,
        0.0,
    )
    b.add(
        "JointLimits.trajectory_velocity_violation",
        "traj",
        "NaN",
        lim("trajectory_velocity_violation"),
        [[NAN] * 9] * 2,
        0.01,
    )
    b.add(
        "JointLimits.trajectory_velocity_violation",
        "traj",
        "(2, 4)",
        lim("trajectory_velocity_violation"),
        [[0.0] * 4] * 2,
        0.01,
    )
    b.add("JointLimits.replace", "acceleration", "NaN", lim("replace"), acceleration=NAN)
    b.add("JointLimits", "lower", "a string", S.JointLimits, ("a",), "x", [1.0], [1.0], [1.0], [1.0], [False])
    b.add("JointLimits", "velocity", "zero", S.JointLimits, ("a",), [0.0], [1.0], [0.0], [1.0], [1.0], [False])
    b.add("JointLimits.from_model", "model", "None", S.JointLimits.from_model, None, ["a"])
    b.add("JointLimits.from_model", "joint_names", "2 names for 9 joints", S.JointLimits.from_model, model, ["a", "b"])


def _systems_registry_and_synthetic_systems(b: Builder) -> None:
    """Bad inputs to coop_ga.systems: registry and synthetic systems."""
    import coop_ga.systems as S
    from coop_ga.systems import meshes

    b.add("load", "name", "unknown", S.load, "nope")
    b.add("load", "name", "None", S.load, None)
    b.add("register", "name", "an int", S.register, 3)
    b.add("register", "name", "empty", S.register, "")
    b.vary("cartesian_points", "n_points", {**BAD_INT, "0": 0, "5": 5}, S.cartesian_points, lambda v: ((v,), {}))
    b.vary(
        "cartesian_points",
        "bases",
        {"NaN": [[NAN, 0, 0]] * 2, "(2, 2)": [[0, 0], [1, 1]], "a string": "b"},
        S.cartesian_points,
        lambda v: ((2, v), {}),
    )
    b.vary(
        "cartesian_points",
        "limit",
        {**BAD_REAL, "negative": -1.0, "zero": 0.0},
        S.cartesian_points,
        lambda v: ((2,), {"limit": v}),
    )
    b.add("VisualSource", "urdf", "an int", S.VisualSource, urdf=3)
    b.add(
        "VisualSource",
        "urdf",
        "both urdf and geometry",
        S.VisualSource,
        urdf="a.urdf",
        geometry=object(),
        model=object(),
    )
    b.add("VisualSource", "package_dirs", "an int", S.VisualSource, urdf="a.urdf", package_dirs=3)
    b.add("VisualSource", "prefix", "an int", S.VisualSource, urdf="a.urdf", prefix=3)
    b.add(
        "System.visual_model",
        "visuals",
        "a missing URDF",
        lambda fx: (
            S.System(
                "s", fx.cart.model, ("tip0",), [0.0] * 9, visuals=(S.VisualSource(urdf="/nonexistent.urdf"),)
            ).visual_model
        ),
    )
    b.add("object_mesh", "obj", "a string", meshes.object_mesh, "mesh")
    b.add("object_mesh", "obj", "None", meshes.object_mesh, None)
    b.add("object_key", "obj", "an int", meshes.object_key, 3)
    b.add(
        "TriMesh.transformed",
        "R",
        "NaN",
        lazy(lambda fx: meshes.TriMesh(fx.np.zeros((3, 3)), fx.np.array([[0, 1, 2]]), fx.np.zeros((3, 3))).transformed),
        [[NAN] * 3] * 3,
        [0, 0, 0],
    )


def systems_cases() -> list[Case]:
    b = Builder("systems")
    _systems_from_urdf(b)
    _systems_append_robots(b)
    _systems_system(b)
    _systems_limits(b)
    _systems_registry_and_synthetic_systems(b)
    return b.cases


# ---------------------------------------------------------------------------- sweep
def _sweep_jobs(b: Builder, job: dict[str, Any]) -> None:
    """Bad jobs for ``normalize_job`` (``job``: a valid one, varied one field at a time)."""
    import coop_ga.sweep as W

    def with_(**kw: Any) -> dict[str, Any]:
        return {**job, **kw}

    for arg, bad, j in (
        ("job", "a list", [1, 2]),
        ("job", "None", None),
        ("system", "missing", {"kind": "circle", "controller": "gn"}),
        ("system", "an int", with_(system=3)),
        ("system", "a recipe without urdf", with_(system={"end_frames": ["a"]})),
        ("kind", "an int", with_(kind=3)),
        ("controller", "'newton'", with_(controller="newton")),
        ("target", "NaN translation", with_(target={"translation": [NAN, 0, 0]})),
        ("target", "a string", with_(target="far")),
        ("target", "an unknown level", with_(target={"sampler": "displacement", "level": "huge"})),
        ("target", "12 NaN coefficients", with_(target={"coeffs": [NAN] * 12})),
        ("target", "an inf angle", with_(target={"angle": INF})),
        ("options", "a list", with_(options=[1])),
        ("seed", "negative", with_(seed=-1)),
        ("seed", "a float", with_(seed=1.5)),
        ("seed", "a string", with_(seed="abc")),
        ("certify", "a string", with_(certify="yes")),
        ("points", "strings", with_(points=["a", "b", "c"])),
        ("points", "floats", with_(points=[0.5, 1, 2])),
        ("start", "unknown key", with_(start={"radius": 1})),
        ("tags", "a reserved name", with_(tags={"status": 1})),
        ("job", "an unknown field", with_(speed=3)),
        ("job", "a set", with_(tags={"t": {1, 2}})),
    ):
        b.add("normalize_job", arg, bad, W.normalize_job, j)


def _sweep_specs(b: Builder, job: dict[str, Any]) -> None:
    """Bad sweep specifications for ``expand``."""
    import coop_ga.sweep as W

    for arg, bad, spec in (
        ("spec", "an int", 5),
        ("spec", "a list", [1, 2]),
        ("sample", "10⁸ jobs", {"base": job, "grid": {"sample": 10**8}}),
        (
            "grid",
            "10⁸ jobs (4 axes)",
            {
                "base": job,
                "grid": {
                    "options.a": list(range(100)),
                    "options.b": list(range(100)),
                    "options.c": list(range(100)),
                    "sample": 100,
                },
            },
        ),
        ("sample", "zero", {"base": job, "grid": {"sample": 0}}),
        ("sample", "a float", {"base": job, "grid": {"sample": 2.5}}),
        ("grid", "a list", {"base": job, "grid": [1, 2]}),
        ("grid", "an unknown key", {"base": job, "grid": {"speed": [1, 2]}}),
        ("jobs", "an int", {"jobs": 5}),
        ("jobs", "with a grid", {"jobs": [job], "grid": {"sample": 2}}),
        ("seed", "negative", {"base": job, "seed": -1}),
        ("seeding", "'random'", {"base": job, "seeding": "random"}),
        ("spec", "an unknown field", {"base": job, "bogus": 1}),
        ("base", "a string", {"base": "job"}),
        ("spec", "a missing file", "/nonexistent/spec.json"),
    ):
        b.add("expand", arg, bad, W.expand, spec)


def _sweep_files_and_seeds(b: Builder, job: dict[str, Any]) -> None:
    """Bad spec files, hashes, seeds and target levels."""
    import coop_ga.sweep as W

    bomb = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n" for p, c in zip("abcdefgh", "bcdefghi")
    )
    b.add("load_spec", "source", "a YAML alias bomb", W.load_spec, lambda fx: fx.file("bomb.yaml", bomb))
    b.add("load_spec", "source", "invalid JSON", W.load_spec, lambda fx: fx.file("bad.json", "{oops"))
    b.add("load_spec", "source", "a JSON list", W.load_spec, lambda fx: fx.file("list.json", "[1, 2]"))
    b.add("load_spec", "source", "NaN in JSON", W.load_spec, lambda fx: fx.file("nan.json", '{"seed": NaN}'))
    b.add("load_spec", "source", "None", W.load_spec, None)
    b.add("load_spec", "fast", "a string", W.load_spec, {"base": job}, fast="yes")
    b.add("job_hash", "job", "NaN", W.job_hash, {"x": NAN})
    b.add("job_hash", "job", "a set", W.job_hash, {"x": {1}})
    b.add("seeds", "n", "negative", W.seeds, 0, -1)
    b.add("seeds", "n", "10¹²", W.seeds, 0, 10**12)
    b.add("seeds", "root", "a string", W.seeds, "x", 2)
    b.add("seeds", "root", "negative", W.seeds, -1, 2)
    b.add("seeds", "n", "a float", W.seeds, 0, 2.5)
    b.add("seed_sequence", "seed", "a float", W.seed_sequence, 1.5)
    b.add("seed_sequence", "seed", "a dict with a string", W.seed_sequence, {"entropy": "x"})
    b.add("seed_sequence", "seed", "negative spawn key", W.seed_sequence, {"entropy": 1, "spawn_key": [-1]})
    b.add("name_spawn_key", "values", "a float", W.name_spawn_key, [1.5])
    b.add("name_spawn_key", "values", "an int", W.name_spawn_key, 5)
    rng = lambda fx: fx.np.random.default_rng(0)  # noqa: E731
    b.add("draw_displacement", "rng", "an int", W.draw_displacement, 3, W.LEVELS["small"], 9)
    b.add("draw_displacement", "level", "a string", W.draw_displacement, rng, "small", 9)
    b.add("draw_displacement", "nq", "negative", W.draw_displacement, rng, W.LEVELS["small"], -1)
    b.add("draw_displacement", "qd_max", "NaN", W.draw_displacement, rng, W.LEVELS["small"], 9, NAN)
    b.add("Level", "translation_m", "NaN", W.Level, NAN, 5.0, 0.05)
    b.add("Level", "scale", "≥ 1 (a zero or negative scale)", W.Level, 0.02, 5.0, 1.5)
    b.add("Level", "angle_deg", "a string", W.Level, 0.02, "5", 0.05)


def _sweep_runs_and_records(b: Builder, job: dict[str, Any]) -> None:
    """Bad arguments to the run, its records, summaries and plots."""
    import coop_ga.sweep as W

    b.add("summarize", "records", "an int", W.summarize, 5)
    b.add("summarize", "records", "strings", W.summarize, ["a", "b"])
    b.add(
        "summarize",
        "quantiles",
        "1.5",
        W.summarize,
        [{"controller": "gn", "status": "ok", "iterations": 3}],
        quantiles=[1.5],
    )
    b.add("summarize", "by", "an int", W.summarize, [{"controller": "gn"}], by=3)
    b.add("format_table", "rows", "an int", W.format_table, 5)
    b.add("format_table", "rows", "strings", W.format_table, ["a"])
    b.add("run", "executor", "'threads'", W.run, [job], "threads")
    b.add("run", "workers", "zero", W.run, [job], "process", 0)
    b.add("run", "workers", "a string", W.run, [job], "process", "2")
    b.add("run", "workers", "a float", W.run, [job], "process", 1.5)
    b.add("run", "format", "'csv'", W.run, [job], format="csv")
    b.add("run", "jobs", "an int", W.run, 5)
    b.add("run", "out", "an int", W.run, [job], out=3)
    b.add("run", "timeout", "negative", W.run, [job], timeout=-1.0)
    b.add("read_records", "out", "an int", W.read_records, 3)
    b.add("read_records", "out", "None", W.read_records, None)
    b.add("RecordWriter", "fmt", "'csv'", W.RecordWriter, lambda fx: str(fx.tmp / "rw"), "csv")
    b.add("RecordWriter", "batch", "zero", W.RecordWriter, lambda fx: str(fx.tmp / "rw2"), batch=0)
    b.add("records_equal", "a", "an int", W.records_equal, 3, [])
    b.add("plot", "records", "an int", W.plot, 5, lambda fx: str(fx.tmp / "p.png"))
    b.add("run_job", "job", "a string", W.run_job, 0, "job")
    b.add("run_job", "index", "a string", W.run_job, "0", job)


def sweep_cases() -> list[Case]:
    b = Builder("sweep")
    job = {"system": "cartesian3", "kind": "circle", "controller": "gauss_newton"}
    _sweep_jobs(b, job)
    _sweep_specs(b, job)
    _sweep_files_and_seeds(b, job)
    _sweep_runs_and_records(b, job)
    return b.cases


BUILDERS: dict[str, Callable[[], list[Case]]] = {
    "collision": collision_cases,
    "linkages": linkage_cases,
    "legged": legged_cases,
    "systems": systems_cases,
    "sweep": sweep_cases,
}


def build_cases(modules: tuple[str, ...] = MODULES, ci: bool = False) -> list[Case]:
    """The cases of ``modules`` (in :data:`MODULES` order); ``ci``: the first two cases of every function."""
    cases: list[Case] = []
    for m in MODULES:
        if m in modules:
            cases += BUILDERS[m]()
    if ci:
        seen: dict[tuple[str, str], int] = {}
        kept = []
        for c in cases:
            k = (c.module, c.function)
            seen[k] = seen.get(k, 0) + 1
            if seen[k] <= 2:
                kept.append(c)
        cases = kept
    return cases


# ============================================================================ running one case
class _Timeout(BaseException):
    """Raised by SIGALRM inside a case (a BaseException: ``except Exception`` in coop_ga does not swallow it)."""


def _alarm(signum: int, frame: Any) -> None:
    raise _Timeout()


def _snapshot(x: Any, depth: int = 0) -> Any:
    """A comparable deep copy of plain data and numpy arrays (objects by identity and type)."""
    import numpy as np

    if depth > 6:
        return ("deep", id(x))
    if isinstance(x, np.ndarray):
        return ("arr", x.dtype.str, x.shape, x.tobytes() if x.dtype != object else repr(x.tolist()))
    if isinstance(x, (list, tuple)):
        return (type(x).__name__, tuple(_snapshot(v, depth + 1) for v in x))
    if isinstance(x, dict):
        return ("dict", tuple((repr(k), _snapshot(v, depth + 1)) for k, v in x.items()))
    if isinstance(x, set):
        return ("set", tuple(sorted(repr(v) for v in x)))
    if isinstance(x, float) and math.isnan(x):
        return ("nan",)
    if isinstance(x, (int, float, complex, str, bytes, bool, type(None))):
        return ("val", x)
    return ("obj", type(x).__name__, id(x))


def _nonfinite(x: Any, depth: int = 0, seen: set[int] | None = None) -> str | None:
    """Where a result holds NaN or inf (a path), or None: numbers, arrays, containers, dataclasses, multivectors."""
    import numpy as np

    seen = set() if seen is None else seen
    if depth > 5 or id(x) in seen:
        return None
    if isinstance(x, (bool, np.bool_, str, bytes, type(None))):
        return None
    if isinstance(x, (float, np.floating, complex, np.complexfloating)):
        return "" if not np.isfinite(x) else None
    if isinstance(x, np.ndarray):
        if x.dtype.kind in "fc" and not np.all(np.isfinite(x)):
            return ""
        if x.dtype == object:
            return _nonfinite(x.tolist(), depth + 1, seen)
        return None
    if type(x).__name__ == "JointLimits":  # ±inf there means "unbounded" (coop_ga.systems.limits)
        return None
    seen.add(id(x))
    if isinstance(x, dict):
        items = list(x.items())
    elif isinstance(x, (list, tuple)):
        items = list(enumerate(x))
    elif dataclasses.is_dataclass(x) and not isinstance(x, type):
        items = [(f.name, getattr(x, f.name, None)) for f in dataclasses.fields(x)]
    elif type(x).__name__ in ("Multivector", "Primitive", "Similarity") and hasattr(x, "coeffs"):
        items = list(enumerate(x.coeffs))
    else:
        return None
    for k, v in items:
        where = _nonfinite(v, depth + 1, seen)
        if where is not None:
            return f"[{k!r}]{where}"
    return None


def run_case(case: Case, fx: Fixtures, limit: float) -> dict[str, Any]:
    """Run one case with a SIGALRM time limit; the record of its outcome (module docstring)."""
    from coop_ga.errors import CoopGAError

    rec: dict[str, Any] = {
        "id": case.id,
        "module": case.module,
        "function": case.function,
        "arg": case.arg,
        "bad": case.bad,
        "outcome": "",
        "exception_type": None,
        "message": "",
        "mutated": False,
        "unnamed": False,
        "seconds": 0.0,
    }
    t0 = time.perf_counter()
    try:
        f, args, kwargs = case.make(fx)
    except Exception as exc:  # a bug of this script (a fixture failed)
        rec.update(outcome="setup_error", exception_type=type(exc).__name__, message=str(exc)[:400])
        return rec
    before = [_snapshot(a) for a in args] + [_snapshot(v) for v in kwargs.values()]
    out: Any = None
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, limit)
    try:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = f(*args, **kwargs)
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        where = _nonfinite(out)
        rec["outcome"] = "nonfinite" if where is not None else "accepted_invalid"
        if where is not None:
            rec["message"] = f"non-finite value at result{where}"
    except _Timeout:
        rec.update(outcome="hang", message=f"no result after {limit:g} s")
    except CoopGAError as exc:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        msg = str(exc)
        rec.update(outcome="refused", exception_type=type(exc).__name__, message=msg[:400])
        rec["unnamed"] = not re.search(rf"(?<![A-Za-z0-9_]){re.escape(case.arg)}(?![A-Za-z0-9_])", msg, re.IGNORECASE)
    except BaseException as exc:  # the failure under test (MemoryError, RecursionError included)
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        rec.update(outcome="other_exception", exception_type=type(exc).__name__, message=str(exc)[:400])
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)
    rec["seconds"] = time.perf_counter() - t0
    after = [_snapshot(a) for a in args] + [_snapshot(v) for v in kwargs.values()]
    rec["mutated"] = before != after
    del out
    return rec


# ============================================================================ the worker process
def _worker(conn: Any, modules: tuple[str, ...], ci: bool, start: int, limit: float, memory_gb: float) -> None:
    """Run cases from index ``start`` on, sending ("start", i) before and ("done", record) after each."""
    import resource

    if memory_gb > 0:
        cap = int(memory_gb * 2**30)
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    cases = build_cases(modules, ci)
    fx = Fixtures()
    for i in range(start, len(cases)):
        conn.send(("start", i))
        conn.send(("done", run_case(cases[i], fx, limit)))
    conn.send(("end", None))


def run_cases(
    modules: tuple[str, ...], ci: bool, limit: float, memory_gb: float, grace: float = 20.0, quiet: bool = False
) -> list[dict[str, Any]]:
    """Every case of ``modules`` in a spawned worker; a worker silent for ``limit + grace`` s is killed and the
    case recorded as a hang (the next worker starts at the following case)."""
    cases = build_cases(modules, ci)
    records: list[dict[str, Any] | None] = [None] * len(cases)
    ctx = mp.get_context("spawn")
    start = 0
    bar = _progress(len(cases), quiet)
    while start < len(cases):
        parent, child = ctx.Pipe(duplex=False)
        # not a daemon: a case may start a process pool of its own (sweep.run)
        proc = ctx.Process(target=_worker, args=(child, modules, ci, start, limit, memory_gb), daemon=False)
        proc.start()
        child.close()
        current = start
        boot = 120.0  # the first message comes after the imports
        while True:
            if not parent.poll(boot if current == start and records[current] is None else limit + grace):
                kind, payload = "timeout", None
            else:
                try:
                    kind, payload = parent.recv()
                except EOFError:
                    kind, payload = "died", None
            if kind == "start":
                current = payload
                continue
            if kind == "done":
                records[current] = payload
                bar(1)
                continue
            if kind == "end":
                start = len(cases)
                break
            # the worker hangs (in C code, out of SIGALRM's reach) or died: record, restart after this case
            c = cases[current]
            why = f"no answer after {limit + grace:g} s" if kind == "timeout" else "the worker process died"
            records[current] = {
                "id": c.id,
                "module": c.module,
                "function": c.function,
                "arg": c.arg,
                "bad": c.bad,
                "outcome": "hang" if kind == "timeout" else "other_exception",
                "exception_type": None if kind == "timeout" else "WorkerDied",
                "message": why,
                "mutated": False,
                "unnamed": False,
                "seconds": limit + grace if kind == "timeout" else 0.0,
            }
            bar(1)
            start = current + 1
            break
        with contextlib.suppress(Exception):
            proc.kill()
        proc.join(5)
    return [r for r in records if r is not None]


def _progress(total: int, quiet: bool) -> Callable[[int], None]:
    if quiet:
        return lambda n: None
    from tqdm import tqdm

    bar = tqdm(total=total, desc="bad inputs", unit="case", file=sys.stderr, leave=False)
    return bar.update


# ============================================================================ report
def summarize(records: list[dict[str, Any]]) -> dict[str, dict[str, int]]:
    """Counts per module (and ``"all"``): cases, each outcome, mutated, unnamed, failures."""
    out: dict[str, dict[str, int]] = {}
    for key in [*MODULES, "all"]:
        rs = [r for r in records if key == "all" or r["module"] == key]
        if not rs:
            continue
        row = {"cases": len(rs)}
        row.update({o: sum(r["outcome"] == o for r in rs) for o in OUTCOMES})
        row["mutated"] = sum(bool(r["mutated"]) for r in rs)
        row["unnamed"] = sum(bool(r["unnamed"]) for r in rs)
        row["failures"] = sum(r["outcome"] in FAILURES or r["mutated"] or r["unnamed"] for r in rs)
        out[key] = row
    return out


def failing(records: list[dict[str, Any]]) -> Iterator[dict[str, Any]]:
    for r in records:
        if r["outcome"] in FAILURES or r["mutated"] or r["unnamed"]:
            yield r


def main(argv: list[str] | None = None) -> int:
    from coop_ga.harness import experiment_parser, positive_float, write_json

    p = experiment_parser("bad_inputs", __doc__, seed=None)
    p.add_argument("--ci", action="store_true", help="short mode: the first two cases of every function")
    p.add_argument("--modules", nargs="+", choices=MODULES, default=list(MODULES), help="modules to test")
    p.add_argument("--time-limit", type=positive_float, default=10.0, help="per-case time limit [s]")
    p.add_argument("--memory-gb", type=positive_float, default=6.0, help="address-space cap of the worker [GiB]")
    p.add_argument(
        "--require",
        nargs="*",
        choices=MODULES,
        default=list(MODULES),
        help="modules that must have no failure for exit status 0",
    )
    p.add_argument("--list", action="store_true", help="list the cases and exit")
    args = p.parse_args(argv)
    modules = tuple(args.modules)
    if args.list:
        for c in build_cases(modules, args.ci):
            print(c.id)
        return 0
    t0 = time.perf_counter()
    records = run_cases(modules, args.ci, args.time_limit, args.memory_gb, quiet=args.quiet)
    wall = time.perf_counter() - t0
    summary = summarize(records)
    header = [
        "module",
        "cases",
        "refused",
        "non-CoopGAError",
        "NaN/inf",
        "accepted-invalid",
        "hangs",
        "mutated",
        "unnamed",
        "setup errors",
    ]
    rows = [
        [
            m,
            s["cases"],
            s["refused"],
            s["other_exception"],
            s["nonfinite"],
            s["accepted_invalid"],
            s["hang"],
            s["mutated"],
            s["unnamed"],
            s["setup_error"],
        ]
        for m, s in summary.items()
    ]
    # the table is the result: printed also with --quiet (which silences the progress bar only)
    print_table(f"bad inputs ({'ci' if args.ci else 'full'}, {wall:.0f} s)", header, rows)
    bad = list(failing(records))
    if bad:
        print(f"\n{len(bad)} failing case(s):")
        for r in bad:
            flags = "".join(f" [{k}]" for k in ("mutated", "unnamed") if r[k])
            print(f"  {r['outcome']:<16} {r['id']}{flags}: {r['exception_type'] or ''} {r['message'][:160]}")
    write_json(
        Path(args.out) / "bad_inputs.json",
        {
            "config": {
                "ci": args.ci,
                "modules": list(modules),
                "time_limit_s": args.time_limit,
                "memory_gb": args.memory_gb,
            },
            "summary": summary,
            "records": records,
            "wall_s": wall,
        },
    )
    ok = all(summary.get(m, {"failures": 0})["failures"] == 0 for m in args.require if m in modules)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
