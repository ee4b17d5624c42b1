"""Shared fixtures and helpers for the coop_ga test suite."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import settings

settings.register_profile("default", max_examples=60, deadline=None)
settings.load_profile("default")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)



@pytest.fixture(scope="session")
def load_system():
    """``load_system(name)``: a registered system, built once per test session (never at import time)."""
    from coop_ga import systems

    cache: dict[str, systems.System] = {}

    def _load(name: str) -> systems.System:
        if name not in cache:
            cache[name] = systems.load(name)
        return cache[name]

    return _load
