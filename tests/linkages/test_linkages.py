"""Planar linkages (seed 004): motors, residuals, Newton tracking, branches, toggles, closed forms."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from coop_ga.errors import CoopGAError
from coop_ga.linkages import (
    Link,
    Linkage,
    LinkageError,
    Revolute,
    crank_limits,
    four_bar,
    freudenstein_output,
    grashof,
    slider_crank,
    ten_bar,
    watt_six_bar,
)
from coop_ga.linkages.library import TEN, WATT, _ten_points
from coop_ga.linkages.planar import apply_point, compose, motor, motor_exp, up

CYCLE = np.linspace(0.0, 2 * np.pi, 241)
RNG = np.random.default_rng(0)


def _se2(theta: float, t) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, t[0]], [s, c, t[1]], [0, 0, 1]])


def test_planar_exp_is_the_se2_matrix_exponential() -> None:
    for _ in range(50):
        w, v1, v2 = RNG.normal(size=3) * [2.0, 1.0, 1.0]
        E = scipy.linalg.expm(np.array([[0, -w, v1], [w, 0, v2], [0, 0, 0]]))
        p = RNG.normal(size=2)
        assert np.allclose(apply_point(motor_exp([w, v1, v2]), p), E[:2, :2] @ p + E[:2, 2], atol=1e-12)
    # ω = 0 exactly (the Taylor branch): a translation
    assert np.allclose(apply_point(motor_exp([0.0, 0.3, -0.2]), (1.0, 1.0)), (1.3, 0.8), atol=1e-15)


def test_planar_motor_composition_matches_matrices() -> None:
    for _ in range(20):
        a, b = RNG.normal(size=3), RNG.normal(size=3)
        Ma, Mb = motor(a[0], a[1:]), motor(b[0], b[1:])
        p = RNG.normal(size=2)
        H = _se2(a[0], a[1:]) @ _se2(b[0], b[1:])
        assert np.allclose(apply_point(compose(Ma, Mb), p), H[:2, :2] @ p + H[:2, 2], atol=1e-12)


def test_seed_bar_constraint_is_a_coincidence() -> None:
    """Seed 004 §3.2 writes a bar as x_i ∧ x_j = 0; for null vectors that means x_i = x_j."""
    p, q = RNG.normal(size=2), RNG.normal(size=2)
    X, Y = up(p), up(q)
    wedge = np.abs((X ^ Y).to_dense()).max()
    assert wedge > 1e-3  # two distinct points: the wedge is not zero, whatever their distance
    assert np.abs((X ^ up(p)).to_dense()).max() < 1e-15  # only coincidence makes it zero
    # the bar of length L is the inner product x_i·x_j = −½ L²
    assert (X | Y)["1"] == pytest.approx(-0.5 * np.sum((p - q) ** 2), rel=1e-14)


def _theta4(motion) -> np.ndarray:
    B, D = motion.point("rocker.B"), motion.point("rocker.D")
    return np.arctan2(B[:, 1] - D[:, 1], B[:, 0] - D[:, 0])


def _branch_error(lengths, motion) -> np.ndarray:
    F = freudenstein_output(*lengths, motion.crank_angles)
    return np.abs(np.angle(np.exp(1j * (F - _theta4(motion)[:, None]))))


@pytest.mark.parametrize("lengths", [(2.0, 0.5, 2.0, 1.5), (1.0, 0.45, 0.6, 0.9), (1.0, 0.4, 1.2, 0.7)])
def test_four_bar_matches_freudenstein_on_both_branches(lengths) -> None:
    cols = []
    for branch in (1, -1):
        fb = four_bar(*lengths, branch=branch)
        assert fb.kind == "crank-rocker"
        xy = fb.simulate(CYCLE)
        assert xy.shape == (CYCLE.size, 4, 2)
        motion = fb.solve(CYCLE)
        err = _branch_error(lengths, motion)
        col = int(np.argmin(err[0]))
        assert err[:, col].max() < 1e-9  # the same Freudenstein root along the whole cycle
        cols.append(col)
        assert motion.residual.max() < 1e-10
        # link lengths are a property of the rigid links: preserved to round-off
        O, A, B, D = (xy[:, k] for k in range(4))
        for (P, Q), L in zip(
            [(O, A), (A, B), (B, D), (O, D)], [lengths[1], lengths[2], lengths[3], lengths[0]], strict=True
        ):
            assert np.abs(np.linalg.norm(P - Q, axis=1) - L).max() < 1e-12
    assert cols[0] != cols[1]  # the two branches are the two roots


def test_grashof_classes() -> None:
    assert grashof(2.0, 0.5, 2.0, 1.5) == "crank-rocker"
    assert grashof(0.5, 2.0, 2.0, 1.5) == "double-crank"
    assert grashof(2.0, 1.5, 0.5, 2.0) == "double-rocker"
    assert grashof(2.0, 1.5, 2.0, 0.5) == "rocker-crank"
    assert grashof(1.0, 0.5, 1.0, 0.5) == "change-point"
    assert grashof(1.0, 0.8, 0.5, 0.45) == "triple-rocker"
    with pytest.raises(CoopGAError, match=r"crank \[m\] must be > 0"):
        grashof(1.0, -0.5, 1.0, 1.0)


def test_coarse_steps_jump_branches_and_tracking_prevents_it() -> None:
    """Coarse crank steps with plain Newton (seed 004 §3.4) land on the other assembly branch
    (pylinkage's bug); the predictor + det-sign / jump checks keep the branch."""
    lengths = (1.0, 0.49, 1.0, 0.5)
    fb = four_bar(*lengths)
    coarse = np.linspace(0.0, 2 * np.pi, 7)
    naive = fb.solve(coarse, guard=False)
    err = _branch_error(lengths, naive)
    col = int(np.argmin(err[0]))
    assert err[:, col].max() > 0.5  # at least one step sits on the other root (jumped)
    assert (err.argmin(1) != col).sum() >= 1
    guarded = fb.solve(coarse)
    err = _branch_error(lengths, guarded)
    assert err[:, col].max() < 1e-9
    assert guarded.substeps.sum() > coarse.size  # it refined the coarse steps
    assert np.all(guarded.det_sign == guarded.det_sign[0])


def test_toggle_of_a_non_grashof_four_bar_is_found_and_reported() -> None:
    lengths = (1.0, 0.8, 0.5, 0.45)
    (limit,) = crank_limits(*lengths)
    fb = four_bar(*lengths)
    motion = fb.solve(np.linspace(0.0, np.pi / 2, 46))
    assert not motion.complete
    assert motion.stop_angle is not None and abs(motion.stop_angle - limit) < 1e-6
    assert motion.stop_sigma_min is not None and motion.stop_sigma_min < 1e-3
    assert "toggle" in motion.message and "62.55" in motion.message
    assert motion.residual.max() < 1e-10
    with pytest.raises(LinkageError, match="cannot pass"):
        fb.simulate(np.linspace(0.0, np.pi / 2, 46))


def test_change_point_four_bar_stops_at_the_collinear_configuration() -> None:
    fb = four_bar(1.0, 0.5, 1.0, 0.5)
    assert fb.kind == "change-point"
    motion = fb.solve(np.linspace(0.3, 2 * np.pi, 61))
    assert not motion.complete and abs(motion.stop_angle - np.pi) < 1e-6
    assert motion.stop_sigma_min < 1e-6


def test_coupler_curve_matches_an_independent_fsolve() -> None:
    lengths = (2.0, 0.5, 2.0, 1.5)
    fb = four_bar(*lengths)
    motion = fb.solve(CYCLE)
    P = motion.point("coupler.P")
    a, b, c, d = lengths[1], lengths[2], lengths[3], lengths[0]
    u, v = fb.coupler_point
    B = fb.closed_form(0.0)[2]
    for k, phi in enumerate(CYCLE):
        A = a * np.array([np.cos(phi), np.sin(phi)])
        B = scipy.optimize.fsolve(
            lambda x: [np.sum((x - A) ** 2) - b * b, np.sum((x - np.array([d, 0.0])) ** 2) - c * c], B, xtol=1e-12
        )
        e = (B - A) / b
        Pk = A + u * e + v * np.array([-e[1], e[0]])
        assert np.abs(Pk - P[k]).max() < 1e-9


def test_crank_tip_speed_is_omega_r() -> None:
    fb = four_bar(2.0, 0.5, 2.0, 1.5)
    omega, h = 3.0, 1e-4
    t = np.linspace(0.0, 2.0, 41)
    for tk in t:
        xy = fb.simulate(omega * np.array([tk - h, tk + h]))
        v = (xy[1, 1] - xy[0, 1]) / (2 * h)
        assert np.linalg.norm(v) == pytest.approx(omega * 0.5, rel=1e-7)


def test_seed_slider_traces_the_vertical_segment_from_3_to_5() -> None:
    lk = slider_crank()
    assert lk.grubler_dof == 1
    motion = lk.track(CYCLE)
    assert motion.complete and motion.residual.max() < 1e-10
    S = motion.point("slider.S")
    assert np.abs(S[:, 0]).max() < 1e-12
    assert np.abs(S[:, 1] - (np.sin(CYCLE) + np.sqrt(16 - np.cos(CYCLE) ** 2))).max() < 1e-10
    assert S[:, 1].min() == pytest.approx(3.0, abs=1e-9) and S[:, 1].max() == pytest.approx(5.0, abs=1e-6)
    # the block does not rotate (prismatic joint)
    L, R = motion.point("slider.S_left"), motion.point("slider.S_right")
    assert np.abs(L[:, 1] - R[:, 1]).max() < 1e-10


@pytest.mark.parametrize("build", [watt_six_bar, ten_bar])
def test_multi_loop_linkages_follow_the_closed_form_dyads(build) -> None:
    lk = build()
    assert lk.grubler_dof == 1
    n_links, n_joints = len(lk.links), len(lk.joints) + 1
    assert (n_links, n_joints) == ((6, 7) if build is watt_six_bar else (10, 13))
    motion = lk.track(CYCLE)
    assert motion.complete and motion.residual.max() < 1e-10
    ref = [_ten_points(p) for p in CYCLE]
    for name, key in [("output.E", "E"), ("rocker.C", "C")] + (
        [("link_FG.G", "G"), ("link_HK.K", "K")] if build is ten_bar else []
    ):
        assert np.abs(motion.point(name) - np.array([r[key] for r in ref])).max() < 1e-9
    # every link keeps its shape
    for ln, link in lk.links.items():
        names = list(link.points)
        for i in range(len(names)):
            for j in range(i + 1, len(names)):
                d0 = np.linalg.norm(np.subtract(link.points[names[i]], link.points[names[j]]))
                d = np.linalg.norm(motion.point(f"{ln}.{names[i]}") - motion.point(f"{ln}.{names[j]}"), axis=1)
                assert np.abs(d - d0).max() < 1e-12


def test_design_margins_of_the_dyads() -> None:
    """The 6- and 10-bar dyads close with ≥ 0.2 m to spare over the whole cycle (no toggle)."""
    P = [_ten_points(p) for p in CYCLE]
    for X, O, l1, l2 in [
        ("C", "O6", WATT["coupler2"], WATT["output"]),
        ("F", "O8", TEN["FG"], TEN["GO8"]),
        ("H", "O10", TEN["HK"], TEN["KO10"]),
    ]:
        r = np.array([np.linalg.norm(p[X] - p[O]) for p in P])
        assert min((l1 + l2 - r).min(), (r - abs(l1 - l2)).min()) > 0.2


def test_jacobian_matches_finite_differences() -> None:
    lk = ten_bar()
    m = lk.track(np.linspace(0, 1.0, 5)).motors[-1]
    F, J = lk.residual(m, 1.0)
    retract = lk._functions()[1]
    h = 1e-6
    Jfd = np.zeros_like(J)
    for k in range(J.shape[1]):
        e = np.zeros(J.shape[1])
        e[k] = h
        Fp = lk.residual(np.asarray(retract(m, e)).ravel(), 1.0)[0]
        Fm = lk.residual(np.asarray(retract(m, -e)).ravel(), 1.0)[0]
        Jfd[:, k] = (Fp - Fm) / (2 * h)
    assert np.abs(J - Jfd).max() < 1e-8
    assert np.abs(F).max() < 1e-10


def test_redundant_linkage_by_gauss_newton() -> None:
    fb = four_bar(2.0, 0.5, 2.0, 1.5)
    links = list(fb.links.values())
    # a second, consistent bearing at D: over-constrained (8 residuals, 6 unknowns)
    joints = list(fb.joints) + [Revolute(("rocker", "D"), ("ground", "D"))]
    with pytest.raises(LinkageError, match="Grübler"):
        Linkage(links, joints)
    lk = Linkage(links, joints, allow_redundant=True)
    motion = lk.track(CYCLE, fb.assembled(0.0))
    assert motion.complete and motion.residual.max() < 1e-10
    assert np.abs(motion.point("rocker.B") - fb.solve(CYCLE).point("rocker.B")).max() < 1e-9


def test_bad_input_is_refused_clearly() -> None:
    with pytest.raises(CoopGAError, match=r"crank \[m\] must be > 0"):
        four_bar(2.0, 0.0, 2.0, 1.5)
    with pytest.raises(CoopGAError, match="branch"):
        four_bar(2.0, 0.5, 2.0, 1.5, branch=0)
    with pytest.raises(CoopGAError, match="cannot be assembled"):
        four_bar(10.0, 0.5, 1.0, 1.0)
    with pytest.raises(CoopGAError, match="unknown point"):
        Linkage(
            [Link("ground", {"O": (0, 0)}), Link("crank", {"O": (0, 0), "A": (1, 0)})],
            [Revolute(("crank", "Z"), ("ground", "O"))],
        )
    with pytest.raises(CoopGAError, match=r"crank_angles .* NaN or inf"):
        four_bar(2.0, 0.5, 2.0, 1.5).solve([0.0, np.nan])
    angles = np.linspace(0, 1, 5)
    before = angles.copy()
    four_bar(2.0, 0.5, 2.0, 1.5).simulate(angles)
    assert np.array_equal(angles, before)
