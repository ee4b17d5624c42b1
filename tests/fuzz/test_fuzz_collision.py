"""Fuzz properties of coop_ga.collision (distances, obstacles, capsules, the collision model, potential fields).

For arbitrary inputs — finite, extreme (1e±300, subnormal), NaN/inf, wrongly typed or shaped — every public
function (a) never returns NaN or inf, (b) raises only :class:`coop_ga.CoopGAError` subclasses and (c) never
modifies its inputs (:func:`tests.fuzz.contract.check`); where it returns, the value is checked against the
Euclidean formula.  ``--hypothesis-profile=long`` runs 10 000 examples per property (CI: 60, fixed seeds).
"""

from __future__ import annotations

from functools import cache

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st

from coop_ga import collision as C
from coop_ga.collision import potential as pot
from coop_ga.systems import cartesian_points
from tests.fuzz.contract import bad, check, moderate, reals, vec, vec3

SPHERE = C.Sphere([0.2, -0.1, 0.5], 0.1)
PLANE = C.Plane([0.0, 0.3, 1.0], 0.05)
obstacles = st.one_of(st.sampled_from([SPHERE, PLANE]), bad, st.just({"center": [0, 0, 0], "radius": 1.0}))
radii = st.one_of(st.floats(0.0, 1.0), reals, st.lists(st.floats(0.0, 1.0), min_size=1, max_size=3))


@cache
def _model() -> C.CollisionModel:
    caps = [C.Capsule(f"tip{i}", [0.0, 0.0, 0.0], [0.0, 0.0, 0.1], 0.05, chain=i) for i in range(3)]
    return C.CollisionModel(cartesian_points(3), [SPHERE, PLANE], capsules=caps)


def _numeric3(x) -> np.ndarray | None:
    """x as a finite (3,) float array if it is one (to compare with the closed form), else None."""
    if isinstance(x, (list, tuple, np.ndarray)) and len(x) == 3:
        try:
            a = np.asarray(x)
        except (TypeError, ValueError):
            return None
        if a.shape == (3,) and a.dtype.kind in "fi" and np.all(np.isfinite(a)):
            return a.astype(float)
    return None


@given(x=vec3(), ob=obstacles)
def test_point_measures(x, ob):
    check(C.conformal_point, x)
    d_s = check(C.point_sphere_distance, x, ob)
    check(C.point_sphere_product, x, ob)
    d_p = check(C.point_plane_distance, x, ob)
    a = _numeric3(x)
    if a is not None and np.max(np.abs(a)) < 1e6:
        if d_s is not None:
            assert abs(float(d_s) - (np.linalg.norm(a - SPHERE.center) - SPHERE.radius)) <= 1e-9 * (1 + np.abs(a).max())
        if d_p is not None:
            assert abs(float(d_p) - (PLANE.normal @ a - PLANE.offset)) <= 1e-9 * (1 + np.abs(a).max())


@given(a=vec3(), b=vec3(), c=vec3(), r=radii, r2=radii)
def test_segments_and_capsules(a, b, c, r, r2):
    check(C.segment_point_parameter, a, b, c)
    check(C.capsule_sphere_distance, a, b, r, SPHERE)
    check(C.capsule_plane_distance, a, b, r, PLANE)
    st_ = check(C.segment_segment_closest, a, b, c, [0.0, 0.0, 1.0])
    out = check(C.capsule_capsule_distance, a, b, r, c, [0.0, 0.0, 1.0], r2)
    if st_ is not None:
        s, t = (np.asarray(v, float) for v in st_)
        assert np.all((0.0 <= s) & (s <= 1.0)) and np.all((0.0 <= t) & (t <= 1.0))
    if out is not None and np.ndim(out[0]) == 0:
        assert float(out[0]) >= -float(np.max(r)) - float(np.max(r2)) - 1e-9 * (1 + float(np.max(np.abs(a))))


@given(p_i=vec3(), p_j=vec3(), r2=reals)
def test_seed002_link_sphere_distance(p_i, p_j, r2):
    check(C.seed002_link_sphere_distance, p_i, p_j, r2, SPHERE)


@given(center=vec3(), radius=reals, normal=vec3(), offset=reals, name=st.one_of(st.text(max_size=3), bad))
def test_obstacles(center, radius, normal, offset, name):
    check(C.Sphere, center, radius)
    check(C.Plane, normal, offset)
    check(C.as_obstacle, {"center": center, "radius": radius}, name)
    check(C.as_obstacle, {"normal": normal, "offset": offset})
    check(C.as_obstacle, center)


@given(a=vec3(), b=vec3(), radius=reals, chain=st.one_of(st.integers(-3, 5), bad), pts=vec(3), tol=reals)
def test_capsules(a, b, radius, chain, pts, tol):
    cap = check(C.Capsule, "tip0", a, b, radius, chain)
    if cap is not None:
        check(cap.point_distance, pts)
        check(cap.contains, pts, tol)
    check(C.fit_capsule, [a, b] if not isinstance(a, str) else a)


@given(q=st.one_of(vec(9), vec(8), st.lists(st.lists(moderate, min_size=9, max_size=9), min_size=1, max_size=3)))
def test_collision_model_queries(q):
    cm = _model()
    d = check(cm.distances, q)
    check(cm.distances_and_jacobian, q)
    check(cm.min_clearance, q)
    check(cm.closest, q)
    check(cm.capsule_segments, q)
    if d is not None:
        assert d.shape[-1] == cm.n


@given(start=vec3(), goal=vec3(), step=st.one_of(st.floats(1e-3, 0.3), reals), margin=reals, rule=st.one_of(
    st.sampled_from(pot.CHARGE_RULES), bad))  # fmt: skip
# found by the long profile: the goal's pull |x − g|⁻³ of a goal 5.6e102 m away raised OverflowError
@example(start=np.zeros(3), goal=np.array([0.0, 0.0, 5.643803094122362e102]), step=0.25, margin=0.0, rule="seed")
def test_potential_path(start, goal, step, margin, rule):
    obs = [pot.obstacle([0.5, 0.0, 0.0], 0.1)]
    r = check(pot.potential_path, start, goal, obs, step=step, margin=margin, charge_rule=rule, max_iter=60)
    if r is not None:
        assert r.min_clearance >= 0.0  # never inside a safety sphere
        if r.reached and r.final_distance == 0.0:
            assert r.length >= float(np.linalg.norm(r.path[-1] - r.path[0])) - 1e-12


@given(x=st.one_of(vec3(), vec(3)), q=st.one_of(st.floats(0.01, 0.9), reals), D=reals, R=reals)
def test_coulomb_field_and_charges(x, q, D, R):
    C1 = [[1.0, 0.0, 0.0]]
    check(pot.coulomb_potential, x, C1, [q], [0.0, 0.0, 0.0])
    check(pot.coulomb_field, x, C1, [q], [0.0, 0.0, 0.0])
    check(pot.charges, [R], C1, x)
    check(pot.equilibrium_distance, q, D)
    check(pot.obstacle, x, R)
    check(pot.signed_squared_distance, x, pot.obstacle([0.5, 0.0, 0.0], 0.1))
