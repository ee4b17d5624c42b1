"""The ``mujoco`` module, imported on first use (typed ``Any``: it ships no type information)."""

from __future__ import annotations

import importlib
from typing import Any

from ..errors import CoopGAError

_MODULE: Any = None


def mj() -> Any:
    """The ``mujoco`` module; raises :class:`CoopGAError` naming the extra to install when it is missing."""
    global _MODULE
    if _MODULE is None:
        try:
            _MODULE = importlib.import_module("mujoco")
        except ImportError as e:
            raise CoopGAError(f"coop_ga.sim needs MuJoCo ({e}); install it with: pip install 'coop_ga[sim]'") from e
    return _MODULE
