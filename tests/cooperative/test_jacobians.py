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
from typing import Any

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import systems
from coop_ga.cooperative import CooperativeTask
from coop_ga.geometry import KIND_SPECS, KINDS

# every registered system × every exact kind, read from the registry and the kind table at collection (no system is
# loaded then): a kind that needs more end points than the system has is a case too — the task must refuse it
CASES = [(name, kind) for name in systems.names() for kind in KINDS]


def _task(name: str, kind: str, **options: Any) -> CooperativeTask | None:
    """The case's task (VM), or None after checking that the system refuses a kind it has too few end points for."""
    sys = systems.load(name)
    need = KIND_SPECS[kind].n_points
    if need > sys.n_chains:
        with pytest.raises(cg.InvalidInputError, match=f"needs {need} end points"):
            CooperativeTask(sys, kind, codegen=False, **options)
        return None
    return CooperativeTask(sys, kind, codegen=False, **options)


def _configs(task: CooperativeTask, rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """Random q inside the limits (around q0) with a well-conditioned primitive."""
    sys = task.system
    out = []
    while len(out) < n:
        q = np.clip(sys.q0 + rng.uniform(-0.4, 0.4, sys.nq), sys.q_lower, sys.q_upper)
        pts = sys.tree.end_points_array(q)[list(task.point_indices)]
        if task.spec.n_points > 1 and cg.well_definedness(task.kind, pts) <= 0.1:
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
        J[:, i] = (cg.geometry.log(V0r * task.similarity(q + dq)) - cg.geometry.log(V0r * task.similarity(q - dq))) / (
            2 * h
        )
    return J


@pytest.mark.parametrize("name,kind", CASES, ids=[f"{n}-{k}" for n, k in CASES])
def test_jacobian_routes_agree(name: str, kind: str) -> None:
    # VM: the same graph the C code is generated from; the canonical chart, the one the closed forms of
    # Appendix B (route (a)) are written for
    task = _task(name, kind, chart_axis=None)
    if task is None:
        return
    sys = task.system
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
        np.testing.assert_allclose(cg.geometry.log(~Vn * task.similarity(q)), 0.0, atol=1e-12)


@pytest.mark.parametrize("name,kind", CASES, ids=[f"{n}-{k}" for n, k in CASES])
def test_bivector_and_error_jacobians(name: str, kind: str) -> None:
    """J^B (Eq 31) and the IK error Jacobian (Eq 47) against finite differences."""
    task = _task(name, kind)
    if task is None:
        return
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
    np.testing.assert_allclose(e, cg.geometry.log(~task.similarity(q) * target), atol=1e-12)


def test_cartesian_system_jacobian_is_the_similarity_part(cartesian4) -> None:
    """With p = base + q, J^G = G(p): FD in point coordinates directly (sphere, all 12 columns)."""
    task = CooperativeTask(cartesian4, "sphere", codegen=False)
    q = np.random.default_rng(3).uniform(-0.2, 0.2, 12)
    np.testing.assert_allclose(task.jacobian(q), _fd_jacobian(task, q), atol=1e-6)
    assert np.all(np.linalg.norm(task.jacobian(q), axis=0) > 1e-3)


def test_a_new_robot_is_collected_and_checked(tmp_path) -> None:
    """Registering a system adds its cases here without editing this file (a hard-coded chain table raised KeyError
    at collection for any new system): a pytest plugin registers two free points, and this module's tests for it
    are collected and pass — the kinds two points span, and the refusal of the others."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    (tmp_path / "temporary_robot.py").write_text(
        "from coop_ga.systems import cartesian_points, register\n\n\n"
        "@register('temporary_robot', 'two free points (a test of tests/cooperative/test_jacobians.py)')\n"
        "def _two_points():\n"
        "    return cartesian_points(2)\n"
    )
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(root), os.environ.get("PYTHONPATH", "")])}
    cmd = [sys.executable, "-m", "pytest", "-p", "temporary_robot", "-p", "no:cacheprovider", "-q"]
    cmd += [str(Path(__file__)), "-k", "temporary_robot and not new_robot"]
    r = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    assert f"{2 * len(KINDS)} passed" in r.stdout, r.stdout[-2000:]
