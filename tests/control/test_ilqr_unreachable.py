"""iLQR on unreachable targets: a certificate (the target primitive misses the reach of an end point) stops the solve
before any iteration with an honest message; it never fires on a reachable target; the balls it uses hold every
position of the end points.  A target that the limits alone keep out of reach stops at the stall test."""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import displaced_target, gauss_newton_ik, ilqr_reach
from coop_ga.control.ilqr import ReachingOCP
from coop_ga.control.ilqr.reachability import bounded_stationarity, reach_balls, unit_distance, unreachable
from coop_ga.control.ilqr.solver import STALL_DECREASE, STALL_STATIONARITY, STALL_WINDOW

PHRASE = "not reachable inside the limits from this start"


def test_far_target_fails_before_any_iteration_and_says_why(load_system):
    """A circle 3 m away from three_franka (the arms reach 1.09 m about their first joints): before, the solve ran its
    60 iterations (1.3 s, 12× the Gauss–Newton IK's time) and the message said only "max_iter reached"."""
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0)
    far = displaced_target(task, q0, translation=(3.0, 0.0, 0.0))
    res = ilqr_reach(task, q0, far)
    assert not res.converged and res.iterations == 0 and res.stats == ()
    assert PHRASE in res.message and "unreachable" in res.message and "arm" in res.message
    assert res.within_limits and np.all(res.u == 0.0) and np.all(res.trajectory == q0)  # rest: nothing to gain
    assert len(res.cost_history) == len(res.error_history) == 1 and res.error == res.error_history[0] > 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gn = gauss_newton_ik(task, q0, far)
    assert not gn.converged and gn.iterations > 10  # the anchor of benchmarks/ilqr_unreachable.py works for it


def test_moving_start_on_an_unreachable_target_brakes_inside(load_system):
    s = load_system("g1_arms")
    task = cg.cooperative_task(s, "line")
    q0 = np.array(s.q0)
    qd0 = np.random.default_rng(3).uniform(-0.2, 0.2, s.nq)
    res = ilqr_reach(task, q0, displaced_target(task, q0, translation=(0.0, 0.0, 3.0)), qd_init=qd0)
    assert not res.converged and res.iterations == 0 and PHRASE in res.message
    assert res.within_limits and res.terminal_speed < 1e-12 and np.array_equal(res.qd[0], qd0)  # braked to rest


@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("three_franka", "circle"),
        ("three_franka", "plane"),
        ("three_franka", "point"),
        ("g1_torso_arms", "circle"),  # the waist is shared by the chains
        ("franka_and_g1", "point_pair"),
        ("g1_arms", "line"),
        ("allegro", "sphere"),
        ("hexapod", "circle"),
    ],
)
def test_certificate_is_sound(load_system, name, kind):
    """Every end point stays inside its ball at random configurations within the limits; a target reached by
    construction (the primitive at such a configuration) is never certified unreachable, and its end points lie on
    it (which checks the unit primitives' conventions of every kind)."""
    s = load_system(name)
    task = cg.cooperative_task(s, kind)
    rng = np.random.default_rng(11)
    worst_ball, worst_on, checked = -np.inf, 0.0, 0
    for _ in range(12):
        q = rng.uniform(s.q_lower, s.q_upper)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                target = task.similarity(q)
                ocp = ReachingOCP(task, s.q0, target)
        except (cg.errors.DegeneratePrimitiveError, cg.errors.ChartError):
            continue  # a degenerate primitive, or one across the chart's half-turn from q0's
        assert unreachable(ocp, 1e-5) is None
        balls = reach_balls(ocp)
        assert balls is not None and len(balls) == len(task.end_frames)
        t, Rm, sc = target.translation, target.rotation_matrix, target.scale
        for p, (c, r) in zip(task.tree.end_points_array(q), balls):
            worst_ball = max(worst_ball, float(np.linalg.norm(p - c)) - r)
            worst_on = max(worst_on, sc * unit_distance(task.primitive_kind, Rm.T @ (p - t) / sc))
        checked += 1
    assert checked >= 6
    assert worst_ball <= 1e-12  # the balls hold the end points
    assert worst_on < 1e-9  # [m]: the end points lie on the primitive they span


def test_certificate_is_off_where_it_cannot_hold(load_system):
    """The least-squares kinds (their points need not lie on the fit) and a coarse tol get no certificate."""
    s = load_system("allegro")
    q0 = np.array(s.q0)
    fit = cg.cooperative_task(s, "sphere_fit")
    assert unreachable(ReachingOCP(fit, q0, displaced_target(fit, q0, translation=(3.0, 0, 0))), 1e-5) is None
    task = cg.cooperative_task(s, "sphere")
    ocp = ReachingOCP(task, q0, displaced_target(task, q0, translation=(3.0, 0, 0)))
    assert unreachable(ocp, 1e-5) is not None and unreachable(ocp, 0.5) is None


def test_unit_distances():
    y = np.array([3.0, 4.0, 12.0])
    assert unit_distance("point", y) == 13.0
    assert unit_distance("point_pair", y) == pytest.approx(np.sqrt(9 + 9 + 144))
    assert unit_distance("line", y) == pytest.approx(np.hypot(3.0, 12.0))
    assert unit_distance("circle", y) == pytest.approx(np.hypot(4.0, 12.0))
    assert unit_distance("plane", y) == 12.0
    assert unit_distance("sphere", y) == 12.0


# Two planes of benchmarks/ilqr_unreachable.py (seed 0) that pass within the arms' reach but that their position limits
# keep out of reach: the certificate cannot tell, so the solve used to run its whole budget (60 iterations, 3–7× the
# Gauss–Newton IK's time) and end with "max_iter reached" / "max_outer … reached", saying nothing of reachability.
BLOCKED_PLANES = [
    ("franka_and_g1", (-1.41254, 1.75253, -1.98327)),  # the G1 hands stay ≥ 0.12 m off the plane (waist pitch limit)
    ("three_finger_hand", (2.45306, 1.29879, 1.13827)),  # the middle finger stays ≥ 0.07 m off it
]


@pytest.mark.parametrize(("name", "translation"), BLOCKED_PLANES)
def test_plane_kept_out_by_the_limits_stops_at_the_stall_and_says_so(load_system, name, translation):
    s = load_system(name)
    task = cg.cooperative_task(s, "plane")
    q0 = np.array(s.q0)
    target = displaced_target(task, q0, translation=translation)
    assert unreachable(ReachingOCP(task, q0, target), 1e-5) is None  # not certified: the stall test decides
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = ilqr_reach(task, q0, target)
        gn = gauss_newton_ik(task, q0, target)
    assert not res.converged and res.message.startswith("not converged: stationary") and PHRASE in res.message
    assert 10 <= res.iterations <= 20 and res.within_limits  # stopped at the stall, not at max_iter = 60
    errs = res.error_history
    assert errs[-1] > 0.05 and errs[-1] >= (1.0 - STALL_DECREASE) * errs[-1 - STALL_WINDOW]
    assert not gn.converged and gn.error > 0.05  # the restart's IK fails too: the result is the stalled solve's
    ocp = ReachingOCP(task, q0, target)
    e, Je = task.error_and_jacobian(res.q, target)
    assert bounded_stationarity(ocp, res.q, e, Je) < STALL_STATIONARITY


def test_bounded_stationarity():
    """‖P J_eᵀe‖ / (‖J_e‖ ‖e‖): a gradient component pushing a joint out through the limit it is on does not count."""
    ocp = SimpleNamespace(q_lower=np.array([-1.0, -1.0, -1.0]), q_upper=np.array([1.0, 1.0, 1.0]))
    Je = np.eye(7)[:, :3]
    e = np.array([0.3, -0.4, 0.0, 1.2, 0.0, 0.0, 0.0])  # ∇f = (0.3, −0.4, 0); ‖J_e‖ = 1, ‖e‖ = 1.3
    assert bounded_stationarity(ocp, np.zeros(3), e, Je) == pytest.approx(0.5 / 1.3)  # inside: the whole gradient
    at_bounds = np.array([-1.0, 1.0, 0.0])  # descent −∇f pushes joint 0 below its lower limit, joint 1 above its upper
    assert bounded_stationarity(ocp, at_bounds, e, Je) == 0.0
    assert bounded_stationarity(ocp, -at_bounds, e, Je) == pytest.approx(0.5 / 1.3)  # the other limits block nothing
