"""Versor groups of CGA (paper Appendix A): rotors, translators, dilators, motors, similarities.

Tangent coordinates
-------------------
A similarity bivector is the 7-vector ``b = [θ12, θ13, θ23, β, t1, t2, t3]`` on the
basis ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``; Jacobian rows follow this order.
Subgroups use the matching sub-vectors (rotor ``[θ12, θ13, θ23]``, translator
``[t1, t2, t3]``, dilator ``[β]``, motor ``[θ12, θ13, θ23, t1, t2, t3]``).

The exponential is the paper's canonical decomposition (Eq 72, 76)::

    exp(b) = V_T V_R V_D,   V_T = 1 − ½ t e∞                       (Eq 64, 66)
                            V_R = cos(φ/2) − sin(φ/2) θ̂·[e12,e13,e23] (Eq 62), φ = |θ|
                            V_D = cosh(β/2) + sinh(β/2) e0∞

and ``log`` is its inverse (Eq 73, 77).  The behaviour this gives, and that users rely on:

* ``t`` on e1∞, e2∞, e3∞ translates by **+t**;
* ``θ`` on e12 rotates by **+θ about +z** (e1 → e2); θ on e23 rotates e2 → e3
  (+θ about +x); θ on e13 rotates e1 → e3 (that is −θ about +y);
* ``β`` on e0∞ scales by **e^β** about the origin.

The sign of the dilator differs from Eq 67 as printed (``cosh − sinh e0∞``): with
``e0 = ½(e5 − e4)``, ``e∞ = e4 + e5`` that versor scales by ``e^{−β}``, the inverse of
what Fig. 21 reports (a command of −1 on e0∞ closes the hand, d = e⁻¹ = 0.3679).  We
keep the paper's *behaviour* (Fig. 21) and flip the internal sign; the check is
``tests/geometry/test_groups.py::test_dilation_scales_by_exp_beta``.

log is exact near zero rotation (series expansions, no 0/0) and returns the
*shortest* rotation, angle in [0, π]; a rotor with negative scalar part is negated
first (the same rotation, the other sheet of the double cover), so ``exp(log V)``
equals V up to that sign.  At exactly π the axis is whatever the versor encodes.
Every formula also runs on CasADi SX, with branches as ``if_else``.
"""

from __future__ import annotations

import abc
from functools import lru_cache
from typing import Any, ClassVar

import numpy as np

from ..algebra import backend as B
from ..algebra.basis import blade_index, blade_name
from ..algebra.multivector import Multivector
from ..errors import InvalidInputError, InvalidVersorError, NonFiniteError

__all__ = [
    "TANGENT_BASIS",
    "SIMILARITY_BLADES",
    "MOTOR_BLADES",
    "exp",
    "log",
    "log_jacobian",
    "apply",
    "VersorGroup",
    "Rotor",
    "Translator",
    "Dilator",
    "Motor",
    "Similarity",
    "decompose",
    "tangent_to_bivector",
    "bivector_to_tangent",
    "motor_rotor_translation",
    "rotor_matrix",
    "rotor_from_matrix",
]

TANGENT_BASIS = ("e12", "e13", "e23", "e0∞", "e1∞", "e2∞", "e3∞")


def _b(name: str) -> int:
    return blade_index(name)[0]


_S, _E12, _E13, _E23 = 0, _b("e12"), _b("e13"), _b("e23")
_E0I = _b("e0inf")
_E012I, _E013I, _E023I = _b("e012inf"), _b("e013inf"), _b("e023inf")
_E1I, _E2I, _E3I, _E123I = _b("e1inf"), _b("e2inf"), _b("e3inf"), _b("e123inf")
_E1, _E2, _E3, _E123 = _b("e1"), _b("e2"), _b("e3"), _b("e123")

ROTOR_BLADES = (_S, _E12, _E13, _E23)
TRANSLATOR_BLADES = tuple(sorted((_S, _E1I, _E2I, _E3I)))
DILATOR_BLADES = (_S, _E0I)
MOTOR_BLADES = tuple(sorted(ROTOR_BLADES + (_E1I, _E2I, _E3I, _E123I)))
SIMILARITY_BLADES = tuple(sorted(MOTOR_BLADES + (_E0I, _E012I, _E013I, _E023I)))

_SMALL_ANGLE = 1e-3  # below this, series expansions (errors < 1e-16)


# ---------------------------------------------------------------------- helpers
def _tangent(b: Any, n: int, name: str) -> tuple[Any, ...]:
    if B.is_symbolic(b):
        if b.numel() != n:
            raise InvalidInputError(f"{name} tangent must have {n} entries, got a CasADi expression of shape {b.shape}")
        return tuple(b[i] for i in range(n))
    if isinstance(b, (list, tuple)) and len(b) == n and any(B.is_symbolic(v) for v in b):
        return tuple(b)
    a = np.asarray(b, dtype=float)
    if a.shape[-1:] != (n,) or a.ndim > 2:
        raise InvalidInputError(f"{name} tangent must have shape ({n},) (or (N, {n})), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name} tangent contains NaN or inf: {a.tolist()}")
    if a.ndim == 1:
        return tuple(float(v) for v in a)
    return tuple(a[:, i].copy() for i in range(n))


def _stack(vals: tuple[Any, ...]) -> Any:
    if any(B.is_symbolic(v) for v in vals):
        import casadi as ca

        return ca.vertcat(*vals)
    return np.stack(np.broadcast_arrays(*[np.asarray(v, dtype=float) for v in vals]), axis=-1)


def _sin_half_over(phi2: Any) -> Any:
    """sin(φ/2)/φ as a function of φ², exact through φ = 0."""
    small = phi2 < _SMALL_ANGLE**2
    phi_safe = B.sqrt(B.where(small, 1.0, phi2))
    return B.where(small, 0.5 - phi2 / 48.0, B.sin(0.5 * phi_safe) / phi_safe)


def _cos_half(phi2: Any) -> Any:
    """cos(φ/2) as a function of φ², with a finite derivative at φ = 0."""
    small = phi2 < _SMALL_ANGLE**2
    phi_safe = B.sqrt(B.where(small, 1.0, phi2))
    return B.where(small, 1.0 - phi2 / 8.0, B.cos(0.5 * phi_safe))


def _atan_over(n2: Any, w: Any) -> Any:
    """atan2(n, w)/n for w ≥ 0, exact through n = 0 (w > 0 there)."""
    small = n2 < (_SMALL_ANGLE**2) * w * w
    n_safe = B.sqrt(B.where(small, 1.0, n2))
    w_safe = B.where(small, w, 1.0)
    return B.where(small, 1.0 / w_safe - n2 / (3.0 * w_safe * w_safe * w_safe), B.atan2(n_safe, w) / n_safe)


# ---------------------------------------------------------------------- exp
def _exp_parts(theta, beta, t) -> Multivector:
    th12, th13, th23 = theta
    phi2 = th12 * th12 + th13 * th13 + th23 * th23
    k = _sin_half_over(phi2)
    r0 = _cos_half(phi2)
    r = (r0, -k * th12, -k * th13, -k * th23)
    c = B.cosh(0.5 * beta)
    s = B.sinh(0.5 * beta)
    # V = c R + s R e0∞ − ½ (c − s) (t R) e∞   (derivation in the module docstring of decompose)
    R = Multivector(ROTOR_BLADES, r)
    tR = Multivector((_E1, _E2, _E3), t) * R  # odd Euclidean: e1, e2, e3, e123
    h = -0.5 * (c - s)
    d: dict[int, Any] = {}
    for blade, rv in zip(ROTOR_BLADES, r):
        d[blade] = c * rv
        d[blade | 0b10001] = s * rv  # e_ij -> e0ij∞, 1 -> e0∞
    for blade, v in zip(tR.blades, tR.coeffs):
        d[blade | 0b10000] = h * v  # e_k -> e_k∞, e123 -> e123∞
    return Multivector.from_dict(d).with_blades(SIMILARITY_BLADES)


def exp(b: Any) -> Multivector:
    """Similarity versor ``V_T V_R V_D`` of the 7-vector ``b = [θ12, θ13, θ23, β, t1, t2, t3]`` (Eq 76).

    Units: θ [rad], β [dimensionless, scale factor e^β], t [m].  Returns a
    :class:`Multivector` on the 12 similarity blades.  Accepts (7,), (N, 7) or CasADi.
    """
    v = _tangent(b, 7, "similarity")
    return _exp_parts(v[0:3], v[3], v[4:7])


# ---------------------------------------------------------------------- log / decompose
def _coeffs(V: Multivector, blades) -> tuple[Any, ...]:
    return tuple(V.get(k) for k in blades)


def _validate_similarity(V: Multivector, what: str = "versor") -> None:
    if not isinstance(V, Multivector):
        raise InvalidInputError(f"{what} must be a coop_ga Multivector, got {type(V).__name__}")
    if V.is_symbolic:
        return
    V.check_finite(what)
    allowed = set(SIMILARITY_BLADES)
    scale = max([float(np.max(np.abs(c))) for c in V.coeffs] + [0.0])
    if scale == 0.0:
        raise InvalidVersorError(f"{what} is zero; a zero-norm versor has no logarithm (did a normalisation underflow?)")
    for k, c in zip(V.blades, V.coeffs):
        if k not in allowed and float(np.max(np.abs(c))) > 1e-9 * scale:
            raise InvalidVersorError(
                f"{what} has a {blade_name(k)} component ({float(np.max(np.abs(c))):.3g}); it is not a similarity "
                "versor (translator·rotor·dilator), e.g. it contains a transversion or a reflection"
            )


def _decompose_coeffs(V: Multivector):
    """Return (R (4 coeffs, unit), beta, t (3)) with V ∝ T(t) R D(β)."""
    A = _coeffs(V, ROTOR_BLADES)  # λ c R
    Bq = _coeffs(V, (_E0I, _E012I, _E013I, _E023I))  # λ s R
    C = _coeffs(V, (_E1I, _E2I, _E3I, _E123I))  # −½ λ (c − s) (t R)
    a2 = A[0] * A[0] + A[1] * A[1] + A[2] * A[2] + A[3] * A[3]
    if not B.any_symbolic(*A):
        if np.any(np.asarray(a2) <= 1e-24 * max(1.0, float(np.max([np.max(np.abs(x)) for x in Bq + C])) ** 2)):
            raise InvalidVersorError(
                "the versor has no rotor part (scalar and e12, e13, e23 are all zero): zero norm or not a "
                "similarity versor"
            )
    an = B.sqrt(a2)  # λ c  (c = cosh ≥ 1, λ > 0 by choice of the sign of R)
    R = tuple(x / an for x in A)
    ls = Bq[0] * R[0] + Bq[1] * R[1] + Bq[2] * R[2] + Bq[3] * R[3]  # λ s
    cm = an - ls  # λ (c − s) > 0
    if not B.any_symbolic(cm, an):
        if np.any(np.asarray(cm) <= 0) or np.any(np.asarray(an + ls) <= 0):
            raise InvalidVersorError("the versor's dilation part is not a valid dilator (|sinh| ≥ cosh)")
        resid = [b - ls * r for b, r in zip(Bq, R)]
        scale = float(np.max(np.abs(an)))
        if max(float(np.max(np.abs(x))) for x in resid) > 1e-6 * scale:
            raise InvalidVersorError(
                "the versor's e0∞-parts are not aligned with its rotor part; it is not a similarity versor"
            )
    beta = B.log((an + ls) / cm)
    tRv = tuple(-2.0 * x / cm for x in C)  # t R as (e1, e2, e3, e123)
    tR = Multivector((_E1, _E2, _E3, _E123), tRv)
    tt = tR * Multivector(ROTOR_BLADES, (R[0], -R[1], -R[2], -R[3]))
    t = (tt.get(_E1), tt.get(_E2), tt.get(_E3))
    if not B.any_symbolic(*t):
        tri = tt.get(_E123)
        if np.any(np.abs(np.asarray(tri)) > 1e-6 * (1.0 + np.sqrt(sum(np.asarray(x) ** 2 for x in t)))):
            raise InvalidVersorError("the versor's e∞-parts are inconsistent with its rotor; not a similarity versor")
    return R, beta, t


def _rotor_log(R: tuple[Any, Any, Any, Any]) -> tuple[Any, Any, Any]:
    w, b12, b13, b23 = R
    sign = B.where(w < 0, -1.0, 1.0)
    w = sign * w
    b12, b13, b23 = sign * b12, sign * b13, sign * b23
    n2 = b12 * b12 + b13 * b13 + b23 * b23
    k = -2.0 * _atan_over(n2, w)
    return k * b12, k * b13, k * b23


def log(V: Any) -> Any:
    """Similarity bivector ``[θ12, θ13, θ23, β, t1, t2, t3]`` of a similarity versor (Eq 77).

    ``V`` may be any positive multiple of a versor (it is normalised).  Raises
    :class:`InvalidVersorError` for zero-norm input or multivectors outside the group.
    ``log(~V1 * V2)`` is the relative similarity expressed in V1's frame.
    """
    if isinstance(V, VersorGroup):
        V = V.versor
    _validate_similarity(V)
    R, beta, t = _decompose_coeffs(V)
    th = _rotor_log(R)
    return _stack((th[0], th[1], th[2], beta, t[0], t[1], t[2]))


def decompose(V: Multivector) -> tuple[Multivector, Multivector, Multivector]:
    """Canonical decomposition V ∝ V_T V_R V_D (Eq 18/74) into normalised factors.

    Derivation: with ``V_R = R``, ``V_D = c + s e0∞`` and ``V_T = 1 − ½ t e∞`` one
    finds ``V_T V_R V_D = c R + s R e0∞ − ½ (c − s) t R e∞`` because ``e∞ e0∞ = −e∞``.
    The e0/e∞-free part gives ``cR``, the e0∞ part ``sR``, the e∞ part ``t``.
    """
    _validate_similarity(V)
    R, beta, t = _decompose_coeffs(V)
    zero = 0.0 * beta
    VT = _exp_parts((zero, zero, zero), zero, t).project(TRANSLATOR_BLADES)
    VR = Multivector(ROTOR_BLADES, R)
    VD = Multivector(DILATOR_BLADES, (B.cosh(0.5 * beta), B.sinh(0.5 * beta)))
    return VT, VR, VD


@lru_cache(maxsize=1)
def _log_jac_fn():
    import casadi as ca

    v = ca.SX.sym("V", len(SIMILARITY_BLADES))
    mv = Multivector(SIMILARITY_BLADES, tuple(v[i] for i in range(len(SIMILARITY_BLADES))))
    out = log(mv)
    return ca.Function("log_jacobian", [v], [ca.jacobian(out, v)])


def log_jacobian(V: Multivector) -> np.ndarray:
    """J_{S→B} (Eq 31): derivative of ``log`` w.r.t. the 12 versor coefficients, shape (7, 12).

    Columns follow :data:`SIMILARITY_BLADES` (scalar, then blades by bitmask); rows
    follow :data:`TANGENT_BASIS`.  Computed by CasADi AD of the same ``log`` source.
    """
    _validate_similarity(V)
    x = np.array([float(V.get(k)) for k in SIMILARITY_BLADES])
    return np.array(_log_jac_fn()(x))


def apply(V: Any, X: Multivector) -> Multivector:
    """Sandwich ``V X Ṽ`` (Eq 6), projected to the grades of X; keeps a primitive's kind tag.

    V may be a versor Multivector or a :class:`VersorGroup` element.
    """
    from .primitives import Primitive

    if isinstance(V, VersorGroup):
        V = V.versor
    if not isinstance(V, Multivector) or not isinstance(X, Multivector):
        raise InvalidInputError("apply(V, X) needs two Multivectors (or a group element and a Multivector)")
    if not V.is_symbolic:
        V.check_finite("versor")
    if not X.is_symbolic:
        X.check_finite("primitive")
    Y = (V * X * V.reverse()).grade(*X.grades)
    if isinstance(X, Primitive):
        return Primitive.tag(Y, X.kind)
    return Y


# ---------------------------------------------------------------------- bivectors <-> 7-vectors
_TANGENT_BLADES = (_E12, _E13, _E23, _E0I, _E1I, _E2I, _E3I)
_TANGENT_SIGNS = (1.0, 1.0, 1.0, -1.0, 1.0, 1.0, 1.0)


def tangent_to_bivector(b: Any) -> Multivector:
    """The bivector B with ``exp(ε b) = 1 − ½ ε B + O(ε²)`` (note the dilation slot: B ∋ −β e0∞)."""
    v = b if isinstance(b, (list, tuple)) else _tangent(b, 7, "similarity")
    return Multivector(tuple(sorted(_TANGENT_BLADES)), tuple(v[_TANGENT_BLADES.index(k)] * _TANGENT_SIGNS[_TANGENT_BLADES.index(k)] for k in sorted(_TANGENT_BLADES)))


def bivector_to_tangent(Bv: Multivector) -> tuple[Any, ...]:
    """Inverse of :func:`tangent_to_bivector`: the 7 coordinates (a tuple) of a bivector.

    A body-frame velocity is ``bivector_to_tangent(−2 Ṽ V̇)`` (paper Eq 8/30).
    """
    return tuple(Bv.get(k) * s for k, s in zip(_TANGENT_BLADES, _TANGENT_SIGNS))


def motor_rotor_translation(M: Multivector) -> tuple[tuple[Any, Any, Any, Any], tuple[Any, Any, Any]]:
    """``(R, t)`` of a *unit* motor ``M = T(t) R``: rotor coefficients (1, e12, e13, e23) and t [m].

    No validation or normalisation (cheap, symbolic-friendly); see :func:`decompose`
    for general similarity versors.
    """
    R = tuple(M.get(k) for k in ROTOR_BLADES)
    C = tuple(-2.0 * M.get(k) for k in (_E1I, _E2I, _E3I, _E123I))  # t R as (e1, e2, e3, e123)
    tt = Multivector((_E1, _E2, _E3, _E123), C) * Multivector(ROTOR_BLADES, (R[0], -R[1], -R[2], -R[3]))
    return R, (tt.get(_E1), tt.get(_E2), tt.get(_E3))


def rotor_matrix(R: tuple[Any, Any, Any, Any]) -> list[list[Any]]:
    """3×3 rotation matrix (nested lists; numpy or CasADi entries) of a unit rotor (1, e12, e13, e23).

    A rotor is a quaternion with ``qw = R0, qx = −R23, qy = R13, qz = −R12``.
    """
    w, x, y, z = R[0], -R[3], R[2], -R[1]
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def rotor_from_matrix(Rm: np.ndarray) -> tuple[float, float, float, float]:
    """Unit rotor (1, e12, e13, e23) of a numeric rotation matrix (via a robust quaternion)."""
    from scipy.spatial.transform import Rotation

    qx, qy, qz, qw = Rotation.from_matrix(np.asarray(Rm, dtype=float)).as_quat()
    return float(qw), float(-qz), float(qy), float(-qx)


# ---------------------------------------------------------------------- group classes
class VersorGroup(abc.ABC):
    """Common interface of the versor groups (jaxlie style).

    Subclasses fix the versor's blade layout and which slots of the similarity
    7-vector their tangent uses.  Elements are immutable; ``a @ b`` composes
    (apply b first, then a), ``a.inverse()``, ``a.log()``, ``cls.exp(v)``,
    ``a.apply(X)``.
    """

    tangent_slots: ClassVar[tuple[int, ...]]
    blades: ClassVar[tuple[int, ...]]
    __slots__ = ("versor",)

    def __init__(self, versor: Multivector, *, check: bool = True):
        if check:
            _validate_similarity(versor, type(self).__name__)
            if not versor.is_symbolic:
                self._check_membership(versor)
        self.versor = versor.project(self.blades) if not check else _relayout(versor, self.blades)

    def _check_membership(self, V: Multivector) -> None:
        full = np.asarray(log(V))
        others = [i for i in range(7) if i not in self.tangent_slots]
        if others and np.max(np.abs(full[..., others])) > 1e-9:
            names = [TANGENT_BASIS[i] for i in others if np.max(np.abs(full[..., i])) > 1e-9]
            raise InvalidVersorError(f"this versor has {names} components; it is not a {type(self).__name__}")

    @classmethod
    def exp(cls, tangent: Any):
        """Group element from tangent coordinates (see :data:`TANGENT_BASIS` for the slots)."""
        v = _tangent(tangent, len(cls.tangent_slots), cls.__name__)
        zero = 0.0 * v[0]
        full = [zero] * 7
        for slot, x in zip(cls.tangent_slots, v):
            full[slot] = x
        V = _exp_parts(tuple(full[0:3]), full[3], tuple(full[4:7]))
        return cls(V.project(cls.blades), check=False)

    @classmethod
    def identity(cls):
        return cls(Multivector.scalar(1.0).with_blades(cls.blades), check=False)

    def log(self) -> Any:
        full = log(self.versor)
        if B.is_symbolic(full):
            import casadi as ca

            return ca.vertcat(*[full[i] for i in self.tangent_slots])
        return full[..., list(self.tangent_slots)]

    def inverse(self):
        return type(self)(self.versor.inverse(), check=False)

    def __matmul__(self, other: VersorGroup) -> VersorGroup:
        if not isinstance(other, VersorGroup):
            return NotImplemented
        cls = _join(type(self), type(other))
        return cls((self.versor * other.versor).project(cls.blades), check=False)

    compose = __matmul__

    def apply(self, X: Multivector) -> Multivector:
        return apply(self.versor, X)

    def as_similarity(self) -> Similarity:
        return Similarity(self.versor.with_blades(SIMILARITY_BLADES), check=False)

    def __repr__(self) -> str:
        lg = self.log()
        return f"{type(self).__name__}({np.round(np.asarray(lg, dtype=float), 6).tolist() if not B.is_symbolic(lg) else lg})"


def _relayout(V: Multivector, blades: tuple[int, ...]) -> Multivector:
    d = V.as_dict()
    return Multivector(blades, tuple(d.get(b, 0.0) for b in blades))


class Rotor(VersorGroup):
    """Rotations (Eq 62/63); tangent ``[θ12, θ13, θ23]`` [rad]."""

    tangent_slots = (0, 1, 2)
    blades = ROTOR_BLADES


class Translator(VersorGroup):
    """Translations (Eq 64/65); tangent ``[t1, t2, t3]`` [m]."""

    tangent_slots = (4, 5, 6)
    blades = TRANSLATOR_BLADES


class Dilator(VersorGroup):
    """Uniform scaling about the origin (Eq 67–69, sign per module docstring); tangent ``[β]``, scale e^β."""

    tangent_slots = (3,)
    blades = DILATOR_BLADES


class Motor(VersorGroup):
    """Rigid motions V_T V_R (Eq 70–73); tangent ``[θ12, θ13, θ23, t1, t2, t3]``."""

    tangent_slots = (0, 1, 2, 4, 5, 6)
    blades = MOTOR_BLADES


class Similarity(VersorGroup):
    """Direct similarities V_T V_R V_D (Eq 74–77); tangent ``[θ12, θ13, θ23, β, t1, t2, t3]``."""

    tangent_slots = (0, 1, 2, 3, 4, 5, 6)
    blades = SIMILARITY_BLADES

    def decompose(self) -> tuple[Translator, Rotor, Dilator]:
        """``(V_T, V_R, V_D)`` with ``self = V_T V_R V_D`` up to a positive scale."""
        VT, VR, VD = decompose(self.versor)
        return Translator(VT, check=False), Rotor(VR, check=False), Dilator(VD, check=False)


def _join(a: type, b: type) -> type:
    if a is b:
        return a
    rigid = {Rotor, Translator, Motor}
    if a in rigid and b in rigid:
        return Motor
    return Similarity
