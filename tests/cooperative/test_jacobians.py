"""J^G of every system and every primitive kind it supports, by three independent routes.

* the structured route of the compiled path (point Jacobians × AD of a small function),
* route (a): closed forms (Eq 15–17, 29–30, Appendix B corrected),
* route (b): CasADi AD of the unstructured graph q → V_Sc,

all against central finite differences of ``log(Ṽ_Sc(q) V_Sc(q ± h e_i))`` — the
definition of column i of the body-frame Jacobian.  Every chain's columns are checked
to be non-zero: a finger whose columns are silently zero is the bug this exists for.
"""

from __future__ import annotations

import warnings
import zlib

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import systems
from coop_ga.cooperative import CooperativeTask
from coop_ga.geometry.primitives import N_POINTS

KINDS = ("point", "point_pair", "line", "circle", "plane", "sphere")
# end frames per registered system, written out so that collection loads no system (checked below)
N_CHAINS = {
    "three_franka": 3,
    "three_iiwa14": 3,
    "g1_arms": 2,
    "g1_torso_arms": 3,
    "franka_and_g1": 3,
    "two_g1": 4,
    "three_finger_hand": 3,
    "allegro": 4,
    "hexapod": 6,
    "hexapod_floating": 6,
}
CASES = [(name, kind) for name in systems.names() for kind in KINDS if N_POINTS[kind] <= N_CHAINS[name]]


def test_chain_counts_are_those_of_the_registry(load_system) -> None:
    assert sorted(N_CHAINS) == sorted(systems.names())
    assert all(load_system(name).n_chains == n for name, n in N_CHAINS.items())


def _configs(task: CooperativeTask, rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """Random q inside the limits (around q0) with a well-conditioned primitive."""
    sys = task.system
    out = []
    while len(out) < n:
        q = np.clip(sys.q0 + rng.uniform(-0.4, 0.4, sys.nq), sys.q_lower, sys.q_upper)
        pts = sys.tree.end_points_array(q)[list(task.point_indices)]
        if N_POINTS[task.kind] > 1 and cg.well_definedness(task.kind, pts) <= 0.1:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cg.ChartWarning)
            if np.linalg.norm(task.log(q)[:3]) > np.deg2rad(150):  # near the chart's half-turn: not this test's topic
                continue
        out.append(q)
    return out


def _fd_jacobian(task: CooperativeTask, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    V0r = ~task.similarity(q)
    J = np.zeros((7, task.nq))
    for i in range(task.nq):
        dq = np.zeros(task.nq)
        dq[i] = h
        J[:, i] = (cg.log(V0r * task.similarity(q + dq)) - cg.log(V0r * task.similarity(q - dq))) / (2 * h)
    return J


@pytest.mark.parametrize("name,kind", CASES, ids=[f"{n}-{k}" for n, k in CASES])
def test_jacobian_routes_agree(name: str, kind: str) -> None:
    sys = systems.load(name)
    # VM: the same graph the C code is generated from; the canonical chart, the one the closed forms of
    # Appendix B (route (a)) are written for
    task = CooperativeTask(sys, kind, codegen=False, chart_axis=None)
    rng = np.random.default_rng(zlib.crc32(f"{name}-{kind}".encode()))  # fixed per case, never hash()
    chains = sys.tree.joint_columns
    for q in _configs(task, rng, 2):
        J = task.jacobian(q)
        scale = max(1.0, np.abs(J).max())
        J_fd = _fd_jacobian(task, q)
        np.testing.assert_allclose(J, J_fd, atol=1e-6 * scale, rtol=0)
        np.testing.assert_allclose(task.jacobian_ad(q), J, atol=1e-9 * scale, rtol=0)
        JA, JG = task.jacobian_closed_form(q)
        np.testing.assert_allclose(JG, J, atol=1e-9 * scale, rtol=0)
        np.testing.assert_allclose(JA, task.analytic_jacobian(q), atol=1e-9 * scale, rtol=0)
        # every chain that defines the primitive moves it; joints of unused chains do not
        used = {j for i in task.point_indices for j in chains[i]}
        for i in task.point_indices:
            assert np.linalg.norm(J[:, list(chains[i])]) > 1e-3, f"chain {i} ({sys.end_frames[i]}) has zero columns"
        unused = [j for j in range(sys.nq) if j not in used]
        if unused:
            assert np.abs(J[:, unused]).max() == 0.0
        # numpy multivector route gives the same versor as the compiled graph
        Vn = task.similarity_numpy(q)
        np.testing.assert_allclose(cg.log(~Vn * task.similarity(q)), 0.0, atol=1e-12)


@pytest.mark.parametrize("name,kind", CASES, ids=[f"{n}-{k}" for n, k in CASES])
def test_bivector_and_error_jacobians(name: str, kind: str) -> None:
    """J^B (Eq 31) and the IK error Jacobian (Eq 47) against finite differences."""
    sys = systems.load(name)
    task = CooperativeTask(sys, kind, codegen=False)
    rng = np.random.default_rng(7)
    q, qt = _configs(task, rng, 2)
    target = task.similarity(qt)
    h = 1e-6
    JB = task.bivector_jacobian(q)
    e, Je = task.error_and_jacobian(q, target)
    JB_fd = np.zeros_like(JB)
    Je_fd = np.zeros_like(Je)
    for i in range(task.nq):
        dq = np.zeros(task.nq)
        dq[i] = h
        JB_fd[:, i] = (task.log(q + dq) - task.log(q - dq)) / (2 * h)
        Je_fd[:, i] = (task.error(q + dq, target) - task.error(q - dq, target)) / (2 * h)
    np.testing.assert_allclose(JB, JB_fd, atol=1e-6 * max(1, np.abs(JB).max()))
    np.testing.assert_allclose(Je, Je_fd, atol=1e-6 * max(1, np.abs(Je).max()))
    np.testing.assert_allclose(e, cg.log(~task.similarity(q) * target), atol=1e-12)


def test_cartesian_system_jacobian_is_the_similarity_part(cartesian4) -> None:
    """With p = base + q, J^G = G(p): FD in point coordinates directly (sphere, all 12 columns)."""
    task = CooperativeTask(cartesian4, "sphere", codegen=False)
    q = np.random.default_rng(3).uniform(-0.2, 0.2, 12)
    np.testing.assert_allclose(task.jacobian(q), _fd_jacobian(task, q), atol=1e-6)
    assert np.all(np.linalg.norm(task.jacobian(q), axis=0) > 1e-3)
