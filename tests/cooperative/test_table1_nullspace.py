"""Table 1 on a robot (rank of J^G = the primitive's DOF), manipulability (Eq 59) and nullspace (Eq 58)."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import systems
from coop_ga.cooperative import (
    CooperativeTask,
    damped_pinv,
    force_manipulability,
    manipulability,
    manipulability_ellipsoid,
    manipulability_index,
    nullspace_projector,
)
from coop_ga.geometry import KIND_SPECS

# The DOF column and the blade sets of Table 1 are facts of the kind table, checked kind by kind against J^G in
# tests/cooperative/test_kinds.py; here the rank on a robot, manipulability and the nullspace.


@pytest.mark.parametrize("name,kind", [("three_franka", k) for k in ("point", "point_pair", "line", "circle", "plane")])
def test_rank_on_robots(name: str, kind: str) -> None:
    sys = systems.load(name)
    task = CooperativeTask(sys, kind, codegen=False)
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = np.clip(sys.q0 + rng.uniform(-0.3, 0.3, sys.nq), sys.q_lower, sys.q_upper)
        assert np.linalg.matrix_rank(task.jacobian(q), tol=1e-8) == KIND_SPECS[kind].dof


def test_table1_controllable_space_is_not_a_coordinate_subspace(cartesian4) -> None:
    """Table 1 lists coordinate blades (e.g. circle: e13, e23, e0∞, e1∞, e2∞, e3∞).  The range of
    J^G has that *dimension*, but in general it is not spanned by those blades: the minimal-rotation
    chart couples roll (e12) into tilts.  At the unit circle itself the paper's claim holds exactly."""
    task = CooperativeTask(cartesian4, "circle", codegen=False)
    # points on the unit circle: X_c = X_u, V_Sc = 1
    q_unit = np.zeros(cartesian4.nq)
    J = task.jacobian(q_unit)
    assert np.abs(J[0]).max() < 1e-12  # no e12 (roll) row at the unit circle: Table 1 holds
    q = np.random.default_rng(2).uniform(-0.4, 0.4, cartesian4.nq)
    J = task.jacobian(q)
    assert np.abs(J[0]).max() > 1e-3  # elsewhere the e12 row is non-zero, rank still 6
    assert np.linalg.matrix_rank(J, tol=1e-8) == 6


def test_nullspace_motion_leaves_vsc_unchanged_to_first_order() -> None:
    sys = systems.load("three_franka")
    task = CooperativeTask(sys, "circle", codegen=False)
    rng = np.random.default_rng(0)
    q = np.clip(sys.q0 + rng.uniform(-0.3, 0.3, sys.nq), sys.q_lower, sys.q_upper)
    J = task.jacobian(q)
    N = nullspace_projector(J)
    v = rng.normal(size=sys.nq)
    w = N @ v
    assert np.linalg.norm(w) > 0.5  # the nullspace is large (21 − 6 = 15 dimensions)
    np.testing.assert_allclose(J @ w, 0.0, atol=1e-12)
    V0 = task.similarity(q)
    d1 = np.linalg.norm(cg.geometry.log(~V0 * task.similarity(q + 1e-3 * w)))
    d2 = np.linalg.norm(cg.geometry.log(~V0 * task.similarity(q + 2e-3 * w)))
    assert d1 < 1e-5 and d2 / d1 == pytest.approx(4.0, rel=0.05)  # second order in the step
    # an unprojected motion moves V_Sc to first order
    d_free = np.linalg.norm(cg.geometry.log(~V0 * task.similarity(q + 1e-3 * v)))
    assert d_free > 100 * d1


def test_damped_pinv_and_manipulability() -> None:
    rng = np.random.default_rng(1)
    J = rng.normal(size=(7, 21))
    J[0] = 0.0  # rank 6, like a circle
    Jp = damped_pinv(J, 0.0)
    np.testing.assert_allclose(J @ Jp @ J, J, atol=1e-10)
    Jd = damped_pinv(J, 1e-3)
    np.testing.assert_allclose(Jd, J.T @ np.linalg.inv(J @ J.T + 1e-6 * np.eye(7)), atol=1e-8)
    M = manipulability(J)
    np.testing.assert_allclose(M, J @ J.T)
    w, _Q = manipulability_ellipsoid(J)
    assert w[0] == pytest.approx(0.0, abs=1e-10) and np.all(w[1:] > 0)
    Mi = force_manipulability(J)
    np.testing.assert_allclose(M @ Mi @ M, M, atol=1e-8)
    s = np.linalg.svd(J, compute_uv=False)
    assert manipulability_index(J) == pytest.approx(np.prod(s[:6]))
    N = nullspace_projector(J, 0.0)
    np.testing.assert_allclose(N @ N, N, atol=1e-10)
    with pytest.raises(cg.NonFiniteError):
        damped_pinv(np.full((7, 3), np.nan))
    with pytest.raises(cg.InvalidInputError):
        damped_pinv(J, -1.0)


def test_manipulability_ellipsoid_resolves_eigenvalues_eigh_loses() -> None:
    """Singular values 1e6 … 1e-6: eigh(J Jᵀ) returns noise ~1e-4 for λ = 1e-12, the SVD route the value."""
    rng = np.random.default_rng(3)
    U, _ = np.linalg.qr(rng.normal(size=(7, 7)))
    V, _ = np.linalg.qr(rng.normal(size=(21, 21)))
    s = np.array([0.0, 1e-6, 1e-3, 1.0, 2.0, 1e3, 1e6])
    J = U @ np.diag(s) @ V[:7]
    w, Q = manipulability_ellipsoid(J)
    # SVD: σ to ~1e-16 σ_max = 1e-10 absolute, so λ = σ² = 1e-12 to ~2e-4 relative
    np.testing.assert_allclose(w[1:], np.sort(s**2)[1:], rtol=1e-3)
    assert w[0] < 1e-18
    np.testing.assert_allclose(Q.T @ Q, np.eye(7), atol=1e-12)
    assert abs(np.linalg.eigvalsh(J @ J.T)[1] - 1e-12) > 1e-10  # eigh is off by far more than the value
