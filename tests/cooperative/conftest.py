"""Fixtures for the cooperative layer: a 'Cartesian' system whose end points are base + q.

Each chain is three prismatic joints (x, y, z), so the end points can be placed
anywhere exactly — collinear, coplanar, coincident — to test the degeneracy guards,
and ∂p/∂q = I isolates the similarity part of the Jacobian.
"""

from __future__ import annotations

import pytest

from coop_ga.systems import CARTESIAN_BASES as BASES
from coop_ga.systems import System, cartesian_points

__all__ = ["BASES", "cartesian_system"]


def cartesian_system(n_points: int) -> System:
    return cartesian_points(n_points)


@pytest.fixture(scope="session")
def cartesian4() -> System:
    return cartesian_system(4)
