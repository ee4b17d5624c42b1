"""The registry of named systems: ``register``, ``names``, ``load``.

The paper's systems are registered by :mod:`coop_ga.systems.library` (imported by
``coop_ga.systems``); users add their own with the :func:`register` decorator.

A registered system may have a **free-flyer variant** (its base on a ``JointModelFreeFlyer``: nq ≠ nv), attached
with :func:`register_free_flyer` and built by ``load(name, free_flyer=True)``.  The variants are not names of
their own: :func:`names` lists the fixed-base systems (what loops over every system expect), and
``names(free_flyer=True)`` those that have a variant.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

from ..errors import InvalidInputError, UnknownNameError, UnsupportedJointError
from .system import System

__all__ = ["load", "names", "register", "register_free_flyer"]

_REGISTRY: dict[str, tuple[Callable[[], System], str]] = {}
#: the free-flyer variant of a registered name (nq ≠ nv)
_FREE_FLYER: dict[str, Callable[[], System]] = {}


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


def register_free_flyer(name: str) -> Callable[[Callable[[], System]], Callable[[], System]]:
    """Decorator attaching a zero-argument builder of the free-flyer variant of the registered system ``name``
    (built by ``load(name, free_flyer=True)``; it must have nq ≠ nv)."""
    if not isinstance(name, str) or name not in _REGISTRY:
        raise UnknownNameError(f"register {name!r} before its free-flyer variant. Registered: {', '.join(names())}")

    def deco(fn: Callable[[], System]) -> Callable[[], System]:
        _FREE_FLYER[name] = fn
        return fn

    return deco


def names(free_flyer: bool = False) -> list[str]:
    """Registered system names (fixed-base); with ``free_flyer=True`` those that also have a free-flyer
    variant (:func:`register_free_flyer`)."""
    if not isinstance(free_flyer, bool):
        raise InvalidInputError(f"free_flyer must be True or False, got {free_flyer!r}")
    return [n for n in _REGISTRY if n in _FREE_FLYER] if free_flyer else list(_REGISTRY)


@cache
def _build(name: str, free_flyer: bool = False) -> System:
    s = _FREE_FLYER[name]() if free_flyer else _REGISTRY[name][0]()
    if free_flyer and s.nq == s.nv:
        raise InvalidInputError(f"the free-flyer variant of {name!r} has nq = nv = {s.nq}: it has no free flyer")
    return s


def load(name: str, free_flyer: bool = False) -> System:
    """Build a registered system (cached per process); ``free_flyer=True``: its free-flyer variant (the base on a
    ``JointModelFreeFlyer``, nq ≠ nv; e.g. ``load("g1_arms", free_flyer=True)``, the floating G1).

    Raises :class:`UnknownNameError` listing the available names, :class:`UnsupportedJointError` when the system
    has no free-flyer variant (naming those that have one).
    """
    if not isinstance(name, str) or name not in _REGISTRY:
        raise UnknownNameError(f"unknown system name {name!r}. Available systems: {', '.join(names())}")
    if not isinstance(free_flyer, bool):
        raise InvalidInputError(f"free_flyer must be True or False, got {free_flyer!r}")
    if free_flyer and name not in _FREE_FLYER:
        raise UnsupportedJointError(
            f"system {name!r} has no free-flyer variant; these have one: {', '.join(names(free_flyer=True))} "
            "(or build one with coop_ga.systems.from_urdf(..., free_flyer=True))"
        )
    return _build(name, free_flyer)
