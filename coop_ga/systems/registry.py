"""The registry of named systems: ``register``, ``names``, ``load``.

The paper's systems are registered by :mod:`coop_ga.systems.library` (imported by
``coop_ga.systems``); users add their own with the :func:`register` decorator.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

from ..errors import InvalidInputError, UnknownNameError
from .system import System

__all__ = ["load", "names", "register"]

_REGISTRY: dict[str, tuple[Callable[[], System], str]] = {}


def register(name: str, description: str = "") -> Callable[[Callable[[], System]], Callable[[], System]]:
    """Decorator registering a zero-argument system builder under ``name`` (a non-empty string)."""
    if not isinstance(name, str) or not name.strip():
        raise InvalidInputError(f"name must be a non-empty string, got {name!r}")
    if not isinstance(description, str):
        raise InvalidInputError(f"description must be a string, got {description!r}")

    def deco(fn: Callable[[], System]) -> Callable[[], System]:
        _REGISTRY[name] = (fn, description)
        return fn

    return deco


def names() -> list[str]:
    """Registered system names."""
    return list(_REGISTRY)


@cache
def _build(name: str) -> System:
    return _REGISTRY[name][0]()


def load(name: str) -> System:
    """Build a registered system (cached per process).

    Raises :class:`UnknownNameError` listing the available names.
    """
    if not isinstance(name, str) or name not in _REGISTRY:
        raise UnknownNameError(f"unknown system name {name!r}. Available systems: {', '.join(names())}")
    return _build(name)
