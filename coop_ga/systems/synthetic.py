"""Synthetic systems whose end points are free: each chain is three prismatic joints (x, y, z).

The end point of chain ``i`` is ``bases[i] + q[3i:3i+3]`` [m] in the world frame, so
``∂p/∂q = I``: the points can be placed anywhere exactly (collinear, coplanar, on the unit
primitive), and the cooperative Jacobian of such a system *is* the similarity part of
``J^G`` (Eq 30).  Table 1 is measured on it (``experiments/table1.py``), and the tests
of the degeneracy guards use it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .system import System

__all__ = ["CARTESIAN_BASES", "cartesian_points"]

#: default chain bases [m]: three points of the unit circle in the xy plane, then e3.
CARTESIAN_BASES = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def cartesian_points(n_points: int, bases: Any = None, limit: float = 5.0) -> System:
    """A :class:`System` of ``n_points`` free points (3 prismatic joints each, nq = 3 n).

    Args:
        n_points: number of chains, 1 … len(bases).
        bases: (n_points, 3) [m] the end points at q = 0 (default :data:`CARTESIAN_BASES`).
        limit: joint range ±limit [m].

    The system is named ``cartesian<n>``, its end frames ``tip0 … tip<n-1>``, q0 = 0.
    """
    import pinocchio as pin

    from .. import validation
    from ..errors import InvalidInputError

    B = validation.array(CARTESIAN_BASES if bases is None else bases, "bases [m]")
    if B.ndim != 2 or B.shape[1] != 3:
        raise InvalidInputError(f"bases must have shape (k, 3) [m] (one base point per chain), got shape {B.shape}")
    n_points = validation.integer(n_points, "n_points")
    if not 1 <= n_points <= len(B):
        raise InvalidInputError(
            f"cartesian_points needs 1 ≤ n_points ≤ {len(B)} (one base per chain), got {n_points}: pass more bases"
        )
    limit = validation.positive(limit, "limit [m]")
    m = pin.Model()
    frames = []
    for i in range(n_points):
        parent = 0
        for k, jm in enumerate((pin.JointModelPX(), pin.JointModelPY(), pin.JointModelPZ())):
            pl = pin.SE3(np.eye(3), B[i]) if k == 0 else pin.SE3.Identity()
            parent = m.addJoint(parent, jm, pl, f"c{i}_p{'xyz'[k]}")
        name = f"tip{i}"
        m.addFrame(pin.Frame(name, parent, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
        frames.append(name)
    m.lowerPositionLimit = -limit * np.ones(m.nq)
    m.upperPositionLimit = limit * np.ones(m.nq)
    return System(name=f"cartesian{n_points}", model=m, end_frames=tuple(frames), q0=np.zeros(m.nq))
