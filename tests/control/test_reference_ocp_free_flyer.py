"""The reference OCP (CasADi Opti + IPOPT) on the floating G1: state (q, v), q_{k+1} = q_k ⊕ (Δt v_k + ½Δt² u_k)
through the exact symbolic ``pinocchio.integrate``; checked with Pinocchio's integrate and forward kinematics."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.control.ilqr import ReachingOCP
from coop_ga.control.reference_ocp import TangentReachingOCP, solve_reference
from coop_ga.cooperative.targets import displaced_target
from coop_ga.errors import InvalidInputError, UnsupportedJointError
from coop_ga.kinematics.chains import integrate_symbolic
from coop_ga.systems.library import g1_floating

MOVE = {"translation": (0.6, 0.2, 0.3), "axis": (0.0, 0.0, 1.0), "angle": 0.4}


@pytest.fixture(scope="module")
def system():
    return g1_floating()


def _hands(s, q) -> np.ndarray:
    d = s.model.createData()
    pin.framesForwardKinematics(s.model, d, q)
    return np.array([d.oMf[s.model.getFrameId(f)].translation for f in s.end_frames])


def test_integrate_symbolic_equals_pinocchio(system) -> None:
    m = system.model
    q, v = ca.SX.sym("q", m.nq), ca.SX.sym("v", m.nv)
    expr = integrate_symbolic(m, q, v)
    f = ca.Function("f", [q, v], [expr, ca.jacobian(expr, v)])
    rng = np.random.default_rng(3)
    worst = worst_jac = 0.0
    # |ω| on both sides of the Taylor/closed-form switch (|ω| = 0.1), down to 0 and up to near a half-turn
    for scale in (0.0, 1e-9, 1e-3, 0.05, 0.099, 0.101, 0.5, 1.5):
        q0, v0 = system.random_q(rng), scale * rng.normal(size=m.nv)
        val, jac = (np.array(a) for a in f(q0, v0))
        ref = pin.integrate(m, q0, v0)
        worst = max(worst, float(np.abs(val.ravel() - ref).max()))
        # ∂(q ⊕ v)/∂v by central differences of pinocchio.integrate
        eps = 1e-6
        fd = np.array(
            [
                (pin.integrate(m, q0, v0 + eps * e) - pin.integrate(m, q0, v0 - eps * e)) / (2 * eps)
                for e in np.eye(m.nv)
            ]
        ).T
        worst_jac = max(worst_jac, float(np.abs(jac - fd).max()))
        assert np.all(np.isfinite(jac))
    assert worst <= 1e-14
    assert worst_jac <= 1e-8


def test_fixed_base_integrate_symbolic_is_q_plus_v() -> None:
    m = cg.systems.load("three_franka").model
    q, v = ca.SX.sym("q", m.nq), ca.SX.sym("v", m.nv)
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=m.nq), rng.normal(size=m.nv)
    out = np.array(ca.Function("f", [q, v], [integrate_symbolic(m, q, v)])(a, b)).ravel()
    assert np.array_equal(out, a + b)


@pytest.mark.parametrize("terminal", ["soft", "constraint"])
def test_floating_reach_solved_by_ipopt(system, terminal) -> None:
    task = cg.cooperative_task(system, "point_pair")
    Vd = displaced_target(task, system.q0, **MOVE)
    ocp = TangentReachingOCP(task, system.q0, Vd, horizon=30, dt=0.05)
    r = solve_reference(ocp, solver="ipopt", terminal=terminal)
    assert r.success, r.status
    assert r.q.shape == (31, 24) and r.qd.shape == (31, 23) and r.u.shape == (30, 23)
    assert r.terminal_error <= (1e-6 if terminal == "soft" else 1e-9)
    assert r.max_violation == 0.0 and r.defect <= 1e-9
    assert np.abs(np.linalg.norm(r.q[:, 3:7], axis=1) - 1.0).max() <= 1e-12  # the quaternion stays unit
    assert np.linalg.norm(r.q[-1, :3] - system.q0[:3]) > 0.3  # the pelvis moved (a fixed one cannot reach)
    q_roll, v_roll = ocp.rollout(r.u)  # the controls re-integrated by pinocchio.integrate give the NLP's states
    assert np.abs(q_roll - r.q).max() <= 1e-8 and np.abs(v_roll - r.qd).max() <= 1e-8
    p0 = _hands(system, system.q0)
    c = p0.mean(axis=0)
    R = pin.AngleAxis(MOVE["angle"], np.array(MOVE["axis"])).toRotationMatrix()
    expected = (p0 - c) @ R.T + c + np.array(MOVE["translation"])
    assert np.abs(_hands(system, r.q[-1]) - expected).max() <= (1e-6 if terminal == "soft" else 1e-8)
    x = system.limit_coordinates(r.q)
    assert system.limits.position_violation(x) == 0.0
    assert np.abs(r.qd[1:]).max(axis=0)[:6].max() <= 2.0 + 1e-9  # the pelvis' own speed bound (2 m/s, rad/s)


def test_fatrop_solves_the_floating_reach_with_the_terminal_constraint(system) -> None:
    task = cg.cooperative_task(system, "point_pair")
    ocp = TangentReachingOCP(task, system.q0, displaced_target(task, system.q0, **MOVE), horizon=30, dt=0.05)
    r = solve_reference(ocp, solver="fatrop", terminal="constraint")
    ref = solve_reference(ocp, solver="ipopt", terminal="constraint")
    assert r.success and ref.success, (r.status, ref.status)
    assert r.terminal_error <= 1e-9 and r.max_violation == 0.0 and r.defect <= 1e-9
    assert np.abs(np.linalg.norm(r.q[:, 3:7], axis=1) - 1.0).max() <= 1e-12
    assert abs(r.cost - ref.cost) <= 1e-7 * ref.cost and np.abs(r.q - ref.q).max() <= 1e-5  # the same optimum


def test_a_reaching_ocp_on_a_free_flyer_is_refused(system) -> None:
    task = cg.cooperative_task(system, "point_pair")
    Vd = displaced_target(task, system.q0, translation=(0.05, 0.0, 0.0))
    with pytest.raises(UnsupportedJointError, match=r"solve_reference.*nq = 24, nv = 23.*TangentReachingOCP"):
        solve_reference(ReachingOCP(task, system.q0, Vd, horizon=5))
    with pytest.raises(InvalidInputError, match="qd_init"):
        TangentReachingOCP(task, system.q0, Vd, qd_init=np.zeros(24))
    q = system.q0.copy()
    q[3:7] *= 2.0
    with pytest.raises(InvalidInputError, match="quaternion"):
        TangentReachingOCP(task, q, Vd)
