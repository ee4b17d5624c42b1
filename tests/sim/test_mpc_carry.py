"""coop_ga.sim.mpc_carry without physics: the figure-eight target and the plan that follows the MPC."""

from __future__ import annotations

import math

import numpy as np


def test_figure_eight_starts_at_rest_and_has_its_amplitude():
    from coop_ga.sim.mpc_carry import carry_target

    c = np.array([0.1, -0.2, 0.5])
    f = carry_target(2.0, c, 0.05, math.radians(90.0), 4.0)
    np.testing.assert_allclose(f(0.0), c, atol=0)
    np.testing.assert_allclose(f(2.0), c, atol=0)
    np.testing.assert_allclose((f(2.001) - f(2.0)) / 1e-3, 0.0, atol=1e-6)  # ramped in: no velocity step
    # after the 1 s ramp: heading 90° → the main axis is world y, the half-amplitude axis is −x
    np.testing.assert_allclose(
        f(2.0 + 5.0), c + 0.05 * np.array([-0.5 * math.sin(5.0 * math.pi), 1.0, 0.0]), atol=1e-12
    )
    ts = np.linspace(3.0, 7.0, 2001)
    p = np.array([f(t) for t in ts])
    np.testing.assert_allclose(np.ptp(p, axis=0), [0.05, 0.10, 0.0], atol=1e-4)


class _Follower:
    start, lifted = 1.0, np.array([0.0, 0.0, 0.55])

    def reference(self, t: float) -> np.ndarray:
        return self.lifted + np.array([0.01 * t, 0.0, 0.0])


def test_follow_plan_moves_the_carry_plan_only_from_the_track_start():
    from dataclasses import fields

    from coop_ga.sim.hold import CarryPlan
    from coop_ga.sim.mpc_carry import FollowPlan

    base = CarryPlan(centre=(0, 0, 0.4), object_centre=(0, -0.01, 0.4), radius_touch=0.28, radius_open=0.31,
                     squeeze=40.0, shift=(0, 0, 0), yaw=0.0, durations=(0.5,) * 9)  # fmt: skip
    plan = FollowPlan(**{f.name: getattr(base, f.name) for f in fields(CarryPlan) if f.init}, follow=_Follower())
    np.testing.assert_array_equal(plan.at(0.7).centre, base.at(0.7).centre)
    np.testing.assert_allclose(plan.at(2.1).centre, base.at(2.1).centre + [0.021, 0.0, 0.0], atol=1e-15)
    assert plan.at(2.1).radius == base.at(2.1).radius  # the squeeze loop's radius, not the MPC's
