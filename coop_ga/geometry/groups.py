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

Numerics: the series are used below 1e-3 and carried to the 4th order, so log and exp
are accurate to ≤ 1e-15 relative on both sides of the switch; β is computed as
``log1p(2 s/(c − s))`` (or its mirror), accurate to ~ε relative also for |β| → 0.
Numeric versors are rescaled exactly (an overall power of two and a dilation by a power
of two, undone on t) before log/decompose/log_jacobian/apply, so every threshold is
relative, a versor times 1e±300 gives the same log, and translations up to the float
range are accepted.  A similarity that scales by s stores its dilation as cosh/sinh of
½ log s: its coefficients, and everything computed from them, carry a relative rounding
error of about ε·max(s, 1/s) (inherent in the representation, not in the formulas).
"""

from __future__ import annotations

import abc
import math
from functools import lru_cache
from typing import Any, ClassVar, Self, TypeAlias

import numpy as np

from .. import validation
from ..algebra import backend as B
from ..algebra.basis import blade_index, blade_name
from ..algebra.multivector import OMEGA, Multivector, _absmax, balance_exponents, safe_range
from ..errors import InvalidInputError, InvalidVersorError, NonFiniteError

__all__ = [
    "MOTOR_BLADES",
    "SIMILARITY_BLADES",
    "TANGENT_BASIS",
    "Dilator",
    "Motor",
    "Rotor",
    "Similarity",
    "SimilarityLike",
    "Translator",
    "VersorGroup",
    "apply",
    "bivector_to_tangent",
    "decompose",
    "exp",
    "log",
    "log_jacobian",
    "motor_rotor_translation",
    "rotor_from_matrix",
    "rotor_matrix",
    "tangent_to_bivector",
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

_SMALL_ANGLE = 1e-3  # below this (φ resp. tan(φ/2) < 1e-3), series expansions: truncation error < 1e-18 relative


# ---------------------------------------------------------------------- helpers
def _tangent(b: Any, n: int, name: str) -> tuple[Any, ...]:
    if type(b) is np.ndarray and b.shape == (n,) and b.dtype == np.float64:  # fast path
        v = tuple(b.tolist())
        if all(math.isfinite(x) for x in v):
            return v
    if B.is_symbolic(b):
        if b.numel() != n:
            raise InvalidInputError(f"{name} tangent must have {n} entries, got a CasADi expression of shape {b.shape}")
        return tuple(b[i] for i in range(n))
    if isinstance(b, (list, tuple)) and len(b) == n and any(B.is_symbolic(v) for v in b):
        out = []
        for i, v in enumerate(b):
            if B.is_symbolic(v):
                if v.numel() != 1:
                    raise InvalidInputError(
                        f"{name} tangent entry {i} must be a scalar CasADi expression, got {v.shape}"
                    )
                out.append(v)
            else:
                if type(v) is int and not -1e308 <= v <= 1e308:
                    raise InvalidInputError(f"{name} tangent entry {i} is an integer beyond the float range")
                out.append(validation.scalar(v, f"{name} tangent entry {i}"))
        return tuple(out)
    if isinstance(b, Multivector):
        raise InvalidInputError(f"{name} tangent must be {n} numbers, got a Multivector (use log(V) for its tangent)")
    a = validation.array(b, f"{name} tangent", finite=False)
    if a.shape[-1:] != (n,) or a.ndim > 2 or (a.ndim == 2 and a.shape[0] == 0):
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
    """sin(φ/2)/φ as a function of φ², exact through φ = 0 (series to φ⁴ below φ = 1e-3)."""
    small = phi2 < _SMALL_ANGLE**2
    phi_safe = B.sqrt(B.where(small, 1.0, phi2))
    return B.where(small, 0.5 - phi2 * (1.0 / 48.0 - phi2 / 3840.0), B.sin(0.5 * phi_safe) / phi_safe)


def _cos_half(phi2: Any) -> Any:
    """cos(φ/2) as a function of φ², with a finite derivative at φ = 0 (series to φ⁴ below 1e-3)."""
    small = phi2 < _SMALL_ANGLE**2
    phi_safe = B.sqrt(B.where(small, 1.0, phi2))
    return B.where(small, 1.0 - phi2 * (0.125 - phi2 / 384.0), B.cos(0.5 * phi_safe))


def _atan_over(n2: Any, w: Any) -> Any:
    """atan2(n, w)/n for w ≥ 0, exact through n = 0 (w > 0 there).

    Below x = n/w = 1e-3 the series ``(1 − x²/3 + x⁴/5)/w`` (truncation < x⁶/7 ≈ 1.4e-19);
    above, ``atan2(n, w)/n``: relative error ≤ 1e-15 on both sides of the switch, measured
    against long-double references (``tests/geometry/test_reliability.py``).
    """
    small = n2 < (_SMALL_ANGLE**2) * w * w
    n_safe = B.sqrt(B.where(small, 1.0, n2))
    w_safe = B.where(small, w, 1.0)
    inv = 1.0 / w_safe
    x2 = n2 * inv * inv
    return B.where(small, inv * (1.0 - x2 * (1.0 / 3.0 - 0.2 * x2)), B.atan2(n_safe, w) / n_safe)


def _rescaled(V: Multivector) -> tuple[Multivector, int]:
    """Numeric V rescaled exactly to unit size (powers of two): log is scale-invariant, and the
    translation of the result is ``2**k`` times that of the rescaled versor."""
    k, (lam,) = balance_exponents(V)
    return V._rescaled(k, lam), k


def _finite_out(x: Any, what: str) -> Any:
    if not B.is_symbolic(x) and not np.all(np.isfinite(np.asarray(x, dtype=float))):
        raise InvalidInputError(f"{what} is beyond the float64 range; the argument is too extreme to be represented")
    return x


# ---------------------------------------------------------------------- exp
def _exp_parts(theta, beta, t, rotor=None) -> Multivector:
    """``V_T(t) V_R(θ) V_D(β)`` on the similarity blades (numeric: range-checked, see :func:`exp`)."""
    if rotor is None and not B.any_symbolic(*theta, beta, *t):
        return _exp_numeric(theta, beta, t)
    th12, th13, th23 = theta
    if rotor is None or rotor is _NO_ROTOR:
        phi2 = th12 * th12 + th13 * th13 + th23 * th23
        k = _sin_half_over(phi2)
        r0 = _cos_half(phi2)
        r = (r0, -k * th12, -k * th13, -k * th23)
    else:
        r = rotor
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
    return Multivector(SIMILARITY_BLADES, tuple(d.get(b, 0.0) for b in SIMILARITY_BLADES))


#: |β| above which cosh(β/2) overflows float64
_BETA_MAX = 2.0 * float(np.arccosh(np.finfo(float).max)) * (1.0 - 1e-12)


def _rotor_numeric(theta: tuple[Any, Any, Any]) -> tuple[Any, Any, Any, Any] | None:
    """Rotor coefficients for rotation vectors too large to square (|θ| > 1e150), else None."""
    m = max(float(np.max(np.abs(x))) for x in theta)
    if m <= 1e150:
        return None
    u = [np.asarray(x, dtype=float) / m for x in theta]
    phi = m * np.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
    sh = np.sin(0.5 * phi)
    out = (np.cos(0.5 * phi), *(-sh * (np.asarray(x, dtype=float) / phi) for x in theta))
    return tuple(float(v) if np.ndim(v) == 0 else v for v in out)  # type: ignore[return-value]


def _exp_numeric(theta, beta, t) -> Multivector:
    bmax = float(np.max(np.abs(beta)))
    if bmax > _BETA_MAX:
        raise InvalidInputError(
            f"b: the dilation β = {bmax:.6g} is outside the representable range |β| ≤ {_BETA_MAX:.6g} "
            "(the versor coefficients cosh(β/2), sinh(β/2) overflow float64)"
        )
    with np.errstate(over="ignore", invalid="ignore"):
        V = _exp_parts(theta, beta, t, rotor=_rotor_numeric(theta) or _NO_ROTOR)
    for c in V.coeffs:
        if not (math.isfinite(c) if type(c) is float or type(c) is np.float64 else np.all(np.isfinite(c))):
            raise InvalidInputError(
                "b: exp(b) is not representable in float64: the translation part |t|·e^(−β/2) overflows "
                "(|t| and β are too large together)"
            )
    return V


_NO_ROTOR = ()  # sentinel: compute the rotor by the generic formula (numeric inputs already checked)


def exp(b: Any) -> Multivector:
    """Similarity versor ``V_T V_R V_D`` of the 7-vector ``b = [θ12, θ13, θ23, β, t1, t2, t3]`` (Eq 76).

    Units: θ [rad], β [dimensionless, scale factor e^β], t [m].  Returns a
    :class:`Multivector` on the 12 similarity blades.  Accepts (7,), (N, 7) or CasADi.
    Numeric b must give a representable versor: |β| ≤ 1420 (cosh(β/2) < 1.8e308) and
    ``|t|·e^(−β/2) < 1.8e308``; otherwise :class:`InvalidInputError`.  Any finite θ is fine
    (the rotation angle is reduced exactly).
    """
    v = _tangent(b, 7, "similarity")
    return _exp_parts(v[0:3], v[3], v[4:7])


# ---------------------------------------------------------------------- log / decompose
def _coeffs(V: Multivector, blades) -> tuple[Any, ...]:
    return tuple(V.get(k) for k in blades)


def _validate_similarity(V: Multivector, what: str = "versor") -> None:
    if not isinstance(V, Multivector):
        raise InvalidInputError(f"{what} must be a coop_ga Multivector, got {type(V).__name__}")
    V.check_finite(what)
    if V.is_symbolic:
        return
    scale = max([_absmax(c) for c in V.coeffs] + [0.0])
    if scale == 0.0:
        raise InvalidVersorError(
            f"{what} is zero; a zero-norm versor has no logarithm (did a normalisation underflow?)"
        )
    allowed = set(SIMILARITY_BLADES)
    if all(k in allowed for k in V.blades):
        return
    Vb, _ = _rescaled(V)  # compare blades of different dimension at a common length scale
    scale = max(float(np.max(np.abs(c))) for c in Vb.coeffs)
    for k, c in zip(Vb.blades, Vb.coeffs):
        if k not in allowed and float(np.max(np.abs(c))) > 1e-9 * scale:
            raise InvalidVersorError(
                f"{what} has a {blade_name(k)} component ({float(np.max(np.abs(c))):.3g} relative to its largest "
                "coefficient after rescaling); it is not a similarity versor (translator·rotor·dilator), e.g. it "
                "contains a transversion or a reflection"
            )


def _decompose_coeffs(V: Multivector):
    """Return (R (4 coeffs, unit), beta, t (3)) with V ∝ T(t) R D(β).

    Numeric V is rescaled exactly first (a positive power of two overall, and a dilation by
    a power of two whose effect on t is undone at the end), so every test below is relative
    and nothing overflows; t beyond the float range raises :class:`InvalidInputError`.
    """
    if V.is_symbolic:
        return _decompose_core(V, symbolic=True)
    if safe_range(V):  # every test below is relative (or has a 1 m floor): the frame does not matter
        return _decompose_core(V, symbolic=False)
    Vb, k = _rescaled(V)
    with np.errstate(over="ignore"):
        unit = float(np.ldexp(1.0, -k))  # 1 m in the rescaled frame (inf if beyond the range: no floor needed)
    R, beta, t = _decompose_core(Vb, symbolic=False, unit=unit)
    with np.errstate(over="ignore"):
        t = tuple(np.ldexp(np.asarray(x, dtype=float), k) for x in t)
    t = tuple(float(x) if x.ndim == 0 else x for x in t)
    _finite_out(np.stack(np.broadcast_arrays(*t)), "the translation of the versor")
    return R, beta, t


def _decompose_core(V: Multivector, symbolic: bool, unit: float = 1.0):
    A = _coeffs(V, ROTOR_BLADES)  # λ c R
    Bq = _coeffs(V, (_E0I, _E012I, _E013I, _E023I))  # λ s R
    C = _coeffs(V, (_E1I, _E2I, _E3I, _E123I))  # −½ λ (c − s) (t R)
    a2 = A[0] * A[0] + A[1] * A[1] + A[2] * A[2] + A[3] * A[3]
    scalar = not symbolic and all(type(c) is float or type(c) is np.float64 for c in V.coeffs)
    if scalar:
        b2 = Bq[0] * Bq[0] + Bq[1] * Bq[1] + Bq[2] * Bq[2] + Bq[3] * Bq[3]
        if a2 <= 1e-24 * (a2 + b2) or a2 == 0:
            raise InvalidVersorError(
                "the versor has no rotor part (scalar and e12, e13, e23 are all zero): zero norm or not a "
                "similarity versor"
            )
    elif not symbolic:
        b2 = sum(np.asarray(x, dtype=float) ** 2 for x in Bq)
        if np.any(np.asarray(a2) <= 1e-24 * (np.asarray(a2) + b2)) or np.any(np.asarray(a2) == 0):
            raise InvalidVersorError(
                "the versor has no rotor part (scalar and e12, e13, e23 are all zero): zero norm or not a "
                "similarity versor"
            )
    an = B.sqrt(a2)  # λ c  (c = cosh ≥ 1, λ > 0 by choice of the sign of R)
    R = tuple(x / an for x in A)
    ls = Bq[0] * R[0] + Bq[1] * R[1] + Bq[2] * R[2] + Bq[3] * R[3]  # λ s
    cm = an - ls  # λ (c − s) > 0
    cp = an + ls  # λ (c + s) > 0
    if not symbolic:
        if (cm <= 0 or cp <= 0) if scalar else (np.any(np.asarray(cm) <= 0) or np.any(np.asarray(cp) <= 0)):
            raise InvalidVersorError(
                "the versor's dilation part is not a valid dilator (|sinh| ≥ cosh); if it came from exp(b) with "
                "a large |β|, the dilation is beyond the precision of the coefficients (|β| ≲ 36)"
            )
        resid = [b - ls * r for b, r in zip(Bq, R)]
        if max(_absmax(x) for x in resid) > 1e-6 * _absmax(an):
            raise InvalidVersorError(
                "the versor's e0∞-parts are not aligned with its rotor part; it is not a similarity versor"
            )
    # β = log(cp/cm) = 2 atanh(s/c), in the form that does not cancel: log1p(2 ls/cm) for ls ≥ 0
    # (cm = an − ls is exact there when ls > an/2), −log1p(−2 ls/cp) for ls < 0; relative error ~ε for
    # every β, also |β| → 0 (log(cp/cm) had ~ε/|β| and returned 0 below 1e-16)
    if scalar:
        beta = math.log1p(2.0 * ls / cm) if ls >= 0 else -math.log1p(-2.0 * ls / cp)
    else:
        pos = ls >= 0
        with np.errstate(invalid="ignore", divide="ignore"):  # numpy evaluates both branches
            beta = B.where(pos, B.log1p(2.0 * ls / B.where(pos, cm, 1.0)), -B.log1p(-2.0 * ls / B.where(pos, 1.0, cp)))
    tRv = tuple(-2.0 * x / cm for x in C)  # t R as (e1, e2, e3, e123)
    tR = Multivector((_E1, _E2, _E3, _E123), tRv)
    tt = tR * Multivector(ROTOR_BLADES, (R[0], -R[1], -R[2], -R[3]))
    t = (tt.get(_E1), tt.get(_E2), tt.get(_E3))
    if not symbolic:
        # e123 part of t R R̃: zero for a similarity; tolerance relative to |t|, with a floor of
        # 1e-6 m (``unit`` is 1 m in the rescaled frame) so that rounding noise of a zero translation passes
        tri = tt.get(_E123)
        if scalar:
            bad = abs(tri) > 1e-6 * (unit + math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]))
        else:
            with np.errstate(over="ignore"):
                tn = np.sqrt(sum(np.asarray(x, dtype=float) ** 2 for x in t))
            bad = bool(np.any(np.abs(np.asarray(tri)) > 1e-6 * (unit + tn)))
        if bad:
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


def _versor_arg(V: Any, what: str) -> Multivector:
    if isinstance(V, VersorGroup):
        return V.versor
    if not isinstance(V, Multivector):
        raise InvalidInputError(
            f"{what} must be a similarity versor (a coop_ga Multivector or group element), got {type(V).__name__}"
        )
    return V


def log(V: Any) -> Any:
    """Similarity bivector ``[θ12, θ13, θ23, β, t1, t2, t3]`` of a similarity versor (Eq 77).

    ``V`` may be any positive multiple of a versor (it is normalised; numeric V is rescaled
    exactly first, so a versor times 1e300 or 1e-300 gives the same answer).  Raises
    :class:`InvalidVersorError` for zero-norm input or multivectors outside the group.
    ``log(~V1 * V2)`` is the relative similarity expressed in V1's frame.
    """
    V = _versor_arg(V, "V")
    _validate_similarity(V, "V")
    R, beta, t = _decompose_coeffs(V)
    th = _rotor_log(R)
    return _stack((th[0], th[1], th[2], beta, t[0], t[1], t[2]))


def decompose(V: Multivector) -> tuple[Multivector, Multivector, Multivector]:
    """Canonical decomposition V ∝ V_T V_R V_D (Eq 18/74) into normalised factors.

    Derivation: with ``V_R = R``, ``V_D = c + s e0∞`` and ``V_T = 1 − ½ t e∞`` one
    finds ``V_T V_R V_D = c R + s R e0∞ − ½ (c − s) t R e∞`` because ``e∞ e0∞ = −e∞``.
    The e0/e∞-free part gives ``cR``, the e0∞ part ``sR``, the e∞ part ``t``.
    """
    V = _versor_arg(V, "V")
    _validate_similarity(V, "V")
    R, beta, t = _decompose_coeffs(V)
    zero = 0.0 * beta
    VT = _exp_parts((zero, zero, zero), zero, t).project(TRANSLATOR_BLADES)
    VR = Multivector(ROTOR_BLADES, R)
    VD = Multivector(DILATOR_BLADES, (B.cosh(0.5 * beta), B.sinh(0.5 * beta)))
    if not V.is_symbolic:
        for c in VD.coeffs:
            _finite_out(c, "decompose(V): the unit dilator cosh(β/2) + sinh(β/2) e0∞")
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
    follow :data:`TANGENT_BASIS`.  Computed by CasADi AD of the same ``log`` source, at the
    exactly rescaled versor (the chain rule of the rescaling is applied afterwards), so a
    versor times 1e±300 gives the correspondingly scaled Jacobian, never NaN/inf.
    One numeric versor (not a batch, not symbolic).
    """
    V = _versor_arg(V, "V")
    _validate_similarity(V, "V")
    if V.is_symbolic:
        raise InvalidInputError("log_jacobian(V) needs a numeric versor; differentiate log(V) with CasADi instead")
    if any(np.ndim(c) for c in V.coeffs):
        raise InvalidInputError("log_jacobian(V) takes one versor, not a batch (coefficients must be scalars)")
    _decompose_coeffs(V)  # group membership and dilator validity (raises like log)
    k, (lam,) = balance_exponents(V)
    Vb = V._rescaled(k, lam)
    x = np.array([float(Vb.get(b)) for b in SIMILARITY_BLADES])
    J = np.array(_log_jac_fn()(x))
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        rows = np.ldexp(1.0, np.array([0, 0, 0, 0, k, k, k]))
        cols = np.ldexp(1.0, np.array([lam - k * OMEGA[b] for b in SIMILARITY_BLADES]))
        J = J * rows[:, None] * cols[None, :]
    return _finite_out(J, "log_jacobian(V)")


def _versor_like(V: Multivector) -> bool:
    """V Ṽ is a scalar, non-zero and with other grades ≤ 1e-9 |V|² (V scaled to unit size first)."""
    if not safe_range(V, lim=500):
        return False
    VV = V * V.reverse()
    if all(type(c) is float or type(c) is np.float64 for c in V.coeffs):
        n2 = sum(c * c for c in V.coeffs)
        s = abs(VV.get(0))
        worst = max([abs(c) for b, c in zip(VV.blades, VV.coeffs) if b != 0] + [0.0])
        return s > 1e-9 * n2 and worst <= 1e-9 * n2
    n2 = sum(np.asarray(c, dtype=float) ** 2 for c in V.coeffs)
    s = np.abs(np.asarray(VV.get(0), dtype=float))
    rest = [np.abs(np.asarray(c, dtype=float)) for b, c in zip(VV.blades, VV.coeffs) if b != 0]
    worst = np.max(np.stack(np.broadcast_arrays(*rest)), axis=0) if rest else np.zeros(())
    return bool(np.all(s > 1e-9 * n2) and np.all(worst <= 1e-9 * n2))


def _check_versor(V: Multivector) -> None:
    """Numeric V must be a versor: V Ṽ a non-zero scalar to relative 1e-9 (after an exact
    rescaling), or an element of the similarity group (e.g. a dilator with large β, whose
    V Ṽ = 1 is small compared with its coefficients)."""
    if _versor_like(V) or _versor_like(_rescaled(V)[0]):  # as given (fast), then in the balanced frame
        return
    if all(b in set(SIMILARITY_BLADES) for b in V.blades):
        try:
            _decompose_coeffs(V)
            return
        except InvalidVersorError as exc:
            raise InvalidVersorError(f"apply(V, X): V is not a versor: {exc}") from None
    Vb = _rescaled(V)[0]
    VV = Vb * Vb.reverse()
    n2 = float(np.max(sum(np.asarray(c, dtype=float) ** 2 for c in Vb.coeffs)))
    sc = float(np.min(np.abs(np.asarray(VV.get(0), dtype=float))))
    worst = max([float(np.max(np.abs(c))) for b, c in zip(VV.blades, VV.coeffs) if b != 0] + [0.0])
    raise InvalidVersorError(
        f"apply(V, X): V is not a versor: V Ṽ must be a non-zero scalar, got scalar {sc / n2:.3g} and other "
        f"grades up to {worst / n2:.3g} relative to |V|² (after rescaling)"
    )


def apply(V: Any, X: Multivector) -> Multivector:
    """Sandwich ``V X Ṽ`` (Eq 6), projected to the grades of X; keeps a primitive's kind tag.

    V may be a versor Multivector or a :class:`VersorGroup` element.  A numeric V must be a
    versor (V Ṽ a non-zero scalar, or a similarity versor), else :class:`InvalidVersorError`.
    Numeric arguments are rescaled exactly before multiplying (nothing overflows
    needlessly); a result beyond the float range raises :class:`InvalidInputError`.
    """
    from .primitives import Primitive

    if isinstance(V, VersorGroup):
        V = V.versor
    if not isinstance(V, Multivector) or not isinstance(X, Multivector):
        raise InvalidInputError(
            "apply(V, X) needs two Multivectors (or a group element and a Multivector), got "
            f"V: {type(V).__name__}, X: {type(X).__name__}"
        )
    V.check_finite("V")
    X.check_finite("X")
    if not V.blades or (not V.is_symbolic and max(_absmax(c) for c in V.coeffs) == 0.0):
        raise InvalidVersorError("apply(V, X): V is zero")
    if V.is_symbolic or X.is_symbolic:
        Y = (V * X * V.reverse()).grade(*X.grades)
    elif safe_range(V, X, lim=300):  # no product of three coefficients can overflow: no rescaling
        _check_versor(V)
        Y = (V * X * V.reverse()).grade(*X.grades)
        for c in Y.coeffs:
            if not (math.isfinite(c) if type(c) is float or type(c) is np.float64 else np.all(np.isfinite(c))):
                raise InvalidInputError("apply(V, X): the result's coefficients are beyond the float64 range")
    else:
        _check_versor(V)
        k, (lv, lx) = balance_exponents(V, X)
        Vb, Xb = V._rescaled(k, lv), X._rescaled(k, lx)
        Yb = (Vb * Xb * Vb.reverse()).grade(*X.grades)
        with np.errstate(over="ignore"):
            Y = Yb._rescaled(-k, -(2 * lv + lx))
        for c in Y.coeffs:
            if not np.all(np.isfinite(c)):
                raise InvalidInputError("apply(V, X): the result's coefficients are beyond the float64 range")
    if isinstance(X, Primitive):
        return Primitive.tag(Y, X.kind)
    return Y


# ---------------------------------------------------------------------- bivectors <-> 7-vectors
_TANGENT_BLADES = (_E12, _E13, _E23, _E0I, _E1I, _E2I, _E3I)
_TANGENT_SIGNS = (1.0, 1.0, 1.0, -1.0, 1.0, 1.0, 1.0)


def tangent_to_bivector(b: Any) -> Multivector:
    """The bivector B with ``exp(ε b) = 1 − ½ ε B + O(ε²)`` (note the dilation slot: B ∋ −β e0∞).

    ``b``: a 7-vector (numeric or CasADi), or a list/tuple of 7 entries that may be CasADi
    scalars or equally shaped numeric arrays (a batch of tangents, one array per slot).
    """
    if isinstance(b, (list, tuple)) and len(b) == 7:
        v = tuple(x if B.is_symbolic(x) else _tangent_entry(x, i) for i, x in enumerate(b))
    else:
        v = _tangent(b, 7, "similarity")
    return Multivector(
        tuple(sorted(_TANGENT_BLADES)),
        tuple(v[_TANGENT_BLADES.index(k)] * _TANGENT_SIGNS[_TANGENT_BLADES.index(k)] for k in sorted(_TANGENT_BLADES)),
    )


def _tangent_entry(x: Any, i: int) -> Any:
    a = validation.array(x, f"tangent entry {i}")
    return float(a) if a.ndim == 0 else a


def bivector_to_tangent(Bv: Multivector) -> tuple[Any, ...]:
    """Inverse of :func:`tangent_to_bivector`: the 7 coordinates (a tuple) of a bivector.

    A body-frame velocity is ``bivector_to_tangent(−2 Ṽ V̇)`` (paper Eq 8/30).
    """
    if not isinstance(Bv, Multivector):
        raise InvalidInputError(f"bivector_to_tangent(B) needs a Multivector, got {type(Bv).__name__}")
    return tuple(Bv.get(k) * s for k, s in zip(_TANGENT_BLADES, _TANGENT_SIGNS))


def motor_rotor_translation(M: Multivector) -> tuple[tuple[Any, Any, Any, Any], tuple[Any, Any, Any]]:
    """``(R, t)`` of a *unit* motor ``M = T(t) R``: rotor coefficients (1, e12, e13, e23) and t [m].

    No validation or normalisation (cheap, symbolic-friendly); see :func:`decompose`
    for general similarity versors.
    """
    if not isinstance(M, Multivector):
        raise InvalidInputError(f"motor_rotor_translation(M) needs a Multivector, got {type(M).__name__}")
    R = tuple(M.get(k) for k in ROTOR_BLADES)
    C = tuple(-2.0 * M.get(k) for k in (_E1I, _E2I, _E3I, _E123I))  # t R as (e1, e2, e3, e123)
    tt = Multivector((_E1, _E2, _E3, _E123), C) * Multivector(ROTOR_BLADES, (R[0], -R[1], -R[2], -R[3]))
    return R, (tt.get(_E1), tt.get(_E2), tt.get(_E3))


def rotor_matrix(R: tuple[Any, Any, Any, Any]) -> list[list[Any]]:
    """3×3 rotation matrix (nested lists; numpy or CasADi entries) of a unit rotor (1, e12, e13, e23).

    A rotor is a quaternion with ``qw = R0, qx = −R23, qy = R13, qz = −R12``.
    """
    if isinstance(R, Multivector):
        R = tuple(R.get(k) for k in ROTOR_BLADES)
    if isinstance(R, (str, bytes)) or not hasattr(R, "__getitem__") or (not B.is_symbolic(R) and len(R) != 4):
        raise InvalidInputError(
            f"rotor_matrix(R) needs the 4 rotor coefficients (1, e12, e13, e23), got {type(R).__name__}"
        )
    w, x, y, z = R[0], -R[3], R[2], -R[1]
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def rotor_from_matrix(Rm: np.ndarray) -> tuple[float, float, float, float]:
    """Unit rotor (1, e12, e13, e23) of a numeric rotation matrix (via a robust quaternion)."""
    from scipy.spatial.transform import Rotation

    M = validation.array(Rm, "Rm", shape=(3, 3))
    if not np.allclose(M @ M.T, np.eye(3), atol=1e-6) or not np.linalg.det(M) > 0:
        raise InvalidInputError("Rm must be a rotation matrix (orthogonal, det +1)")
    qx, qy, qz, qw = Rotation.from_matrix(M).as_quat()
    return float(qw), float(-qz), float(qy), float(-qx)


# ---------------------------------------------------------------------- group classes
class VersorGroup(abc.ABC):
    """Common interface of the versor groups (jaxlie style).

    Subclasses fix the versor's blade layout and which slots of the similarity
    7-vector their tangent uses.  Elements are immutable; ``a @ b`` (or ``a.compose(b)``)
    composes (apply b first, then a), ``a.inverse()``, ``a.log()``, ``cls.exp(v)``,
    ``a.apply(X)``, ``a.coeffs`` / ``cls.from_coeffs(v)``.

    Every subgroup element is also a similarity: wherever coop_ga takes a
    :class:`Similarity` (targets of the controllers), a :class:`Motor`, :class:`Rotor`,
    :class:`Translator` or :class:`Dilator` is accepted and converted with
    :meth:`as_similarity`.

    Numeric elements are stored normalised (``V Ṽ = 1``): the constructor divides by
    ``√⟨V Ṽ⟩₀`` after checking membership, so a positive multiple of a versor is the
    same element.  Symbolic (CasADi) elements are stored as given.
    """

    tangent_slots: ClassVar[tuple[int, ...]]
    blades: ClassVar[tuple[int, ...]]
    __slots__ = ("_coeffs", "versor")

    def __init__(self, versor: Multivector, *, check: bool = True):
        if check:
            if not isinstance(versor, Multivector):
                raise InvalidInputError(
                    f"{type(self).__name__}(versor) needs a coop_ga Multivector, got {type(versor).__name__}; "
                    f"use {type(self).__name__}.exp(tangent) or {type(self).__name__}.from_coeffs(v)"
                )
            _validate_similarity(versor, type(self).__name__)
            if not versor.is_symbolic:
                versor = _normalised(versor, type(self).__name__)
                self._check_membership(versor)
            versor = _relayout(versor, self.blades)
        else:
            versor = versor.project(self.blades)
        self.versor = versor
        self._coeffs: np.ndarray | None = None

    def _check_membership(self, V: Multivector) -> None:
        full = np.asarray(log(V))
        others = [i for i in range(7) if i not in self.tangent_slots]
        if others and np.max(np.abs(full[..., others])) > 1e-9:
            names = [TANGENT_BASIS[i] for i in others if np.max(np.abs(full[..., i])) > 1e-9]
            raise InvalidVersorError(f"this versor has {names} components; it is not a {type(self).__name__}")

    # ------------------------------------------------------------------ construction
    @classmethod
    def exp(cls, tangent: Any) -> Self:
        """Group element from tangent coordinates (see :data:`TANGENT_BASIS` for the slots)."""
        v = _tangent(tangent, len(cls.tangent_slots), cls.__name__)
        zero = 0.0 * v[0]
        full = [zero] * 7
        for slot, x in zip(cls.tangent_slots, v):
            full[slot] = x
        V = _exp_parts(tuple(full[0:3]), full[3], tuple(full[4:7]))
        return cls(V.project(cls.blades), check=False)

    @classmethod
    def identity(cls) -> Self:
        return cls(Multivector.scalar(1.0).with_blades(cls.blades), check=False)

    @classmethod
    def from_coeffs(cls, v: Any) -> Self:
        """Element from its versor coefficients on :attr:`blades` (e.g. 12 on
        :data:`SIMILARITY_BLADES` for a :class:`Similarity`), validated and normalised."""
        n = len(cls.blades)
        if isinstance(v, (str, bytes, dict)) or v is None:
            raise InvalidInputError(f"{cls.__name__}.from_coeffs needs {n} numbers, got {type(v).__name__}")
        try:
            a = np.asarray(v)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"{cls.__name__}.from_coeffs needs {n} numbers: {exc}") from None
        if a.dtype.kind not in "fiu" or a.dtype == np.bool_:
            raise InvalidInputError(f"{cls.__name__}.from_coeffs needs {n} real numbers, got dtype {a.dtype}")
        a = a.astype(float).reshape(-1) if a.size == n else a
        if a.shape != (n,):
            raise InvalidInputError(
                f"{cls.__name__}.from_coeffs needs {n} coefficients (on {cls.__name__}.blades), got shape {np.shape(v)}"
            )
        if not np.all(np.isfinite(a)):
            raise NonFiniteError(f"{cls.__name__} coefficients contain NaN or inf: {a.tolist()}")
        return cls(Multivector(cls.blades, tuple(float(x) for x in a)))

    # ------------------------------------------------------------------ read-outs
    @property
    def coeffs(self) -> np.ndarray:
        """Versor coefficients on :attr:`blades` as a read-only float array (numeric elements)."""
        if self._coeffs is None:
            if self.versor.is_symbolic:
                raise InvalidInputError(f"a symbolic {type(self).__name__} has no numeric coefficients")
            c = np.array([float(np.asarray(x)) for x in self.versor.coeffs])
            c.setflags(write=False)
            self._coeffs = c
        return self._coeffs

    def log(self) -> Any:
        """Tangent coordinates (the slots of this group in :data:`TANGENT_BASIS`)."""
        full = log(self.versor)
        if B.is_symbolic(full):
            import casadi as ca

            return ca.vertcat(*[full[i] for i in self.tangent_slots])
        return full[..., list(self.tangent_slots)]

    def log_jacobian(self) -> np.ndarray:
        """∂ log / ∂ (similarity coefficients) at this element (7, 12), Eq 31 (see :func:`log_jacobian`)."""
        return log_jacobian(self.versor.with_blades(SIMILARITY_BLADES))

    # ------------------------------------------------------------------ group operations
    def inverse(self) -> Self:
        return type(self)(self.versor.inverse(), check=False)

    def __matmul__(self, other: VersorGroup) -> VersorGroup:
        if not isinstance(other, VersorGroup):
            return NotImplemented
        cls = _join(type(self), type(other))
        return cls((self.versor * other.versor).project(cls.blades), check=False)

    def compose(self, other: VersorGroup) -> VersorGroup:
        """``self @ other``: apply ``other`` first, then ``self``."""
        if not isinstance(other, VersorGroup):
            raise InvalidInputError(f"compose needs a versor group element, got {type(other).__name__}")
        return self @ other

    # CGA notation: the geometric product of versors is their composition and the reverse of a
    # unit versor its inverse, so ``~V1 * V2`` reads as in the paper.  A Multivector operand is
    # converted at this boundary (it must be a similarity versor).
    def __mul__(self, other: Any) -> VersorGroup:
        if isinstance(other, VersorGroup):
            return self @ other
        if isinstance(other, Multivector):
            return self @ Similarity.coerce(other, "right operand of *")
        return NotImplemented

    def __rmul__(self, other: Any) -> VersorGroup:
        if isinstance(other, Multivector):
            return Similarity.coerce(other, "left operand of *") @ self
        return NotImplemented

    def __invert__(self) -> Self:
        return self.inverse()

    def apply(self, X: Multivector) -> Multivector:
        """Sandwich ``V X Ṽ`` (Eq 6); a :class:`~coop_ga.Primitive` keeps its kind."""
        return apply(self.versor, X)

    def as_similarity(self) -> Similarity:
        return Similarity(self.versor.with_blades(SIMILARITY_BLADES), check=False)

    def __repr__(self) -> str:
        lg = self.log()
        vals = np.round(np.asarray(lg, dtype=float), 6).tolist() if not B.is_symbolic(lg) else lg
        return f"{type(self).__name__}({vals})"


def _normalised(V: Multivector, what: str) -> Multivector:
    """V / √⟨V Ṽ⟩₀ after rescaling by the largest coefficient (no overflow/underflow)."""
    big = max(float(np.max(np.abs(np.asarray(c, dtype=float)))) for c in V.coeffs)
    if not big > 0:
        raise InvalidVersorError(f"{what}: the versor is zero; a zero versor is no transformation")
    Vs = V.scale(1.0 / big)
    n2 = (Vs * Vs.reverse()).get(0)
    n2 = float(np.min(np.asarray(n2, dtype=float)))
    if not n2 > 0:
        raise InvalidVersorError(f"{what}: V Ṽ = {n2:.3g} is not positive; this is not a similarity versor")
    return Vs.scale(1.0 / np.sqrt(n2))


def _relayout(V: Multivector, blades: tuple[int, ...]) -> Multivector:
    d = V.as_dict()
    return Multivector(blades, tuple(d.get(b, 0.0) for b in blades))


class Rotor(VersorGroup):
    """Rotations (Eq 62/63); tangent ``[θ12, θ13, θ23]`` [rad]."""

    __slots__ = ()
    tangent_slots = (0, 1, 2)
    blades = ROTOR_BLADES


class Translator(VersorGroup):
    """Translations (Eq 64/65); tangent ``[t1, t2, t3]`` [m]."""

    __slots__ = ()
    tangent_slots = (4, 5, 6)
    blades = TRANSLATOR_BLADES


class Dilator(VersorGroup):
    """Uniform scaling about the origin (Eq 67–69, sign per module docstring); tangent ``[β]``, scale e^β."""

    __slots__ = ()
    tangent_slots = (3,)
    blades = DILATOR_BLADES


class Motor(VersorGroup):
    """Rigid motions V_T V_R (Eq 70–73); tangent ``[θ12, θ13, θ23, t1, t2, t3]``."""

    __slots__ = ()
    tangent_slots = (0, 1, 2, 4, 5, 6)
    blades = MOTOR_BLADES


class Similarity(VersorGroup):
    """Direct similarities V_T V_R V_D (Eq 74–77); tangent ``[θ12, θ13, θ23, β, t1, t2, t3]``.

    The currency of coop_ga: a cooperative pose V_Sc(q), a controller target V_Sd and
    :func:`coop_ga.control.displaced_target` are Similarities.  ``coeffs`` are the 12
    coefficients on :data:`SIMILARITY_BLADES`; :meth:`coerce` is the one conversion every
    public function applies to a similarity argument.

    Constructors: :meth:`exp` (tangent 7-vector), :meth:`from_coeffs`, :meth:`from_parts`
    (translation, axis–angle, scale), :meth:`between` (two primitives, §3.3), :meth:`from_unit`
    (Eq 28), :meth:`coerce` (any accepted form).
    """

    __slots__ = ()
    tangent_slots = (0, 1, 2, 3, 4, 5, 6)
    blades = SIMILARITY_BLADES

    def decompose(self) -> tuple[Translator, Rotor, Dilator]:
        """``(V_T, V_R, V_D)`` with ``self = V_T V_R V_D`` up to a positive scale."""
        VT, VR, VD = decompose(self.versor)
        return Translator(VT, check=False), Rotor(VR, check=False), Dilator(VD, check=False)

    @property
    def translation(self) -> np.ndarray:
        """t (3,) [m] of ``self = V_T(t) V_R V_D``."""
        return _parts(self)[0]

    @property
    def rotation_matrix(self) -> np.ndarray:
        """3×3 rotation matrix of V_R."""
        return _parts(self)[1]

    @property
    def scale(self) -> float:
        """Scale factor e^β of V_D (dimensionless)."""
        return _parts(self)[2]

    @classmethod
    def from_parts(
        cls, translation: Any = (0.0, 0.0, 0.0), axis: Any = (0.0, 0.0, 1.0), angle: float = 0.0, scale: float = 1.0
    ) -> Similarity:
        """``T(translation) · R(axis, angle) · D(log scale)``: scale about the origin, rotate by
        ``angle`` [rad] right-handed about ``axis`` (3,), then translate by ``translation`` (3,) [m]."""
        t = _finite_vector(translation, 3, "translation")
        ax = _finite_vector(axis, 3, "axis")
        nrm = float(np.linalg.norm(ax))
        if not nrm > 0:
            raise InvalidInputError("axis must be a non-zero 3-vector")
        ax = ax / nrm
        angle = _finite_scalar(angle, "angle")
        scale = _finite_scalar(scale, "scale")
        if not scale > 0:
            raise InvalidInputError(f"scale must be > 0, got {scale}")
        # rotation by +angle about ax: θ12 = ax_z, θ13 = −ax_y, θ23 = ax_x (TANGENT_BASIS convention)
        R = cls.exp([angle * ax[2], -angle * ax[1], angle * ax[0], 0.0, 0.0, 0.0, 0.0])
        return cls.exp([0.0, 0.0, 0.0, 0.0, *t]) @ R @ cls.exp([0.0, 0.0, 0.0, float(np.log(scale)), 0.0, 0.0, 0.0])  # type: ignore[return-value]

    @classmethod
    def between(cls, X_from: Multivector, X_to: Multivector) -> Similarity:
        """The similarity with ``X_to ∝ V X_from Ṽ`` (§3.3, Eq 20; :func:`coop_ga.geometry.similarity`)."""
        from .similarity import similarity

        return cls(similarity(X_from, X_to))

    @classmethod
    def from_unit(cls, X: Multivector) -> Similarity:
        """V_S(X_u, X), mapping the unit primitive of X's kind onto X (Eq 28)."""
        from .similarity import similarity_from_unit

        return cls(similarity_from_unit(X))

    @classmethod
    def coerce(cls, value: Any, what: str = "target") -> Similarity:
        """The one conversion of a similarity argument (targets, poses): returns a :class:`Similarity`.

        Accepted: a :class:`Similarity` (returned as is), any other versor group element
        (:meth:`~VersorGroup.as_similarity`), or a numeric similarity-versor
        :class:`~coop_ga.Multivector` (validated and normalised).  Everything else raises
        :class:`~coop_ga.InvalidInputError` naming ``what``, what was passed and what is
        expected — a :class:`~coop_ga.Primitive`, a tuple (e.g. the ``(V, X)`` pair older
        versions of ``displaced_target`` returned), a raw array, a zero or non-versor
        multivector, a symbolic one.
        """
        if type(value) is cls:
            return value
        if isinstance(value, Similarity):
            return cls(value.versor, check=False)
        if isinstance(value, VersorGroup):
            return value.as_similarity()
        from .primitives import Primitive

        if isinstance(value, Primitive):
            raise InvalidInputError(
                f"{what} must be a coop_ga.Similarity, got a Primitive ({value.kind}); the similarity that maps "
                f"the unit {value.kind} onto it is coop_ga.Similarity.from_unit(X)"
            )
        if isinstance(value, Multivector):
            if value.is_symbolic:
                raise InvalidInputError(f"{what} must be a numeric similarity, got a symbolic (CasADi) Multivector")
            try:
                return cls(value)
            except InvalidInputError as exc:
                raise type(exc)(f"{what} is not a similarity versor: {exc}") from None
        if isinstance(value, tuple):
            raise InvalidInputError(
                f"{what} must be a coop_ga.Similarity, got a tuple of length {len(value)}; displaced_target() "
                "returns a Similarity (its primitive is target.apply(task.unit))"
            )
        if isinstance(value, (np.ndarray, list)):
            raise InvalidInputError(
                f"{what} must be a coop_ga.Similarity, got a {type(value).__name__} of shape {np.shape(value)}; "
                "12 versor coefficients convert with coop_ga.Similarity.from_coeffs(v), a tangent 7-vector "
                "with coop_ga.Similarity.exp(b)"
            )
        raise InvalidInputError(f"{what} must be a coop_ga.Similarity, got {type(value).__name__}")


#: A similarity argument (targets, poses): what :meth:`Similarity.coerce` accepts — a :class:`Similarity`, any
#: other versor group element (:class:`Motor`, :class:`Rotor`, :class:`Translator`, :class:`Dilator`: a similarity
#: without scale or rotation) or a numeric similarity-versor :class:`~coop_ga.Multivector` on
#: :data:`SIMILARITY_BLADES`.  Every solver converts it once with :func:`coop_ga.validation.target`.
SimilarityLike: TypeAlias = VersorGroup | Multivector

# validation.target converts similarity arguments with this; validation sits below this layer and does not
# import it, so the conversion is handed down here (coop_ga/__init__ imports this module)
validation.similarity_coerce = Similarity.coerce


def _parts(S: Similarity) -> tuple[np.ndarray, np.ndarray, float]:
    R, beta, t = _decompose_coeffs(S.versor)
    return (
        np.array([float(x) for x in t]),
        np.array(rotor_matrix((float(R[0]), float(R[1]), float(R[2]), float(R[3]))), dtype=float),
        float(np.exp(float(beta))),
    )


def _finite_vector(x: Any, n: int, what: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{what} must be {n} real numbers, got {x!r}") from None
    if a.shape != (n,):
        raise InvalidInputError(f"{what} must have {n} entries, got shape {np.shape(x)}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{what} contains NaN or inf: {a.tolist()}")
    return a


def _finite_scalar(x: Any, what: str) -> float:
    if isinstance(x, (bool, np.bool_, str, bytes)) or (not np.isscalar(x) and np.ndim(x) != 0):
        raise InvalidInputError(f"{what} must be a real number, got {x!r}")
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{what} must be a real number, got {x!r}") from None
    if not np.isfinite(v):
        raise NonFiniteError(f"{what} must be finite, got {v}")
    return v


def _join(a: type[VersorGroup], b: type[VersorGroup]) -> type[VersorGroup]:
    if a is b:
        return a
    rigid = {Rotor, Translator, Motor}
    if a in rigid and b in rigid:
        return Motor
    return Similarity
