"""coop_ga.viewer.drawing: every primitive kind is drawn by its own branch, and what is drawn lies on the
primitive (a kind added to coop_ga.geometry.kinds without a drawing branch fails here)."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.geometry.kinds import KIND_SPECS
from coop_ga.viewer.drawing import primitive_geometry


def _moved(kind: str) -> cg.Primitive:
    """The unit primitive's spanning points scaled, rotated and moved off the origin (so no branch is right by
    accident), as a primitive of ``kind``."""
    rng = np.random.default_rng(5)
    spec = KIND_SPECS[kind]
    P = np.array(spec.unit_points) * 0.3 + np.array([0.4, -0.2, 0.7])
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    return cg.primitive_from_points(kind, list(P @ R.T))


@pytest.mark.parametrize("kind", cg.KINDS)
def test_every_kind_is_drawn_on_the_primitive(kind: str) -> None:
    X = _moved(kind)
    g = primitive_geometry(X, anchor=[0.1, 0.2, 0.3], extent=0.5)
    assert g.kind == kind
    drawn = [g.points, g.segments.reshape(-1, 3)] + ([g.quad] if g.quad is not None else [])
    P = np.vstack(drawn)
    assert len(P) >= KIND_SPECS[kind].n_points
    for p in P:  # incidence: P(p) ∧ X = 0 (Eq 2), relative to the size of X
        W = cg.point(p) ^ X
        assert max((abs(float(c)) for c in W.coeffs), default=0.0) < 1e-9 * max(abs(float(c)) for c in X.coeffs)
    if g.sphere is not None:
        assert not KIND_SPECS[kind].flat and KIND_SPECS[kind].dimension == 2
        np.testing.assert_allclose(g.sphere[1], float(cg.radius(X)), rtol=1e-12)
