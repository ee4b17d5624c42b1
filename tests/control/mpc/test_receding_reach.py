"""RecedingReach (the MPC's inner solver, set up once): the same numbers as ilqr_reach without restart, tick after
tick, and its cheap checks of the later inputs."""

from __future__ import annotations

import numpy as np
import pytest

from coop_ga.errors import InvalidInputError, NonFiniteError


@pytest.fixture(scope="module")
def setup(load_system):
    import coop_ga as cg
    from coop_ga.geometry import primitives as P
    from coop_ga.sim.mpc_track import figure_eight_target

    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0, float)
    X0 = task.primitive(q0)
    return task, q0, figure_eight_target(np.asarray(P.center(X0), float), float(P.radius(X0)))


OPTS = dict(horizon=10, dt=0.02, R=1e-3, Q=1e5, Qv=1.0, terminal="soft", hessian="gauss_newton", restart=False)


def test_same_solves_as_ilqr_reach(setup):
    """Five receding ticks (new start, new target, shifted warm start): trajectories, controls, errors and iteration
    counts equal ilqr_reach's to the last bit; only the list of active bounds is left out."""
    from coop_ga.control.ilqr import RecedingReach, ilqr_reach

    task, q0, target = setup
    solver = RecedingReach(task, max_iter=3, **OPTS)
    q, qd, u = q0.copy(), np.zeros(task.nq), None
    for k in range(5):
        V = target(0.2 + 0.04 * k)
        a = solver.solve(q, V, qd_init=qd, u_init=u)
        b = ilqr_reach(task, q, V, qd_init=qd, u_init=u, max_iter=3, **OPTS)
        np.testing.assert_array_equal(a.trajectory, b.trajectory)
        np.testing.assert_array_equal(a.u, b.u)
        assert (a.error, a.cost, a.iterations, a.converged) == (b.error, b.cost, b.iterations, b.converged)
        assert a.within_limits and a.active_constraints == ()
        q, qd = a.trajectory[2].copy(), a.qd[2].copy()  # two knots on: the next tick's state
        u = np.vstack([a.u[2:], a.u[-1:], a.u[-1:]])
    assert np.linalg.norm(q - q0) > 1e-3  # the loop did move


def test_later_inputs_are_still_checked(setup):
    from coop_ga.control.ilqr import RecedingReach

    task, q0, target = setup
    solver = RecedingReach(task, max_iter=1, **OPTS)
    solver.solve(q0, target(0.0))
    with pytest.raises(InvalidInputError, match="q_init"):
        solver.solve(q0[:-1], target(0.0))
    bad = q0.copy()
    bad[3] = np.nan
    with pytest.raises(NonFiniteError, match="qd_init"):
        solver.solve(q0, target(0.0), qd_init=bad)
