"""Planar motors of G(4,1): the SE(2) subgroup that moves the plane z = 0 (seed 004, §3.1, §3.3).

A rigid motion of the plane is a motor of coop_ga's algebra restricted to the four blades
``1, e12, e1∞, e2∞`` (the 8-blade motor of Eq 70–73 with every e3 part zero), so linkages
reuse the algebra of the cooperative code, on numpy and on CasADi SX alike.

Conventions (those of :mod:`coop_ga.geometry.groups`): a rotation by θ about the origin is
``R = cos(θ/2) − sin(θ/2) e12`` (it turns e1 toward e2), a translation by t is
``T = 1 − ½ t e∞``, a point is ``up(p) = e0 + p + ½|p|² e∞`` (seed 004 §3.1) and moves by the
sandwich ``M up(p) M̃``.

The Lie algebra (seed 004 §3.3)
-------------------------------
A planar twist ξ = (ω, v1, v2) — angular velocity [rad] and linear velocity [m] — is the
bivector ``B = −½(ω e12 + v1 e1∞ + v2 e2∞)``.  Because e12 anticommutes with e1, e2 and
commutes with e∞, ``B² = −ω²/4`` is a scalar, so the exponential has the closed form

    exp(B) = cos(ω/2) + sinc(ω/2) B,        sinc(x) = sin(x)/x                   (1)

(the screw motion: a rotation by ω about a centre, or a translation by v when ω = 0).

**Seed 004 errors (§3.3):** the seed's basis ``{e1∧e2, e1∧e0, e2∧e0}`` generates rotations
and *transversions* (e0 is the origin; e1∧e0 moves the point at infinity, not the origin): the
translation generators are e1∧e∞ and e2∧e∞.  And its crank update
``R = exp(tθ e12) R`` rotates about the origin by −2tθ, not about the crank pivot: the
crank here is ``T(c) R(φ) T(−c)`` about its pivot c (:func:`rotation_about`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import validation
from ..algebra import backend as bk
from ..algebra.multivector import Multivector
from ..errors import InvalidInputError

__all__ = [
    "PLANAR_BLADES",
    "apply_point",
    "compose",
    "motor",
    "motor_exp",
    "motor_pose",
    "rotation_about",
    "up",
]

#: blade names of a planar motor's coefficients, in the order of the 4-vectors used here
PLANAR_BLADES = ("1", "e12", "e1inf", "e2inf")


def _coords(x: Any, n: int, what: str) -> Any:
    """``x`` with ``n`` entries: numbers are checked (:func:`coop_ga.validation.vector`: finite, real), CasADi
    expressions (or sequences holding one) pass as they are — these functions also build CasADi graphs."""
    if bk.is_symbolic(x):
        if x.numel() != n:
            raise InvalidInputError(f"{what} must have {n} entries, got a CasADi expression of shape {x.shape}")
        return x
    if isinstance(x, (list, tuple)) and any(bk.is_symbolic(v) for v in x):
        if len(x) != n:
            raise InvalidInputError(f"{what} must have {n} entries, got {len(x)}")
        return x
    a = validation.vector(x, n, what)
    if a.size and float(np.max(np.abs(a))) > _MAX:
        raise InvalidInputError(f"{what} has an entry of {float(np.max(np.abs(a))):.3g}, beyond ±{_MAX:g}")
    return a


def _angle(x: Any, what: str) -> Any:
    return x if bk.is_symbolic(x) else validation.scalar(x, what, low=-_MAX, high=_MAX)


#: numeric entries beyond this are refused: the products of the motor algebra must not overflow
_MAX = 1e75


def _mv(m: Any) -> Multivector:
    return Multivector.from_names({name: m[i] for i, name in enumerate(PLANAR_BLADES)})


def _coeffs(M: Multivector) -> list[Any]:
    return [M[name] for name in PLANAR_BLADES]


def up(p: Any) -> Multivector:
    """The conformal point ``e0 + p + ½|p|² e∞`` of a planar point ``p`` (2,) [m]."""
    p = _coords(p, 2, "p")
    x, y = p[0], p[1]
    return Multivector.from_names({"e0": 1.0, "e1": x, "e2": y, "einf": 0.5 * (x * x + y * y)})


def _sinc(x: Any) -> Any:
    # the Taylor branch keeps values and derivatives finite at ω = 0 on CasADi too
    small = bk.fabs(x) < 1e-4
    safe = bk.where(small, 1.0, x)
    return bk.where(small, 1.0 - x * x / 6.0 + x**4 / 120.0, bk.sin(safe) / safe)


def motor_exp(xi: Any) -> list[Any]:
    """exp of the twist ξ = (ω [rad], v1, v2 [m]) as planar motor coefficients (4,), Eq (1)."""
    xi = _coords(xi, 3, "xi")
    w, v1, v2 = xi[0], xi[1], xi[2]
    c = bk.cos(0.5 * w)
    k = -0.5 * _sinc(0.5 * w)
    return [c, k * w, k * v1, k * v2]


def motor(angle: Any, translation: Any) -> list[Any]:
    """Coefficients (4,) of ``T(t) R(θ)``: rotate by ``angle`` [rad] about the origin, then translate [m]."""
    angle = _angle(angle, "angle")
    translation = _coords(translation, 2, "translation")
    c, s = bk.cos(0.5 * angle), bk.sin(0.5 * angle)
    t1, t2 = translation[0], translation[1]
    # (1 − ½ t e∞)(c − s e12) = c − s e12 − ½(c t1 + s t2) e1∞ − ½(c t2 − s t1) e2∞
    return [c, -s, -0.5 * (c * t1 + s * t2), -0.5 * (c * t2 - s * t1)]


def rotation_about(center: Any, angle: Any) -> list[Any]:
    """Coefficients of the rotation by ``angle`` [rad] about the planar point ``center`` [m]."""
    angle = _angle(angle, "angle")
    center = _coords(center, 2, "center")
    c, s = bk.cos(0.5 * angle), bk.sin(0.5 * angle)
    # T(c) R T(−c): the translation part is c − R c
    cx, cy = center[0], center[1]
    ca, sa = bk.cos(angle), bk.sin(angle)
    t = (cx - (ca * cx - sa * cy), cy - (sa * cx + ca * cy))
    return [c, -s, -0.5 * (c * t[0] + s * t[1]), -0.5 * (c * t[1] - s * t[0])]


def compose(a: Any, b: Any) -> list[Any]:
    """Coefficients of the geometric product ``A B`` of two planar motors (apply B first)."""
    return _coeffs(_mv(_coords(a, 4, "a")) * _mv(_coords(b, 4, "b")))


def apply_point(m: Any, p: Any) -> tuple[Any, Any]:
    """The planar point ``p`` (2,) moved by the motor ``m`` (4,): Euclidean part of ``M up(p) M̃``.

    Raises :class:`~coop_ga.errors.InvalidInputError` for a numeric motor with a zero rotation part
    (c = s = 0: no rigid motion)."""
    m = _coords(m, 4, "m")
    if not bk.is_symbolic(m) and not any(bk.is_symbolic(v) for v in m) and not np.hypot(m[0], m[1]) > 1e-12:
        raise InvalidInputError(f"m = {list(m)} is no planar motor: its rotation part (c, s) is zero")
    M = _mv(m)
    X = M * up(p) * M.reverse()
    w = X["e0"]  # 1 for a unit motor; divided out so a slightly unnormalised motor still gives a point
    x, y = X["e1"] / w, X["e2"] / w
    if not bk.is_symbolic(x) and not (np.isfinite(x) and np.isfinite(y)):
        raise InvalidInputError(f"moving p by m overflows (m = {list(m)}, p = {list(p)}); rescale the linkage")
    return x, y


def motor_pose(m: Any) -> tuple[float, float, float]:
    """(θ [rad] in (−π, π], x, y [m]) of a numeric planar motor: ``M = T(x, y) R(θ)``."""
    m = validation.vector(m, 4, "m (planar motor coefficients)")
    c, s = float(m[0]), float(m[1])
    theta = 2.0 * np.arctan2(-s, c)
    theta = float(np.arctan2(np.sin(theta), np.cos(theta)))
    x, y = apply_point(m, (0.0, 0.0))
    return theta, float(x), float(y)
