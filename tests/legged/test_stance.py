"""coop_ga.legged.stance: the stance primitive of each stance size on flat and uneven ground (the decision
rule, including the singular flat 4-foot sphere), and the cooperative task of the named stance feet."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.geometry.groups import Similarity
from coop_ga.geometry.primitives import center, normal, radius
from coop_ga.geometry.similarity import similarity_from_unit
from coop_ga.kinematics.chains import KinematicTree
from coop_ga.legged.stance import LEGS, STANCE_ORDER, stance_order, stance_primitive, stance_task
from coop_ga.legged.terrain import Terrain

HEX = cg.systems.load("hexapod")
_P0 = KinematicTree(HEX.model, HEX.end_frames).end_points_array(HEX.q0)
#: the stand-pose feet in B, rows in STANCE_ORDER (counter-clockwise from above)
FEET_B = np.array([_P0[HEX.end_frames.index(f"{leg}_foot")] for leg in STANCE_ORDER])
SUBSETS = {  # rows of FEET_B: a tripod, a ripple-like 4-foot stance, a wave-like 5-foot stance, all six
    3: [0, 2, 4],
    4: [0, 1, 2, 4],
    5: [0, 1, 2, 3, 4],
    6: [0, 1, 2, 3, 4, 5],
}


def _on(terrain: Terrain, shift=(0.0, 0.0)) -> np.ndarray:
    """The stand-pose footprint moved by ``shift`` (2,) and landed on the terrain (W)."""
    return terrain.land(FEET_B[:, :2] + np.asarray(shift))


def _finite(sp) -> None:
    assert np.all(np.isfinite(sp.center))
    assert sp.radius is None or (math.isfinite(sp.radius) and sp.radius <= 5.0)
    assert np.all(np.isfinite(np.array([float(c) for c in sp.X.coeffs])))
    assert math.isfinite(sp.well_definedness) and 0.0 <= sp.well_definedness <= 1.0 + 1e-12


# ---------------------------------------------------------------------- flat ground
@pytest.mark.parametrize("k", [3, 4, 5, 6])
def test_flat_ground_is_always_the_plane(k):
    feet = _on(Terrain.flat(0.02))[SUBSETS[k]]
    sp = stance_primitive(feet)
    _finite(sp)
    assert sp.kind == "plane" and sp.X.kind == "plane"
    assert sp.task_kind == ("plane" if k == 3 else "plane_fit")
    np.testing.assert_allclose(sp.normal, [0.0, 0.0, 1.0], atol=1e-15)  # counter-clockwise feet: normal up
    np.testing.assert_allclose(normal(sp.X), [0.0, 0.0, 1.0], atol=1e-15)
    assert sp.center[2] == pytest.approx(0.02, abs=1e-15)
    assert sp.radius is None and sp.indices == tuple(range(k))
    if k >= 4:  # the singular sphere: detected by its well-definedness, switched to the plane
        assert sp.sphere_well_definedness < 1e-12
        assert sp.sphere_radius is None
        assert "coplanar" in sp.reason and "w_min" in sp.reason
    else:
        assert sp.sphere_well_definedness is None


def test_flat_four_feet_forced_sphere_raises_and_circle_on_request():
    feet = _on(Terrain.flat())
    with pytest.raises(cg.DegeneratePrimitiveError, match="coplanar"):
        stance_primitive(feet[SUBSETS[4]], kind="sphere")
    sp = stance_primitive(feet[SUBSETS[3]], kind="circle")
    assert sp.kind == "circle" == sp.task_kind
    for p in feet[SUBSETS[3]]:
        assert np.linalg.norm(p - sp.center) == pytest.approx(sp.radius, rel=1e-13)
    np.testing.assert_allclose(sp.normal, [0.0, 0.0, 1.0], atol=1e-15)
    with pytest.raises(cg.InvalidInputError, match="exactly 3"):
        stance_primitive(feet[SUBSETS[4]], kind="circle")
    with pytest.raises(cg.InvalidInputError, match="at least 4"):
        stance_primitive(feet[SUBSETS[3]], kind="sphere")
    sp = stance_primitive(feet[SUBSETS[4]], kind="plane")
    assert sp.kind == "plane" and sp.reason.startswith("requested")


def test_slope_gives_its_plane():
    T = Terrain.slope(0.15, (1.0, 0.5))
    for k in (3, 4, 6):
        sp = stance_primitive(_on(T)[SUBSETS[k]])
        assert sp.kind == "plane"
        np.testing.assert_allclose(sp.normal, T.normal([0.0, 0.0]), atol=1e-14)
        assert T.signed_distance(sp.center) == pytest.approx(0.0, abs=1e-15)


def test_nearly_flat_four_feet_switch_to_the_plane_instead_of_a_huge_sphere():
    feet = _on(Terrain.flat())[SUBSETS[4]]
    feet[1, 2] += 1e-4  # one foot 0.1 mm higher: the exact sphere exists but is huge and ill-conditioned
    forced = stance_primitive(feet, w_min=0.0, r_max=math.inf)
    assert forced.kind == "sphere" and forced.radius > 50.0  # what the sphere would be
    sp = stance_primitive(feet)
    assert sp.kind == "plane" and sp.sphere_well_definedness < 1e-2 and sp.radius is None
    _finite(sp)


def test_the_radius_bound_also_switches_to_the_plane():
    # four feet on a sphere of radius 6 m: well defined (w ≥ w_min) but larger than r_max = 5 m
    c, R = np.array([0.0, 0.0, 6.0]), 6.0
    xy = np.array([[0.6, 0.0], [-0.3, 0.52], [-0.3, -0.52], [0.05, 0.0]])
    feet = np.c_[xy, c[2] - np.sqrt(R**2 - (xy**2).sum(1))]
    assert cg.well_definedness("sphere", feet) > 1e-2
    sp = stance_primitive(feet)
    assert sp.kind == "plane" and "r_max" in sp.reason
    assert sp.sphere_radius == pytest.approx(6.0, rel=1e-12)
    sp2 = stance_primitive(feet, r_max=10.0)
    assert sp2.kind == "sphere" and sp2.radius == pytest.approx(6.0, rel=1e-12)
    np.testing.assert_allclose(sp2.center, c, atol=1e-11)


# ---------------------------------------------------------------------- uneven ground
@pytest.mark.parametrize("seed", [1, 4])
def test_random_terrain_spheres(seed):
    T = Terrain.random(seed=seed)
    feet6 = _on(T, (0.1, -0.05))
    assert np.ptp(feet6[:, 2]) > 0.005  # really uneven under the feet
    kinds = []
    for k in (4, 5, 6):
        feet = feet6[SUBSETS[k]]
        sp = stance_primitive(feet)
        _finite(sp)
        kinds.append(sp.kind)
        # the decision rule: a sphere exactly when it is well defined and not too large
        sw, sr = sp.sphere_well_definedness, sp.sphere_radius
        assert (sp.kind == "sphere") == (sw >= 1e-2 and sr is not None and sr <= 5.0)
        if sp.kind == "plane":
            assert sp.task_kind == "plane_fit" and ("w_min" in sp.reason or "r_max" in sp.reason)
            continue
        assert sp.X.kind == "sphere"
        assert sp.task_kind == ("sphere" if k == 4 else "sphere_fit")
        assert sp.well_definedness >= 1e-2 and sp.radius <= 5.0
        np.testing.assert_allclose(center(sp.X), sp.center, atol=1e-12)
        assert float(radius(sp.X)) == pytest.approx(sp.radius, rel=1e-12)
        d = np.linalg.norm(feet - sp.center, axis=1) - sp.radius
        if k == 4:  # through the four feet
            np.testing.assert_allclose(d, 0.0, atol=1e-12)
        else:  # least squares: the sphere (4 parameters) fits the feet better than the best plane (3)
            pl = stance_primitive(feet, kind="plane")
            assert np.sqrt(np.mean(d**2)) < np.sqrt(np.mean(((feet - pl.center) @ pl.normal) ** 2))
    assert kinds == {1: ["sphere"] * 3, 4: ["plane", "sphere", "sphere"]}[seed]
    # the tripod is always a plane through its three feet
    sp3 = stance_primitive(feet6[SUBSETS[3]])
    assert sp3.kind == "plane" and sp3.task_kind == "plane"
    np.testing.assert_allclose((feet6[SUBSETS[3]] - sp3.center) @ sp3.normal, 0.0, atol=1e-15)
    assert sp3.normal[2] > 0.99


def test_steps_four_feet_across_a_rise_make_a_sphere():
    T = Terrain.steps()
    feet = _on(T, (0.1, 0.0))  # the left front foot on the first tread (0.03 m), the others below
    four = feet[SUBSETS[4]]
    assert sorted(np.round(four[:, 2], 3).tolist()) == [0.0, 0.0, 0.0, 0.03]
    sp = stance_primitive(four)
    assert sp.kind == "sphere" and sp.task_kind == "sphere"
    np.testing.assert_allclose(np.linalg.norm(four - sp.center, axis=1), sp.radius, rtol=1e-12)
    # five and six feet across the rise: the least-squares sphere
    for k in (5, 6):
        spk = stance_primitive(feet[SUBSETS[k]])
        assert spk.kind == "sphere" and spk.task_kind == "sphere_fit" and spk.radius <= 5.0
    # the symmetric stand with every foot on a tread edge pattern that is planar: the plane again
    sp_planar = stance_primitive(_on(T, (0.3, 0.0))[SUBSETS[4]])
    assert sp_planar.kind == "plane" and sp_planar.task_kind == "plane_fit"


def test_bad_feet():
    with pytest.raises(cg.InvalidInputError, match="at least 3"):
        stance_primitive(FEET_B[:2])
    with pytest.raises(cg.InvalidInputError):
        stance_primitive(FEET_B[:, :2])
    with pytest.raises(cg.NonFiniteError):
        stance_primitive(np.where(np.eye(6, 3) > 0, np.nan, FEET_B))
    line = np.outer(np.linspace(0, 1, 4), [1.0, 0.5, 0.0])
    with pytest.raises(cg.DegeneratePrimitiveError, match="collinear"):
        stance_primitive(line)
    with pytest.raises(cg.DegeneratePrimitiveError, match="collinear"):
        stance_primitive(line[:3])
    with pytest.raises(cg.InvalidInputError):
        stance_primitive(FEET_B, kind="ellipse")


# ---------------------------------------------------------------------- the task of the stance feet
def test_stance_order_and_kinds():
    assert stance_order(("rm", "lf", "lr")) == ("lf", "lr", "rm")
    assert stance_order(("rf", "lm", "rr")) == ("lm", "rr", "rf")
    assert stance_order(np.array([True, False, True, False, True, False])) == ("lf", "lr", "rm")  # LEGS order mask
    assert stance_order([0, 5, 0]) == ("lf", "rr")
    assert set(stance_order(LEGS)) == set(LEGS)
    with pytest.raises(cg.InvalidInputError):
        stance_order("lf")
    with pytest.raises(cg.InvalidInputError):
        stance_order(("lf", "xx"))
    t3 = stance_task(HEX, ("rm", "lf", "lr"), codegen=False)
    assert t3.kind == "plane" and t3.end_frames == ("lf_foot", "lr_foot", "rm_foot")
    assert stance_task(HEX, ("lf", "lm", "lr", "rr"), codegen=False).kind == "sphere"
    assert stance_task(HEX, LEGS, codegen=False).kind == "sphere_fit"
    assert stance_task(HEX, LEGS, "plane", codegen=False).kind == "plane_fit"
    assert stance_task(HEX, ("lf", "lr", "rm"), "circle", codegen=False).kind == "circle"
    with pytest.raises(cg.InvalidInputError, match="at least 4"):
        stance_task(HEX, ("lf", "lr", "rm"), "sphere")
    with pytest.raises(cg.InvalidInputError, match="exactly 3"):
        stance_task(HEX, LEGS, "circle")
    with pytest.raises(cg.InvalidInputError, match="no end frame"):
        stance_task(cg.systems.load("three_franka"), ("lf", "lr", "rm"))


def test_stance_task_is_cached_and_thread_safe():
    out: list = []

    def get():
        out.append(stance_task("hexapod", ("lr", "lf", "rm"), codegen=False))

    threads = [threading.Thread(target=get) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(out) == 8 and all(t is out[0] for t in out)
    assert stance_task(HEX, ["lf", "lr", "rm"], codegen=False) is out[0]


@pytest.mark.parametrize(
    "legs,kind",
    [
        (("lf", "lr", "rm"), None),
        (("lf", "lm", "lr", "rr"), None),
        (("lf", "lm", "lr", "rr", "rm"), None),
        (LEGS, None),
        (LEGS, "plane"),
    ],
)
def test_stance_task_similarity_is_that_of_the_stance_primitive(legs, kind):
    task = stance_task(HEX, legs, kind, codegen=False)
    rng = np.random.default_rng(len(legs))
    q = HEX.q0 + rng.normal(scale=0.12, size=HEX.nq)  # feet off the common plane
    st = task.evaluate(q)
    sp = stance_primitive(st.points, kind=None if kind is None else kind)
    assert sp.task_kind == task.kind
    V = Similarity(similarity_from_unit(sp.X, chart_axis=task.chart_axis))
    np.testing.assert_allclose(V.coeffs, st.coeffs, atol=1e-12)
    assert st.jacobian.shape == (7, 18) and np.all(np.isfinite(st.jacobian))


def test_flat_stand_pose_tasks():
    # at the stand pose every foot is on z = −0.0993 m: the tripod plane has its normal up (chart angle 0),
    # the sphere of four or six feet is singular and raises
    t3 = stance_task(HEX, ("lf", "lr", "rm"), codegen=False)
    assert t3.chart_angle(HEX.q0) == pytest.approx(0.0, abs=1e-7)
    np.testing.assert_allclose(t3.similarity(HEX.q0).translation, [0.0, 0.0, -0.0993], atol=1e-4)
    for legs in (("lf", "lm", "lr", "rr"), LEGS):
        with pytest.raises(cg.DegeneratePrimitiveError):
            stance_task(HEX, legs, codegen=False).evaluate(HEX.q0)
    assert stance_task(HEX, LEGS, "plane", codegen=False).well_definedness(HEX.q0) > 0.9


def test_random_terrain_statistics_quoted_in_the_module_docstring():
    for k, frac, med_r, med_w in ((4, 0.70, 1.06, 0.016), (5, 0.80, 1.28, 0.033), (6, 0.85, 1.41, 0.040)):
        sps = [stance_primitive(_on(Terrain.random(seed=s), (0.1, -0.05))[SUBSETS[k]]) for s in range(40)]
        radii = [sp.radius for sp in sps if sp.kind == "sphere"]
        assert len(radii) / 40 == pytest.approx(frac)
        assert np.median(radii) == pytest.approx(med_r, abs=0.005) and max(radii) <= 5.0
        assert np.median([sp.sphere_well_definedness for sp in sps]) == pytest.approx(med_w, abs=0.0005)
