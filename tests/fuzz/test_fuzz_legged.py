"""Fuzz properties of coop_ga.legged (leg kinematics, body states, gaits, terrain, stance primitives, options).

For arbitrary inputs — finite, extreme, NaN/inf, wrongly typed or shaped — every public function (a) never
returns NaN or inf, (b) raises only :class:`coop_ga.CoopGAError` subclasses and (c) never modifies its inputs
(:func:`tests.fuzz.contract.check`); where it returns, the result is checked (FK of an IK solution reaches the
target, rotations stay orthonormal).  The walk, the posture step and the contact roll-out are too slow to
fuzz; ``benchmarks/bad_inputs.py`` covers their arguments.  ``--hypothesis-profile=long`` runs 10 000
examples per property (CI: 60, fixed seeds).
"""

from __future__ import annotations

import importlib
from functools import cache

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from coop_ga.legged import (
    BodyState,
    PostureOptions,
    RolloutOptions,
    Terrain,
    WalkOptions,
    hexapod_legs,
    phase_table,
    stance_primitive,
    static_stability_margin,
    swing_arc,
)
from coop_ga.legged.body import body_tangent, rotation_from_rpy, rpy_from_rotation, stance_indices
from coop_ga.legged.posture import command_from_body_twist, feet_field
from tests.fuzz.contract import bad, check, moderate, reals, vec, vec3

W = importlib.import_module("coop_ga.legged.walk")  # (coop_ga.legged.walk is also the function walk)
legs_arg = st.one_of(
    st.lists(st.sampled_from(["lf", "lm", "lr", "rf", "rm", "rr", "xx", 0, 5, 6, 1.5]), max_size=6), bad
)


@cache
def _legs():
    return hexapod_legs()


def q18():
    near = st.lists(st.floats(-2.0, 2.0), min_size=18, max_size=18).map(np.array)
    return st.one_of(vec(18), near, vec(17))


def feet():
    stand = _legs().fk(_legs().q_stand)
    offsets = st.lists(st.floats(-0.2, 0.2), min_size=18, max_size=18).map(lambda v: np.reshape(v, (6, 3)))
    return st.one_of(offsets.map(lambda d: stand + d), vec(18), st.lists(st.lists(moderate, min_size=3, max_size=3),
                                                                         min_size=6, max_size=6))  # fmt: skip


@given(q=q18(), tol=reals)
def test_forward_kinematics(q, tol):
    lm = _legs()
    p = check(lm.fk, q)
    J = check(lm.jacobians, q)
    check(lm.within_limits, q, tol)
    check(lm.branch_of, q)
    check(lm.per_leg, q)
    if p is not None and J is not None:
        assert p.shape[-2:] == (6, 3) and J.shape[-3:] == (6, 3, 3)


@given(target=feet(), branch=st.one_of(st.sampled_from(["knee_up", "knee_down"]), bad), check_limits=st.booleans())
def test_inverse_kinematics(target, branch, check_limits):
    lm = _legs()
    check(lm.workspace_margin, target)
    check(lm.ik_candidates, target)
    q = check(lm.ik, target, branch, check_limits)
    if q is not None:
        err = np.linalg.norm(lm.fk(q) - np.asarray(target, float), axis=-1)
        assert float(err.max()) < 1e-6
    r = check(lm.dls_ik, target, lm.q_stand, max_iter=20)
    if r is not None:
        assert r.error.shape == (6,)


@given(position=vec3(), rpy=vec3(), q=q18(), v=vec3(), omega=vec3(), dt=reals, pts=vec(3))
def test_body_states(position, rpy, q, v, omega, dt, pts):
    s = check(BodyState.from_rpy, position, rpy, q)
    R = check(rotation_from_rpy, rpy)
    if R is not None:
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-12)
        check(rpy_from_rotation, R)
    check(body_tangent, v, omega)
    if s is not None:
        s2 = check(s.moved, v, omega, dt)
        check(s.to_world, pts)
        check(s.to_body, pts)
        check(s.pose7)
        q25 = check(s.free_flyer_q)
        check(BodyState.from_free_flyer_q, q25)
        if s2 is not None:
            assert np.allclose(s2.rotation.T @ s2.rotation, np.eye(3), atol=1e-9)


@given(q=vec(25))
def test_body_state_from_free_flyer_q(q):
    s = check(BodyState.from_free_flyer_q, q)
    if s is not None:
        assert np.allclose(s.rotation.T @ s.rotation, np.eye(3), atol=1e-9)


@given(gait=st.one_of(st.sampled_from(["tripod", "ripple", "wave"]), bad), n=st.one_of(st.integers(3, 9), bad),
       duty=st.one_of(st.none(), st.floats(0.05, 0.95), reals), period=reals, t=st.one_of(reals, vec(3)),
       samples=st.one_of(st.integers(1, 5000), st.integers(10**8, 10**12), bad))  # fmt: skip
def test_gaits(gait, n, duty, period, t, samples):
    tab = check(phase_table, gait, n, duty, period=period)
    if tab is None:
        return
    ph = check(tab.phase, t)
    check(tab.stance, t)
    check(tab.min_stance, samples)
    if ph is not None:
        assert np.all((0.0 <= ph) & (ph < 1.0))
        sw = call_masked(tab.swing_progress, t)
        if sw is not None:  # NaN exactly where the leg is in stance (documented), in [0, 1) elsewhere
            assert np.array_equal(np.isnan(sw), tab.stance(t))
            assert np.all((sw[~np.isnan(sw)] >= 0.0) & (sw[~np.isnan(sw)] < 1.0))


def call_masked(f, *args):
    """swing_progress / stance_progress mark the other phase with NaN (documented): (b) and (c) only."""
    from tests.fuzz.test_fuzz_geometry import call

    return call(f, *args, _finite_out=False)


@given(p0=vec3(), p1=vec3(), lift=reals, s=st.one_of(st.floats(0.0, 1.0), reals, vec(3)))
def test_swing_arcs(p0, p1, lift, s):
    out = check(swing_arc, p0, p1, lift, s)
    if out is not None and np.ndim(s) == 0:
        p, _ = out
        lo = min(float(p0[2]), float(p1[2]))
        assert p[2] >= lo - 1e-9 * max(1.0, abs(lo))


@given(height=reals, angle=reals, direction=vec(2), step=reals, n=st.one_of(st.integers(-1, 20), st.just(10**12), bad),
       xy=st.one_of(vec(2), st.lists(st.lists(moderate, min_size=2, max_size=2), min_size=1, max_size=3)),
       tol=reals)  # fmt: skip
def test_terrain(height, angle, direction, step, n, xy, tol):
    for T in (check(Terrain.flat, height), check(Terrain.slope, angle, direction), check(Terrain.steps, step, 0.25,
                                                                                          0.1, n)):  # fmt: skip
        if T is None:
            continue
        check(T.height, xy)
        check(T.normal, xy)
        check(T.land, xy)
        check(T.max_height, [0.0, 0.0], xy, 16)
        pts = check(T.land, xy)
        if pts is not None:
            d = check(T.signed_distance, pts)
            if d is not None and d.size:
                assert np.allclose(d, 0.0, atol=1e-9 * max(1.0, float(np.abs(pts).max())))
            check(T.in_contact, pts, tol)


@given(points=st.one_of(vec(12), st.lists(st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3), min_size=2,
                                                 max_size=6), st.lists(vec3(), min_size=3, max_size=5)),
       w_min=reals, r_max=reals, kind=st.one_of(st.none(), st.sampled_from(["sphere", "plane", "circle"]), bad))  # fmt: skip
def test_stance_primitives(points, w_min, r_max, kind):
    sp = check(stance_primitive, points, w_min=w_min, r_max=r_max, kind=kind)
    if sp is not None:
        assert sp.kind in ("sphere", "plane", "circle") and 0.0 <= sp.well_definedness


@given(com=vec(2), support=st.one_of(st.lists(st.lists(moderate, min_size=2, max_size=2), max_size=6), vec(4)),
       stance=legs_arg, command=vec(7), pts=vec(3), v=vec3())  # fmt: skip
def test_support_and_posture_helpers(com, support, stance, command, pts, v):
    m = call_masked(static_stability_margin, com, support)
    if m is not None:  # −inf (documented) only without a stance foot
        assert np.isfinite(m) or (m == -np.inf and np.size(support) == 0)
    check(W.convex_hull, support)
    check(stance_indices, stance)
    check(feet_field, command, pts)
    check(command_from_body_twist, v, v)


@given(dt=reals, gain=reals, kind=st.one_of(st.none(), st.sampled_from(["plane", "sphere_fit", "cube"]), bad),
       duty=st.one_of(st.none(), reals), speed=st.one_of(st.none(), vec(3)), kp=reals, baum=vec(2))  # fmt: skip
def test_option_classes(dt, gain, kind, duty, speed, kp, baum):
    check(PostureOptions, dt=dt, gain=gain, kind=kind)
    check(WalkOptions, dt=dt, duty=duty, speed=speed)
    check(RolloutOptions, kp=kp, dt=dt, baumgarte=baum)
