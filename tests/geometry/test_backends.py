"""One algebra, two backends: numpy floats and CasADi SX give the same numbers."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import coop_ga as cg
from coop_ga.geometry import N_POINTS


@pytest.mark.parametrize("kind", cg.KINDS)
def test_similarity_pipeline_symbolic_equals_numeric(kind):
    n = N_POINTS[kind]
    x = ca.SX.sym("x", 3 * n)
    X = cg.primitive_from_points(kind, [x[3 * i : 3 * i + 3] for i in range(n)])
    V = cg.geometry.similarity_from_unit(X)
    b = cg.geometry.log(V)
    outs = [b]
    if kind in ("point_pair", "circle", "sphere"):
        outs += [cg.center(X), cg.radius(X)]
    f = ca.Function("f", [x], outs)
    rng = np.random.default_rng(7)
    for _ in range(20):
        pts = rng.normal(size=(n, 3))
        Xn = cg.primitive_from_points(kind, list(pts))
        got = [np.array(o).ravel() for o in f(pts.ravel())] if len(outs) > 1 else [np.array(f(pts.ravel())).ravel()]
        np.testing.assert_allclose(got[0], cg.geometry.log(cg.geometry.similarity_from_unit(Xn)), atol=1e-12)
        if len(outs) > 1:
            np.testing.assert_allclose(got[1], cg.center(Xn), atol=1e-12)
            np.testing.assert_allclose(got[2], cg.radius(Xn), atol=1e-12)


def test_exp_log_symbolic_equals_numeric_and_derivative_finite_at_zero():
    b = ca.SX.sym("b", 7)
    V = cg.geometry.exp(b)
    f = ca.Function("f", [b], [ca.vertcat(*V.coeffs), cg.geometry.log(V)])
    J = ca.Function("J", [b], [ca.jacobian(cg.geometry.log(V), b)])
    rng = np.random.default_rng(1)
    for v in [np.zeros(7), rng.normal(size=7), 1e-9 * rng.normal(size=7)]:
        coeffs, lg = f(v)
        np.testing.assert_allclose(np.array(coeffs).ravel(), np.array(cg.geometry.exp(v).coeffs), atol=1e-14)
        np.testing.assert_allclose(np.array(lg).ravel(), v, atol=1e-12)
        Jv = np.array(J(v))
        assert np.all(np.isfinite(Jv))
        np.testing.assert_allclose(Jv, np.eye(7), atol=1e-7)  # log∘exp = id ⇒ identity derivative
