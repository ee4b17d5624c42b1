"""Shared fixtures and helpers for the coop_ga test suite."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

# Hypothesis profiles.  ``default`` is the CI one (modest example counts, fixed seeds: the
# whole suite stays fast and reproducible); ``long`` runs 10 000 examples per property (``long5k``: 5 000), e.g.
# ``python -m pytest tests/fuzz --hypothesis-profile=long``.  The profile is loaded in
# pytest_configure, after the command line is parsed, so ``--hypothesis-profile`` always wins
# (a module-level ``load_profile("default")`` here would override it whenever this conftest
# is imported after the hypothesis plugin has configured itself).
settings.register_profile("default", max_examples=60, deadline=None, derandomize=True)
settings.register_profile(
    "long",
    max_examples=10_000,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
# ``long5k``: the long run at half the length (5 000 examples per property), for a shared 2-core machine
settings.register_profile(
    "long5k",
    max_examples=5_000,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.load_profile("default")


def pytest_configure(config: pytest.Config) -> None:
    settings.load_profile(config.getoption("--hypothesis-profile", default=None) or "default")


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
