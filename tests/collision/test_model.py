"""CollisionModel on three_franka: pair selection, distances against independent geometry, Jacobians
against central finite differences and CasADi AD of the same code, batch evaluation, speed."""

from __future__ import annotations

import time

import numpy as np
import pytest

import coop_ga
from coop_ga.collision import CollisionModel, Plane, Sphere
from coop_ga.errors import CoopGAError


@pytest.fixture(scope="module")
def franka():
    return coop_ga.systems.load("three_franka")


@pytest.fixture(scope="module")
def cm(franka):
    return CollisionModel(franka, [Sphere([0.0, 0.1, 0.55], 0.12), Plane([0, 0, 1], -0.02)])


def _seg_dist(p0, p1, q0, q1, n=2001):
    """Brute-force segment–segment distance: dense grid on one, exact projection on the other."""
    s = np.linspace(0, 1, n)[:, None]
    P = p0 + s * (p1 - p0)
    d = q1 - q0
    t = np.clip((P - q0) @ d / (d @ d), 0, 1) if d @ d > 0 else np.zeros(n)
    return float(np.linalg.norm(P - (q0 + t[:, None] * d), axis=1).min())


def test_q0_has_positive_self_clearance_with_adjacent_links_excluded(franka):
    for srdf in (True, False):
        m = CollisionModel(franka, srdf=srdf)
        d = m.distances(franka.q0)
        assert m.n == len(m.labels) == len(d) > 300
        assert set(m.kinds) == {"self"}
        assert d.min() > 0.0, m.closest(franka.q0)
    m = CollisionModel(franka, srdf=False)
    reasons = dict(m.excluded)
    assert reasons["arm0_panda_link3 – arm0_panda_link4"].startswith("adjacent")
    assert reasons["arm1_panda_link0 – arm1_panda_link1"].startswith("adjacent")
    assert reasons["arm0_panda_link7 – arm0_panda_hand"] == "same rigid body"
    assert "arm0_panda_link0 – arm1_panda_link1" in m.labels  # another arm's base is not adjacent
    assert "arm0_panda_link5 – arm0_panda_link7" in m.labels  # two joints apart: kept without the SRDF
    assert "arm0_panda_hand – arm1_panda_hand" in m.labels
    inter = dict(zip(m.labels, m.inter_branch))
    assert inter["arm0_panda_hand – arm1_panda_hand"] and inter["arm0_panda_link0 – arm1_panda_link1"]
    assert not inter["arm0_panda_link5 – arm0_panda_link7"] and not inter["arm0_panda_link0 – arm0_panda_link2"]
    assert m.inter_branch.sum() == 3 * 11 * 11 - 3  # every arm–arm pair but the three world-fixed bases
    assert reasons["arm0_panda_link0 – arm1_panda_link0"] == "same rigid body"
    # with the SRDF, the pairs it disables ("Never"/"Default") are dropped as well
    m2 = CollisionModel(franka)
    assert "arm0_panda_link5 – arm0_panda_link7" not in m2.labels
    assert dict(m2.excluded)["arm0_panda_link5 – arm0_panda_link7"].startswith("SRDF")
    assert m2.n < m.n


def test_labels_and_distances_against_independent_geometry(franka, cm):
    rng = np.random.default_rng(0)
    q = franka.random_q(rng, 0.5)
    d = cm.distances(q)
    A, B = cm.capsule_segments(q)
    nc = len(cm.capsules)
    assert cm.n_obstacle_rows == 2 * nc
    assert cm.labels[0] == f"{cm.capsules[0].link} – sphere 0"
    assert cm.labels[nc] == f"{cm.capsules[0].link} – plane 1"
    S, P = cm.obstacles
    for k in range(cm.n):
        i, j = cm.pairs[k]
        ci = cm.capsules[i]
        if cm.kinds[k] == "obstacle" and j == 0:
            s = np.linspace(0, 1, 2001)[:, None]
            ref = np.linalg.norm(A[i] + s * (B[i] - A[i]) - S.center, axis=1).min() - S.radius - ci.radius
        elif cm.kinds[k] == "obstacle":
            ref = min(A[i] @ P.normal, B[i] @ P.normal) - P.offset - ci.radius
        else:
            ref = _seg_dist(A[i], B[i], A[j], B[j]) - ci.radius - cm.capsules[j].radius
        assert d[k] == pytest.approx(ref, abs=2e-6), cm.labels[k]


def test_jacobian_against_central_differences_and_casadi(franka, cm):
    rng = np.random.default_rng(1)
    f = cm.casadi()
    fj = cm.casadi_jacobian()
    h = 1e-6
    for _ in range(3):
        q = franka.random_q(rng, 0.6)
        d, J = cm.distances_and_jacobian(q)
        assert J.shape == (cm.n, franka.nq)
        np.testing.assert_allclose(np.array(f(q), float).ravel(), d, atol=1e-12)
        dc, Jc = (np.array(v, float) for v in fj(q))
        np.testing.assert_allclose(dc.ravel(), d, atol=1e-12)
        np.testing.assert_allclose(Jc, J, atol=1e-10)
        Jn = np.zeros_like(J)
        for k in range(franka.nq):
            e = np.zeros(franka.nq)
            e[k] = h
            Jn[:, k] = (cm.distances(q + e) - cm.distances(q - e)) / (2 * h)
        np.testing.assert_allclose(J, Jn, atol=1e-7)
        # rows only depend on the joints that move the pair
        for k in range(cm.n):
            i, j = cm.pairs[k]
            chains = {cm.capsules[i].chain} | ({cm.capsules[j].chain} if cm.kinds[k] == "self" else set())
            cols = {c for ch in chains if ch >= 0 for c in franka.tree.joint_columns[ch]}
            assert np.all(J[k, [c for c in range(franka.nq) if c not in cols]] == 0.0)


def test_sphere_on_the_path_is_detected_and_margin_shifts(franka):
    tcp = franka.end_points(franka.q0)[0]
    m = CollisionModel(franka, [Sphere(tcp, 0.05)], self_collision=False)
    assert m.min_clearance(franka.q0) < -0.05  # the sphere centre is at arm0's tcp, inside the fingers
    label, dmin = m.closest(franka.q0)
    assert label.startswith("arm0_panda_") and dmin == m.min_clearance(franka.q0)
    m2 = CollisionModel(franka, [Sphere(tcp, 0.05)], self_collision=False, margin=0.03)
    np.testing.assert_allclose(m2.distances(franka.q0), m.distances(franka.q0) - 0.03, atol=1e-15)


def test_kinds_masks(franka, cm):
    q = franka.q0
    d = cm.distances(q)
    assert cm.min_clearance(q, "obstacle") == d[: cm.n_obstacle_rows].min()
    assert cm.min_clearance(q, "self") == d[cm.n_obstacle_rows :].min()
    assert cm.min_clearance(q, "inter_branch") == d[cm.inter_branch].min()
    assert cm.min_clearance(q) == d.min()
    with pytest.raises(CoopGAError):
        cm.mask("arm_arm")


def test_other_systems_have_positive_clearance_at_q0():
    """Every pair that is kept is free at q0 (by the overlap rule), and URDFs without <collision>
    (our iiwa14) fall back to their visual geometry."""
    for name in ("three_iiwa14", "hexapod"):
        s = coop_ga.systems.load(name)
        m = CollisionModel(s)
        assert len(m.capsules) > 15 and m.n > 100
        assert m.min_clearance(s.q0) > 0.0


def test_batch_over_q(franka, cm):
    rng = np.random.default_rng(2)
    Q = np.stack([franka.random_q(rng, 0.5) for _ in range(6)]).reshape(2, 3, franka.nq)
    D = cm.distances(Q)
    assert D.shape == (2, 3, cm.n)
    np.testing.assert_allclose(D[1, 2], cm.distances(Q[1, 2]), atol=0)
    np.testing.assert_allclose(cm.min_clearance(Q), D.min(axis=-1))


def test_bad_input_raises(franka):
    with pytest.raises(CoopGAError):
        CollisionModel(franka, margin=-0.1)
    with pytest.raises(CoopGAError):
        CollisionModel(franka, ["not an obstacle"])
    with pytest.raises(CoopGAError):
        CollisionModel(franka, capsules=("capsule",))
    m = CollisionModel(franka, self_collision=False)
    assert m.n == 0 and m.min_clearance(franka.q0) == float("inf")
    with pytest.raises(CoopGAError):
        m.distances(np.zeros(5))


def test_speed_three_franka(franka, cm):
    """µs per call on three_franka (21 DOF): measured, printed, and bounded generously (a loaded
    2-core machine); the report quotes the numbers from a quiet run."""
    q = franka.q0
    out = {}
    for name, fn in (("distances", cm.distances), ("distances_and_jacobian", cm.distances_and_jacobian)):
        fn(q)
        reps = 50
        t0 = time.perf_counter()
        for _ in range(reps):
            fn(q)
        out[name] = 1e6 * (time.perf_counter() - t0) / reps
    print(f"\nthree_franka, {cm.n} distances: {out}")
    assert out["distances"] < 20_000 and out["distances_and_jacobian"] < 40_000


# ----------------------------------------------------------------------------- trajectories (broad phase)
def _trajectory(franka: object, K: int = 12, scale: float = 0.25) -> np.ndarray:
    q0 = np.asarray(franka.q0, float)  # type: ignore[attr-defined]
    return q0 + scale * np.random.default_rng(7).standard_normal((K, q0.size))


def test_trajectory_ends_equal_pinocchio_placements(franka, cm):
    Q = _trajectory(franka)
    A, B = cm.trajectory_ends(Q)
    assert A.shape == B.shape == (len(Q), len(cm.capsules), 3)
    for k in (0, 5, 11):
        A0, B0 = cm.capsule_segments(Q[k])
        np.testing.assert_allclose(A[k], A0, atol=1e-12)
        np.testing.assert_allclose(B[k], B0, atol=1e-12)


def test_close_pairs_are_every_pair_below_the_cutoff_exactly(franka, cm):
    """The broad phase drops no pair: close_pairs returns exactly the (configuration, row) pairs of the full
    evaluation below the cutoff, with the same distances; the bounding-sphere bounds never exceed a distance."""
    Q = _trajectory(franka)
    D = np.array([cm.distances(q) for q in Q])
    A, B = cm.trajectory_ends(Q)
    assert np.all(cm.lower_bounds(A, B) <= D + 1e-12)
    for cutoff in (0.0, 0.05, 0.2):
        kk, rows, d = cm.close_pairs(Q, cutoff)
        expect = np.argwhere(D < cutoff)
        assert len(expect) > 0 or cutoff == 0.0
        assert sorted(zip(kk.tolist(), rows.tolist())) == sorted(map(tuple, expect.tolist()))
        np.testing.assert_allclose(d, D[kk, rows], atol=1e-12)


def test_close_pairs_jacobian_rows_match_the_full_jacobian_and_differences(franka, cm):
    Q = _trajectory(franka, K=4)
    kk, rows, d, J = cm.close_pairs_and_jacobian(Q, 0.1)
    assert len(kk) > 20
    h = 1e-6
    for i in range(0, len(kk), max(1, len(kk) // 15)):
        k, r = int(kk[i]), int(rows[i])
        np.testing.assert_allclose(J[i], cm.distances_and_jacobian(Q[k])[1][r], atol=1e-12)
        dq = np.zeros(cm.nq)
        for j in np.flatnonzero(np.abs(J[i]) > 1e-3)[:3]:
            dq[:] = 0.0
            dq[j] = h
            fd = (cm.distances(Q[k] + dq)[r] - cm.distances(Q[k] - dq)[r]) / (2 * h)
            assert fd == pytest.approx(J[i, j], abs=1e-6)
    d2, J2 = cm.rows_and_jacobian(Q[kk[0]], rows[kk == kk[0]])
    np.testing.assert_allclose(d2, d[kk == kk[0]], atol=1e-12)
    np.testing.assert_allclose(J2, J[kk == kk[0]], atol=1e-12)


def test_close_pairs_reuse_the_last_pair_list_exactly(franka, cm):
    """The model keeps its last broad phase: the same trajectory with a smaller cutoff is served from it, and gives
    what a fresh evaluation gives; a changed trajectory (even changed in place) is recomputed."""
    Q = _trajectory(franka)
    D = np.array([cm.distances(q) for q in Q])
    cm.close_pairs(Q, 0.2)
    for cutoff in (0.2, 0.05, 0.0):
        kk, rows, d = cm.close_pairs(Q, cutoff)
        assert sorted(zip(kk.tolist(), rows.tolist())) == sorted(map(tuple, np.argwhere(D < cutoff).tolist()))
        np.testing.assert_allclose(d, D[kk, rows], atol=1e-12)
    kj, rj, _, J = cm.close_pairs_and_jacobian(Q, 0.05)  # served from the list of cutoff 0.2
    np.testing.assert_array_equal(kj, cm.close_pairs(Q.copy(), 0.05)[0])
    np.testing.assert_allclose(J[0], cm.distances_and_jacobian(Q[kj[0]])[1][rj[0]], atol=1e-12)
    Q[3] += 0.3  # in place: the stored copy no longer matches
    D3 = cm.distances(Q[3])
    kk, rows, d = cm.close_pairs(Q, 0.05)
    np.testing.assert_allclose(d[kk == 3], D3[rows[kk == 3]], atol=1e-12)
    assert sorted(rows[kk == 3].tolist()) == np.flatnonzero(D3 < 0.05).tolist()


def test_close_pairs_are_recomputed_when_the_obstacles_move(franka):
    """A receding horizon moves the obstacles by assigning a new tuple (or changes the margin): the kept pair list is
    not reused then."""
    Q = _trajectory(franka)
    cm_a = CollisionModel(franka, obstacles=[Sphere([0.3, 0.0, 0.5], 0.05)], self_collision=False)
    near = cm_a.close_pairs(Q, 0.3)
    assert len(near[0]) > 0
    cm_a.obstacles = (Sphere([0.0, 0.0, 3.0], 0.05),)
    assert len(cm_a.close_pairs(Q, 0.3)[0]) == 0
    cm_a.obstacles = (Sphere([0.3, 0.0, 0.5], 0.05),)
    np.testing.assert_array_equal(cm_a.close_pairs(Q, 0.3)[2], near[2])
    cm_a.margin = 0.01
    fresh = CollisionModel(franka, obstacles=[Sphere([0.3, 0.0, 0.5], 0.05)], self_collision=False, margin=0.01)
    np.testing.assert_array_equal(cm_a.close_pairs(Q, 0.3)[2], fresh.close_pairs(Q, 0.3)[2])
    assert not np.array_equal(fresh.close_pairs(Q, 0.3)[2], near[2])
