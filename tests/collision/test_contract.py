"""The error contract of coop_ga.collision: bad arguments raise a CoopGAError naming them; no NaN/inf comes back.

Regression tests: before these checks every distance function returned NaN for a NaN input (and inf, or a
numpy ValueError, for others), ``potential_path`` reported a one-point path as "reached" when the step (its
default goal tolerance) was as long as the start–goal distance — so ``experiments/potential_field.py --step 100``
gave a path-length ratio of 0 — and ``random_scene`` looped forever on scenes that cannot be drawn.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from coop_ga import collision as C
from coop_ga.collision import potential as pot
from coop_ga.errors import InvalidInputError, NonFiniteError
from coop_ga.systems import cartesian_points

NAN, INF = float("nan"), float("inf")
SPHERE = C.Sphere([0.0, 0.0, 0.5], 0.1)
PLANE = C.Plane([0.0, 0.0, 1.0], 0.0)
Z, E3 = [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]

#: (function, arguments) with one point argument replaced by each bad value below
POINT_CALLS = [
    (C.conformal_point, lambda p: (p,), "x"),
    (C.point_sphere_product, lambda p: (p, SPHERE), "x"),
    (C.point_sphere_distance, lambda p: (p, SPHERE), "x"),
    (C.point_plane_distance, lambda p: (p, PLANE), "x"),
    (C.segment_point_parameter, lambda p: (Z, E3, p), "c"),
    (C.capsule_sphere_distance, lambda p: (p, E3, 0.05, SPHERE), "a"),
    (C.capsule_plane_distance, lambda p: (Z, p, 0.05, PLANE), "b"),
    (C.segment_segment_closest, lambda p: (Z, E3, p, [1.0, 0.0, 1.0]), "q0"),
    (C.capsule_capsule_distance, lambda p: (Z, E3, 0.05, [1.0, 0.0, 0.0], p, 0.05), "b1"),
    (C.seed002_link_sphere_distance, lambda p: (p, E3, 0.02, SPHERE), "p_i"),
]


@pytest.mark.parametrize("f, args, arg", POINT_CALLS, ids=[c[0].__name__ for c in POINT_CALLS])
@pytest.mark.parametrize("bad", [[NAN, 0.0, 0.0], [0.0, INF, 0.0], [0.0, 0.0, -INF]])
def test_every_distance_function_refuses_nan_and_inf(f, args, arg, bad):
    with pytest.raises(NonFiniteError, match=rf"\b{arg}\b"):
        f(*args(bad))


@pytest.mark.parametrize("f, args, arg", POINT_CALLS, ids=[c[0].__name__ for c in POINT_CALLS])
@pytest.mark.parametrize("bad", ["abc", None, [1j, 0.0, 0.0], [True, False, True], [[0.0, 1.0], [2.0]], [0.0] * 4])
def test_wrong_types_and_shapes_are_coop_ga_errors(f, args, arg, bad):
    with pytest.raises(InvalidInputError, match=rf"\b{arg}\b"):
        f(*args(bad))


@pytest.mark.parametrize("f, args, arg", POINT_CALLS, ids=[c[0].__name__ for c in POINT_CALLS])
def test_coordinates_that_overflow_are_refused_not_returned_as_inf(f, args, arg):
    with pytest.raises(InvalidInputError, match=rf"\b{arg}\b.*(overflow|representable)"):
        f(*args([1e200, 0.0, 0.0]))


def test_radii_obstacles_and_batches_are_checked():
    with pytest.raises(InvalidInputError, match="radius must be ≥ 0"):
        C.capsule_sphere_distance(Z, E3, -0.05, SPHERE)
    with pytest.raises(NonFiniteError, match="rb"):
        C.capsule_capsule_distance(Z, E3, 0.05, Z, E3, NAN)
    with pytest.raises(InvalidInputError, match=r"sphere must be a collision\.Sphere"):
        C.capsule_sphere_distance(Z, E3, 0.05, PLANE)
    with pytest.raises(InvalidInputError, match=r"plane must be a collision\.Plane"):
        C.point_plane_distance(Z, {"normal": E3})
    with pytest.raises(InvalidInputError, match="do not broadcast"):
        C.segment_segment_closest(np.zeros((4, 3)), np.ones((5, 3)), Z, E3)
    with pytest.raises(InvalidInputError, match="radius has shape"):
        C.capsule_sphere_distance(Z, E3, [0.05], SPHERE)  # a radius never adds a batch dimension
    # batches with one radius per pair, and CasADi symbols, still work
    A = np.random.default_rng(0).normal(size=(6, 3))
    d, _ = C.capsule_sphere_distance(A, A + 0.1, np.full(6, 0.02), SPHERE)
    assert d.shape == (6,) and np.all(np.isfinite(d))
    x = ca.SX.sym("x", 3)
    assert isinstance(C.point_sphere_distance(x, SPHERE), ca.SX)


def test_obstacles_and_capsules_refuse_bad_fields():
    with pytest.raises(InvalidInputError, match="name must be a string"):
        C.as_obstacle({"center": Z, "radius": 0.1}, name=[1])
    with pytest.raises(InvalidInputError, match="beyond"):
        C.Sphere([1e200, 0.0, 0.0], 0.1)
    with pytest.raises(InvalidInputError, match=r"Capsule\.radius"):
        C.Capsule("tip0", Z, E3, "r")
    with pytest.raises(InvalidInputError, match=r"Capsule\.chain"):
        C.Capsule("tip0", Z, E3, 0.05, chain=1.5)
    with pytest.raises(InvalidInputError, match="tol"):
        C.Capsule("tip0", Z, E3, 0.05).contains([Z], tol=-1.0)
    with pytest.raises(InvalidInputError, match="vertices"):
        C.fit_capsule([[1e200, 0, 0], [0, 1e200, 0], [0, 0, 0]])


def test_collision_model_checks_its_arguments():
    s = cartesian_points(3)
    caps = [C.Capsule(f"tip{i}", Z, [0.0, 0.0, 0.1], 0.05) for i in range(3)]
    with pytest.raises(InvalidInputError, match=r"system must be a coop_ga\.systems\.System"):
        C.CollisionModel("cartesian3", capsules=caps)
    with pytest.raises(InvalidInputError, match="margin"):
        C.CollisionModel(s, capsules=caps, margin="0.1")
    with pytest.raises(NonFiniteError, match=r"obstacles\[0\]"):
        C.CollisionModel(s, [{"center": [NAN, 0, 0], "radius": 1.0}], capsules=caps)
    with pytest.raises(InvalidInputError, match="self_collision"):
        C.CollisionModel(s, capsules=caps, self_collision="yes")
    cm = C.CollisionModel(s, [SPHERE], capsules=caps)
    with pytest.raises(InvalidInputError, match=r"\bq\b"):
        cm.distances("abc")
    with pytest.raises(NonFiniteError, match=r"\bq\b"):
        cm.distances([[0.0] * 9, [INF] * 9])
    with pytest.raises(InvalidInputError, match="CasADi SX column"):
        cm.symbolic(np.zeros(9))


def test_coulomb_potential_and_field_refuse_a_point_on_a_charge():
    C1 = [[1.0, 0.0, 0.0]]
    for f in (pot.coulomb_potential, pot.coulomb_field):
        with pytest.raises(InvalidInputError, match="charge 0"):
            f([1.0, 0.0, 0.0], C1, [0.1], Z)
        with pytest.raises(InvalidInputError, match="the goal"):
            f(Z, C1, [0.1], Z)
    with pytest.raises(InvalidInputError, match="2 charges q for 1 centers"):
        pot.coulomb_potential([0.0, 1.0, 0.0], C1, [0.1, 0.2], Z)
    with pytest.raises(InvalidInputError, match="security_radii must be > 0"):
        pot.charges([-0.5], C1, Z)
    assert math.isfinite(pot.coulomb_potential([0.0, 1.0, 0.0], C1, [0.1], Z))


def test_potential_path_refuses_a_tolerance_as_long_as_the_distance():
    """A step (the default goal tolerance) ≥ the start–goal distance used to return the start alone as
    "reached": a path of length 0 — with an obstacle blocking the straight line."""
    wall = [pot.obstacle([0.5, 0.0, 0.0], 0.1)]
    with pytest.raises(InvalidInputError, match=r"step \(the default goal tolerance tol\) = 100 m"):
        pot.potential_path(Z, [1.0, 0.0, 0.0], wall, step=100.0)
    with pytest.raises(InvalidInputError, match="tol = 2 m"):
        pot.potential_path(Z, [1.0, 0.0, 0.0], wall, tol=2.0)
    r = pot.potential_path(Z, [1.0, 0.0, 0.0], [], step=2.0, tol=0.01)  # long step, explicit tol: straight line
    assert r.reached and r.length == pytest.approx(1.0) and r.final_distance == 0.0
    with pytest.raises(InvalidInputError, match="max_iter"):
        pot.potential_path(Z, [1.0, 0.0, 0.0], max_iter=10**12)
    with pytest.raises(InvalidInputError, match="obstacles"):
        pot.potential_path(Z, [1.0, 0.0, 0.0], 5)


def test_random_scene_gives_up_instead_of_looping():
    rng = np.random.default_rng(0)
    with pytest.raises(InvalidInputError, match="n_obstacles"):
        pot.random_scene(rng, 10**6)
    with pytest.raises(InvalidInputError, match="no scene"):
        pot.random_scene(rng, 3, margin=5.0)  # every sphere would cover the start
    with pytest.raises(InvalidInputError, match="rng"):
        pot.random_scene(3, 2)


def _experiment():
    path = Path(__file__).resolve().parents[2] / "experiments" / "potential_field.py"
    spec = importlib.util.spec_from_file_location("potential_field_experiment", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_experiment_refuses_a_step_as_long_as_a_scene(capsys):
    """``potential_field.py --fast --step 100`` reported path_length_ratio_median 0.0."""
    with pytest.raises(SystemExit) as exc:
        _experiment().main(["--fast", "--quiet", "--step", "100", "--out", "/nonexistent/never_written"])
    assert exc.value.code == 2
    assert "must be below 1 m" in capsys.readouterr().err


def test_experiment_length_ratio_only_counts_paths_on_the_goal():
    mod = _experiment()
    goal = np.array([1.0, 0.0, 0.0])
    on = pot.potential_path(Z, goal, [], step=0.01)
    off = pot.PotentialPath(
        path=np.array([Z, [0.6, 0.0, 0.0]]),
        reached=True,  # within a (large) tolerance of the goal, but not on it
        status="reached",
        message="",
        iterations=1,
        final_distance=0.4,
        clearance=np.zeros(0),
        charges=np.zeros(0),
        security_radii=np.zeros(0),
        centers=np.zeros((0, 3)),
        guard_steps=0,
    )
    st = mod._scene_stats([(on, 1.0), (off, 1.0)])
    assert st["reached"] == 2
    assert st["length_ratio_median"] == pytest.approx(1.0) and st["length_ratio_max"] == pytest.approx(1.0)
