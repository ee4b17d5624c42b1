"""Fixtures for the cooperative layer: a 'Cartesian' system whose end points are base + q.

Each chain is three prismatic joints (x, y, z), so the end points can be placed
anywhere exactly — collinear, coplanar, coincident — to test the degeneracy guards,
and ∂p/∂q = I isolates the similarity part of the Jacobian.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from coop_ga.systems import System

BASES = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def cartesian_system(n_points: int) -> System:
    m = pin.Model()
    frames = []
    for i in range(n_points):
        parent = 0
        for k, jm in enumerate((pin.JointModelPX(), pin.JointModelPY(), pin.JointModelPZ())):
            pl = pin.SE3(np.eye(3), BASES[i]) if k == 0 else pin.SE3.Identity()
            parent = m.addJoint(parent, jm, pl, f"c{i}_p{'xyz'[k]}")
            m.lowerPositionLimit[-1:] = -5.0
            m.upperPositionLimit[-1:] = 5.0
        name = f"tip{i}"
        m.addFrame(pin.Frame(name, parent, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
        frames.append(name)
    m.lowerPositionLimit = -5.0 * np.ones(m.nq)
    m.upperPositionLimit = 5.0 * np.ones(m.nq)
    return System(name=f"cartesian{n_points}", model=m, end_frames=tuple(frames), q0=np.zeros(m.nq))


@pytest.fixture(scope="session")
def cartesian4() -> System:
    return cartesian_system(4)
