"""Fuzz properties of coop_ga.systems (systems built from models, configurations, limits, the registry).

For arbitrary inputs — finite, extreme, NaN/inf, wrongly typed or shaped — every public function (a) never
returns NaN or inf (±inf limits mean "unbounded" and are allowed), (b) raises only :class:`coop_ga.CoopGAError`
subclasses and (c) never modifies its inputs (:func:`tests.fuzz.contract.check`); a system that is built
has a finite q0 inside its limits.  ``--hypothesis-profile=long`` runs 10 000 examples per property (CI: 60,
fixed seeds).
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pinocchio as pin
from hypothesis import given
from hypothesis import strategies as st

from coop_ga import systems
from coop_ga.systems import System, append_robots, cartesian_points, from_model, prefixed, unique_frames
from tests.fuzz.contract import bad, check, moderate, reals, vec


@cache
def _cart() -> System:
    return cartesian_points(3)


def q9():
    return st.one_of(vec(9), st.lists(st.floats(-6.0, 6.0), min_size=9, max_size=9).map(np.array), vec(8),
                     st.lists(st.lists(moderate, min_size=9, max_size=9), min_size=1, max_size=3))  # fmt: skip


@given(q=q9(), warn=st.one_of(st.booleans(), bad))
def test_configurations(q, warn):
    s = _cart()
    a = check(s.check_q, q, warn_limits=warn)
    p = check(s.end_points, q)
    check(s.frame_motors, q)
    if a is not None and p is not None:
        np.testing.assert_allclose(
            p, np.asarray(s.end_points(s.q0)) + a.reshape(3, 3), atol=1e-9 * (1 + np.abs(a).max())
        )


@given(q=q9(), dt=reals, tol=reals)
def test_limit_checks(q, dt, tol):
    lim = _cart().limits
    v = check(lim.position_violation, q)
    check(lim.velocity_violation, q)
    check(lim.acceleration_violation, q)
    check(lim.effort_violation, q)
    c = check(lim.clip, q)
    check(lim.trajectory_velocity_violation, q, dt)
    check(lim.describe, q, tol)
    if v is not None:
        assert v >= 0.0
    if c is not None:
        assert lim.position_violation(c) == 0.0


@given(q0=st.one_of(st.none(), q9()), name=st.one_of(st.text(min_size=1, max_size=4), bad),
       frames=st.one_of(st.just(["tip0", "tip1"]), st.lists(st.sampled_from(["tip0", "tip2", "nope", 3]), max_size=3),
                        bad), locked=st.one_of(st.just(()), st.just(["c0_px"]), bad))  # fmt: skip
def test_from_model(q0, name, frames, locked):
    s = check(from_model, _cart().model, frames, name=name, q0=q0, locked_joints=locked)
    if s is not None:
        assert np.all(s.q_lower <= s.q0) and np.all(s.q0 <= s.q_upper)
        if q0 is None:
            assert np.all(s.q_lower < s.q0) and np.all(s.q0 < s.q_upper)  # the default: strictly inside


@given(n=st.one_of(st.integers(-1, 6), bad), bases=st.one_of(st.none(), vec(6), st.lists(
    st.lists(moderate, min_size=3, max_size=3), min_size=1, max_size=4)), limit=reals)  # fmt: skip
def test_cartesian_points(n, bases, limit):
    s = check(cartesian_points, n, bases, limit)
    if s is not None:
        assert s.nq == 3 * n and np.all(s.q0 == 0.0)


@given(prefix=st.one_of(st.text(max_size=3), bad), placement=st.one_of(st.just(pin.SE3.Identity()), bad),
       twice=st.booleans())  # fmt: skip
def test_combining_models(prefix, placement, twice):
    m = _cart().model
    p = check(prefixed, m, prefix)
    check(unique_frames, m)
    parts = [(m, placement), (p if p is not None else m, placement)] if twice else [(m, placement)]
    out = check(append_robots, parts)
    if out is not None:
        assert out.nq == sum(x.nq for x, _ in parts)


@given(scale=reals, seed=st.integers(0, 2**32 - 1), rng_bad=st.one_of(st.none(), bad))
def test_random_configurations(scale, seed, rng_bad):
    s = _cart()
    q = check(s.random_q, np.random.default_rng(seed), scale)
    check(s.random_q, rng_bad, 0.5)
    if q is not None:
        assert np.all(s.q_lower <= q) and np.all(q <= s.q_upper)


@given(name=st.one_of(st.sampled_from(systems.names()[:1]), st.text(max_size=5), bad), vel=st.one_of(reals, vec(2)),
       pos=st.one_of(st.tuples(reals, reals), bad))  # fmt: skip
def test_registry_and_limit_overrides(name, vel, pos):
    check(systems.load, name)
    s = _cart()
    t = check(s.with_limits, position={"c0_px": pos}, velocity=vel)
    if t is not None:
        assert t.limits.lower[0] <= t.q0[0] <= t.limits.upper[0]
