"""Regression: a circle whose normal is exactly antiparallel to the unit circle's axis at q.

Found by the sweep work: three hexapod feet (lf, rm, lr) at the neutral configuration span a circle with
normal exactly −e3.  Building the task graph then made a rotor whose scalar part is a structural zero,
which the algebra drops, and ``_compose_trd`` refused its 3 coefficients for 4 rotor blades.
"""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.systems import ROBOTS_DIR


@pytest.mark.parametrize("codegen", [False, True])
def test_half_turn_chart_builds_and_reproduces_the_circle(codegen: bool) -> None:
    system = cg.systems.from_urdf(ROBOTS_DIR / "hexapod" / "hexapod.urdf", ["lf_foot", "rm_foot", "lr_foot"])
    task = cg.cooperative_task(system, "circle", codegen=codegen)
    X = task.primitive(system.q0)
    assert np.allclose(cg.normal(X), [0.0, 0.0, -1.0], atol=1e-15)  # the antiparallel case itself
    V = task.similarity(system.q0)
    Y = V.apply(task.unit)
    assert np.allclose(cg.center(Y), cg.center(X), atol=1e-14)
    assert cg.radius(Y) == pytest.approx(cg.radius(X), rel=1e-14)
    assert np.allclose(cg.normal(Y), cg.normal(X), atol=1e-14)
    assert abs(task.log(system.q0)[2]) == pytest.approx(np.pi, abs=1e-12)  # a half-turn about e23
    assert np.isfinite(task.jacobian(system.q0 + 0.01)).all()
