"""Mixed primitives in one controller (seed 003 §5.7): similarity tasks over *subsets* of a system's end frames.

On the hexapod (six end points): a circle of three feet and a line of two others stacked in one
:func:`~coop_ga.control.solve_step`, both reached inside the joint limits; then those two as the first priority
level and a point pair of a circle foot and the sixth foot as the second, in conflict with the first (4 free DOF
for its 6): the first level is reached to rounding, the second as far as the first's nullspace allows — measured
by the projected gradient of ½‖e₂‖² (first-order optimality on the manifold e₁ = 0) and by perturbations along
that manifold, none of which lowers ‖e₂‖.
"""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import Configuration, SimilarityTask, default_limits, displaced_target, run_ik, solve_step
from coop_ga.cooperative import cooperative_task
from coop_ga.systems import cartesian_points, load

DT = 0.02


@pytest.fixture(scope="module")
def setup():
    system = load("hexapod")
    q0 = np.asarray(system.q0, float)
    circle = cooperative_task(system, "circle", points=(0, 1, 2), codegen=False)
    line = cooperative_task(system, "line", points=(3, 4), codegen=False)
    pair = cooperative_task(system, "point_pair", points=(0, 5), codegen=False)
    targets = {
        "circle": displaced_target(circle, q0, translation=(0.01, -0.01, 0.02), axis=(1, 0, 0), angle=0.08, scale=1.02),
        "line": displaced_target(line, q0, translation=(-0.01, 0.02, 0.01), axis=(0, 0, 1), angle=0.1),
        "pair": displaced_target(pair, q0, translation=(0.03, 0.02, 0.02), axis=(0, 1, 0), angle=0.2, scale=1.1),
    }
    return system, q0, {"circle": circle, "line": line, "pair": pair}, targets


def test_subset_tasks_evaluate_their_own_primitive(setup):
    _, q0, tasks, targets = setup
    assert tasks["circle"].end_frames == ("lf_foot", "lr_foot", "rm_foot")
    assert tasks["line"].end_frames == ("rf_foot", "lm_foot")
    cfg = Configuration(tasks["circle"], q0)
    for name in ("circle", "line"):
        t = SimilarityTask(targets[name], model=tasks[name])
        assert t.similarity_target is None  # its own configuration is prepared, not the step's
        np.testing.assert_allclose(t.error(cfg), -tasks[name].error(q0, targets[name]), atol=1e-15)
        np.testing.assert_allclose(t.jacobian(cfg), tasks[name].jacobian(q0), atol=1e-15)
        ex = SimilarityTask(targets[name], model=tasks[name], jacobian="exact")
        np.testing.assert_allclose(ex.jacobian(cfg), -tasks[name].error_jacobian(q0, targets[name]), atol=1e-14)
    # the configuration's own model given explicitly: the same numbers as without it
    own = SimilarityTask(targets["circle"], model=tasks["circle"])
    plain = SimilarityTask(targets["circle"])
    np.testing.assert_array_equal(own.error(cfg), plain.error(cfg))
    # moving the step moves the subset task's evaluation with it
    q1 = q0 + 0.05
    cfg.update(q1)
    line_task = SimilarityTask(targets["line"], model=tasks["line"])
    np.testing.assert_allclose(line_task.error(cfg), -tasks["line"].error(q1, targets["line"]), atol=1e-15)


def test_a_task_of_another_system_is_refused(setup):
    _, q0, tasks, _ = setup
    other = cooperative_task(cartesian_points(3), "circle", codegen=False)
    t = SimilarityTask(other.similarity(np.zeros(other.nq)), model=other)
    with pytest.raises(cg.InvalidInputError, match="same system"):
        t.error(Configuration(tasks["circle"], q0))


def test_circle_of_three_feet_and_line_of_two_others_in_one_controller(setup):
    system, q0, tasks, targets = setup
    circle, line = tasks["circle"], tasks["line"]
    both = [SimilarityTask(targets["circle"], model=circle), SimilarityTask(targets["line"], model=line)]
    assert np.linalg.norm(circle.error(q0, targets["circle"])) > 0.05
    assert np.linalg.norm(line.error(q0, targets["line"])) > 0.05
    run = run_ik(Configuration(circle, q0), both, default_limits(system.limits), dt=DT, steps=300)
    qf = run.trajectory[-1]
    assert np.linalg.norm(circle.error(qf, targets["circle"])) < 1e-4  # measured 2e-16
    assert np.linalg.norm(line.error(qf, targets["line"])) < 1e-4  # measured 3e-17
    assert run.max_position_violation == 0.0
    assert np.all(run.trajectory >= system.limits.lower) and np.all(run.trajectory <= system.limits.upper)
    # one step: the two tasks' rows are stacked (14 rows), the step is their least-squares (min-norm) solution
    cfg = Configuration(circle, q0)
    st = solve_step(cfg, both, (), DT, damping=0.0)
    A = np.vstack([t.jacobian(cfg) for t in both])
    b = np.concatenate([-t.gain * t.error(cfg) for t in both])
    np.testing.assert_allclose(st.velocity, np.linalg.lstsq(A, b, rcond=1e-12)[0], atol=1e-10)


def test_priorities_first_level_exact_second_as_far_as_the_nullspace_allows(setup):
    system, q0, tasks, targets = setup
    circle, line, pair = tasks["circle"], tasks["line"], tasks["pair"]
    first = [SimilarityTask(targets["circle"], model=circle), SimilarityTask(targets["line"], model=line)]
    second = SimilarityTask(targets["pair"], model=pair, jacobian="exact")  # Gauss–Newton: its fixed point is optimal
    run = run_ik(Configuration(circle, q0), first, default_limits(system.limits), dt=DT, steps=400, levels=[[second]])
    qf = run.trajectory[-1]

    def e1(q):
        return np.r_[circle.error(q, targets["circle"]), line.error(q, targets["line"])]

    def J1(q):
        return np.vstack([circle.error_jacobian(q, targets["circle"]), line.error_jacobian(q, targets["line"])])

    e2 = pair.error(qf, targets["pair"])
    assert np.linalg.norm(e1(qf)) < 1e-10  # measured 4e-16
    # in conflict: the point pair has 6 DOF, the first level leaves it 4 (foot 5, and foot 0 along its circle)
    assert 0.15 < np.linalg.norm(e2) < np.linalg.norm(pair.error(q0, targets["pair"]))  # measured 0.194 < 0.230
    # first-order optimal on the manifold e1 = 0: the gradient of ½‖e2‖² has no component in the nullspace of J1
    N = np.eye(system.model.nq) - np.linalg.pinv(J1(qf)) @ J1(qf)
    g = pair.error_jacobian(qf, targets["pair"]).T @ e2
    assert np.linalg.norm(N @ g) < 1e-6 * np.linalg.norm(g)  # measured 1.8e-10
    # and locally minimal: steps along the manifold (projected back onto e1 = 0 by Gauss–Newton) never lower ‖e2‖
    rng = np.random.default_rng(5)
    for _ in range(12):
        q = qf + N @ rng.normal(scale=5e-3, size=qf.size)
        for _ in range(6):
            q = q - np.linalg.pinv(J1(q)) @ e1(q)
        assert np.linalg.norm(e1(q)) < 1e-12
        assert np.linalg.norm(pair.error(q, targets["pair"])) >= np.linalg.norm(e2) - 1e-12
    assert run.max_position_violation == 0.0
    assert np.all(qf > system.limits.lower) and np.all(qf < system.limits.upper)
