"""A cooperative circle tracks a smooth screw reference (coop_ga.reference_trajectory):
the three Frankas' circle moves, turns and grows along the minimum-jerk similarity path, driven by
differential IK with the reference's twist as feed-forward plus feedback on e = log(Ṽ_Sc V_ref)."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import diff_ik_step
from coop_ga.cooperative.targets import displaced_target

SCALE = 1.15


@pytest.fixture(scope="module")
def runs():
    task = cg.cooperative_task(cg.systems.load("three_franka"), "circle")
    q0 = task.system.q0.copy()
    V0 = task.similarity(q0)
    V1 = displaced_target(task, q0, translation=(0.0, 0.1, 0.05), axis=(0, 0, 1), angle=0.2, scale=SCALE)
    t, poses, twists = cg.reference_trajectory(V0, V1, 2.0, 201)
    out = {}
    for name, ff in (("feedforward", 1.0), ("feedback_only", 0.0)):
        q = q0.copy()
        qd = np.zeros_like(q)  # the last step's velocity, for the acceleration limits (from rest)
        errors, radii, worst_limit = [], [], 0.0
        for k in range(len(t)):
            e = task.error(q, poses[k])
            errors.append(float(np.linalg.norm(e)))
            radii.append(float(cg.radius(task.primitive(q))))
            worst_limit = max(
                worst_limit, float(np.max(task.system.q_lower - q)), float(np.max(q - task.system.q_upper))
            )
            if k < len(t) - 1:
                dt = float(t[1] - t[0])
                q_next = diff_ik_step(task, q, ff * twists[k] + 5.0 * e, dt=dt, velocity=qd)
                q, qd = q_next, (q_next - q) / dt
        out[name] = (np.array(errors), np.array(radii), worst_limit)
    return t, poses, out


def test_reference_starts_at_the_current_pose_and_ends_at_the_target(runs) -> None:
    _, _, out = runs
    assert out["feedforward"][0][0] < 1e-12


def test_feedforward_tracks_the_screw_reference(runs) -> None:
    _, _, out = runs
    ff, fb = out["feedforward"][0], out["feedback_only"][0]
    assert ff.max() < 1e-3  # measured 3.3e-4 along the whole 2 s path
    assert fb.max() > 30 * ff.max()  # feedback alone lags (measured 4.5e-2)
    assert out["feedforward"][2] <= 0.0  # inside the joint limits throughout


def test_the_circle_grows_along_the_geometric_radius_profile(runs) -> None:
    t, _, out = runs
    radii = out["feedforward"][1]
    tau = t / t[-1]
    s = tau**3 * (10 - 15 * tau + 6 * tau**2)
    expected = radii[0] * SCALE**s  # r0^(1−s) r1^s of the similarity's screw path
    assert np.abs(radii / expected - 1).max() < 2e-3
    assert radii[-1] / radii[0] == pytest.approx(SCALE, rel=1e-3)
