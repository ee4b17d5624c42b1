"""Fuzz properties of coop_ga.linkages (4-bars, the generic tracker, closed forms, planar motors).

For arbitrary inputs — finite, extreme, NaN/inf, wrongly typed or shaped — every public function (a) never
returns NaN or inf, (b) raises only :class:`coop_ga.CoopGAError` subclasses and (c) never modifies its inputs
(:func:`tests.fuzz.contract.check`); tracked motions keep every link rigid.  ``--hypothesis-profile=long``
runs 10 000 examples per property (CI: 60, fixed seeds).
"""

from __future__ import annotations

from functools import cache

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from coop_ga.linkages import (
    FourBar,
    Link,
    Linkage,
    Prismatic,
    Revolute,
    crank_limits,
    dyad,
    four_bar,
    freudenstein_output,
    grashof,
    slider_crank,
    ten_bar,
    watt_six_bar,
)
from coop_ga.linkages.planar import apply_point, compose, motor, motor_exp, motor_pose, rotation_about, up
from tests.fuzz.contract import bad, check, reals, vec

lengths = st.one_of(st.floats(0.05, 5.0), reals)
branches = st.one_of(st.sampled_from([1, -1]), st.integers(-2, 2), bad, st.booleans(), st.just(1.0))
angles = st.one_of(
    st.lists(st.floats(-7.0, 7.0), min_size=1, max_size=4),
    st.lists(st.floats(-1e7, 1e7), min_size=1, max_size=3),
    vec(2),
    bad,
)


@cache
def _four_bar() -> FourBar:
    return four_bar(2.0, 0.5, 2.0, 1.5)


@given(g=lengths, a=lengths, b=lengths, c=lengths, branch=branches, cp=vec(2))
def test_four_bar_construction_and_closed_forms(g, a, b, c, branch, cp):
    fb = check(FourBar, g, a, b, c, branch, cp)
    check(grashof, g, a, b, c)
    check(crank_limits, g, a, b, c)
    out = check(freudenstein_output, g, a, b, c, [0.0, 1.0])
    if out is not None:
        assert out.shape == (2, 2)
    if fb is not None:
        phi = fb._reference_angle()
        P = check(fb.closed_form, phi)
        assert np.allclose(np.linalg.norm(P[1] - P[0]), fb.lengths["crank"], rtol=1e-9)


@given(crank_angles=angles, max_step=st.one_of(st.floats(0.01, 0.2), reals), max_substeps=st.one_of(
    st.integers(1, 500), bad))  # fmt: skip
def test_tracking_is_bounded_and_rigid(crank_angles, max_step, max_substeps):
    fb = _four_bar()
    m = check(fb.solve, crank_angles, max_step=max_step, max_substeps=max_substeps)
    if m is not None and len(m.crank_angles):
        A, B = m.point("coupler.A"), m.point("coupler.B")
        assert np.allclose(np.linalg.norm(A - B, axis=1), fb.lengths["coupler"], atol=1e-9)
        assert m.substeps[1:].sum() <= (max_substeps if isinstance(max_substeps, int) else 10**9)


@given(motors=st.one_of(vec(8), vec(3), st.lists(st.floats(-2, 2), min_size=8, max_size=8)), phi=reals)
def test_newton_residual_positions(motors, phi):
    fb = _four_bar()
    check(fb.residual, motors, phi)
    check(fb.positions, motors, phi)
    check(fb.newton, motors, phi, max_iter=5)
    check(fb.track, [0.0, 0.05], motors, max_substeps=20)


@given(p=vec(2), q=vec(2), r_p=reals, r_q=reals, branch=branches)
def test_dyad(p, q, r_p, r_q, branch):
    x = check(dyad, p, q, r_p, r_q, branch)
    if x is not None:
        P, R = np.asarray(p, float), float(r_p)
        assert abs(np.linalg.norm(x - P) - R) <= 1e-8 * max(1.0, R, float(np.abs(P).max()))


@given(points=st.dictionaries(st.one_of(st.text(min_size=1, max_size=2), st.integers(), st.none()), vec(2), max_size=3),
       name=st.one_of(st.text(max_size=3), bad), ref=st.one_of(st.tuples(st.text(max_size=2), st.text(max_size=2)),
                                                               bad))  # fmt: skip
def test_links_and_joints(points, name, ref):
    link = check(Link, name, points)
    check(Revolute, ref, ("crank", "A"))
    check(Prismatic, ref, ("ground", "G1", "G2"))
    if link is not None:
        check(Linkage, [link, Link("crank", {"O": (0, 0), "A": (1, 0)})], [], ground=link.name)


@given(crank=reals, rod=reals, phi0=reals)
def test_library_linkages(crank, rod, phi0):
    check(slider_crank, crank, rod)
    check(watt_six_bar, phi0)
    check(ten_bar, phi0)


@given(m=st.one_of(vec(4), vec(3)), p=vec(2), xi=vec(3), angle=reals, t=vec(2))
def test_planar_motors(m, p, xi, angle, t):
    check(up, p)
    check(motor_exp, xi)
    check(motor, angle, t)
    check(rotation_about, t, angle)
    check(compose, m, m)
    check(apply_point, m, p)
    pose = check(motor_pose, m)
    if pose is not None:
        assert -np.pi <= pose[0] <= np.pi
