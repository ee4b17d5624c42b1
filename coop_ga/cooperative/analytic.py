"""Route (a): closed-form similarity Jacobians (paper Eq 29 and Appendix B, corrected and extended).

Given the cooperative primitive X_c and its Jacobian columns ∂X_c/∂q_j (Eq 15, from
the point Jacobians of Eq 16–17), the analytic similarity Jacobian follows from the
factorisation ``V_Sc = V_T V_R V_D`` by the product rule (Eq 29)::

    J^A = J_T V_R V_D + V_T J_R V_D + V_T V_R J_D

with closed-form derivatives of the read-outs (center c, radius r, axis o) that build
the factors (see :mod:`coop_ga.geometry.similarity`).  No automatic differentiation is
involved: every line below is a hand-derived derivative, which is the point — it is
checked against CasADi AD and central finite differences in
``tests/cooperative/test_jacobians.py``.

Corrections to Appendix B (which covers only the circle):

* Eq 82 (dilator): with ``V_D = cosh(β/2) + sinh(β/2) e0∞`` and ``β = log r``, the
  derivative is ``J_D = ½ (sinh(β/2) + cosh(β/2) e0∞) · ∂r/r``; the printed factor
  ``−¼ (P∞ P̃∞)⁻¹ …`` goes with the printed (inverted) dilator sign of Eq 67.
* Eq 85/87 (normalisation, Eq 79): for a rotor ``N = 1 + o u`` the bracket
  ``N Ñ'+ N' Ñ`` is a scalar, ``2 (u · ∂o)``; we use Eq 79 with that scalar.
* Eq 86 ``J_R = e3·J_N − e3∧J_N`` is the derivative of ``e3 N`` up to the reversal
  convention; we write the rotor as ``1 + o u`` (u the unit axis, o the current axis),
  which maps u onto o (Eq 26 with the ``N2∧N2`` typo fixed).
* Eq 90 (translator): ``J_T = −½ ∂c e∞`` with ∂c from the center point ``P_c = X e∞ X``
  (Eq 27) normalised by its e0 weight: ``∂c = (∂x w − x ∂w)/w²``.

Line and plane (flats) use the closest point to the origin instead of a center, and
have no dilation; point pairs and lines use the direction ``o ∝ ⟨X ∧ e∞⟩_{e0i∞}``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..algebra.basis import blade_index
from ..algebra.multivector import Multivector
from ..geometry.groups import SIMILARITY_BLADES, bivector_to_tangent
from ..geometry.kinds import KIND_SPECS, Kind

__all__ = ["analytic_similarity_jacobian", "readout_derivatives"]


def _b(n: str) -> int:
    return blade_index(n)[0]


_EINF = Multivector.blade("einf")
_I5 = Multivector.blade("e0123inf")
_E0, _E1, _E2, _E3, _EI = _b("e0"), _b("e1"), _b("e2"), _b("e3"), _b("einf")
_E0IINF = tuple(_b(n) for n in ("e01inf", "e02inf", "e03inf"))
_EIJINF = tuple(_b(n) for n in ("e23inf", "e13inf", "e12inf"))


def _v3(X: Multivector, blades: Sequence[int]) -> list[Any]:
    return [X.get(k) for k in blades]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _unit_and_derivative(v, dv):
    """u = v/|v| and ∂u = (∂v − u (u·∂v))/|v|."""
    n = float(np.sqrt(_dot(v, v)))
    u = [x / n for x in v]
    ud = _dot(u, dv)
    return u, [(dv[i] - u[i] * ud) / n for i in range(3)]


def _center_and_derivative(X: Multivector, dX: Multivector):
    """Eq 27: P_c = X e∞ X, c = x/w;  ∂P_c = ∂X e∞ X + X e∞ ∂X."""
    Pc = X * _EINF * X
    dPc = dX * _EINF * X + X * _EINF * dX
    w, dw = Pc.get(_E0), dPc.get(_E0)
    x, dx = _v3(Pc, (_E1, _E2, _E3)), _v3(dPc, (_E1, _E2, _E3))
    return [xi / w for xi in x], [(dx[i] * w - x[i] * dw) / (w * w) for i in range(3)]


def _radius_and_derivative(X: Multivector, dX: Multivector):
    """r² = −⟨X X̃⟩ / ⟨D D̃⟩ with D = e∞⌋X (Eq 24 corrected); ∂⟨A Ã⟩ = 2⟨∂A Ã⟩."""
    num = X.norm_squared()
    dnum = 2.0 * (dX * X.reverse()).get(0)
    D, dD = _EINF | X, _EINF | dX
    den = D.norm_squared()
    dden = 2.0 * (dD * D.reverse()).get(0)
    r2 = -num / den
    dr2 = -(dnum * den - num * dden) / (den * den)
    r = float(np.sqrt(r2))
    return r, dr2 / (2.0 * r)


def _line_direction(L: Multivector, dL: Multivector):
    return _unit_and_derivative(_v3(L, _E0IINF), _v3(dL, _E0IINF))


def _plane_dual(E: Multivector, dE: Multivector):
    """E I = w (n + δ e∞): returns (w n, w δ) and their derivatives (linear in E)."""
    Ed, dEd = E * _I5, dE * _I5
    return _v3(Ed, (_E1, _E2, _E3)), Ed.get(_EI), _v3(dEd, (_E1, _E2, _E3)), dEd.get(_EI)


def readout_derivatives(kind: Kind, X: Multivector, dX: Multivector):
    """(c, ∂c, r, ∂r, o, ∂o) of a primitive and a batch of perturbations dX (coefficient arrays).

    r/∂r are None for points and flats; o/∂o None for points and spheres.  A round's axis is its carrier
    flat's (X ∧ e∞: the line through a point pair, the plane of a circle).
    """
    spec = KIND_SPECS[kind]
    r = dr = o = do = None
    if spec.n_points == 1:  # a point
        c = [X.get(k) / X.get(_E0) for k in (_E1, _E2, _E3)]
        w, dw = X.get(_E0), dX.get(_E0)
        dc = [(dX.get(k) * w - X.get(k) * dw) / (w * w) for k in (_E1, _E2, _E3)]
    elif spec.has_radius:
        c, dc = _center_and_derivative(X, dX)
        r, dr = _radius_and_derivative(X, dX)
        if spec.axis_role == "direction":
            o, do = _line_direction(X ^ _EINF, dX ^ _EINF)
        elif spec.axis_role == "normal":
            wn, _, dwn, _ = _plane_dual(X ^ _EINF, dX ^ _EINF)
            o, do = _unit_and_derivative(wn, dwn)
    elif spec.axis_role == "direction":  # a line
        d, dd = _v3(X, _E0IINF), _v3(dX, _E0IINF)
        m = [X.get(_EIJINF[0]), -X.get(_EIJINF[1]), X.get(_EIJINF[2])]
        dm = [dX.get(_EIJINF[0]), -dX.get(_EIJINF[1]), dX.get(_EIJINF[2])]
        d2 = _dot(d, d)
        dd2 = 2.0 * _dot(d, dd)
        p = _cross(d, m)
        dp = [a + b for a, b in zip(_cross(dd, m), _cross(d, dm))]
        c = [pi / d2 for pi in p]
        dc = [(dp[i] * d2 - p[i] * dd2) / (d2 * d2) for i in range(3)]
        o, do = _unit_and_derivative(d, dd)
    else:  # plane
        wn, wd, dwn, dwd = _plane_dual(X, dX)
        n2 = _dot(wn, wn)
        dn2 = 2.0 * _dot(wn, dwn)
        c = [wd * v / n2 for v in wn]
        dc = [((dwd * wn[i] + wd * dwn[i]) * n2 - wd * wn[i] * dn2) / (n2 * n2) for i in range(3)]
        o, do = _unit_and_derivative(wn, dwn)
    return c, dc, r, dr, o, do


def analytic_similarity_jacobian(
    kind: Kind, X: Multivector, dX: Multivector
) -> tuple[Multivector, np.ndarray, np.ndarray]:
    """V_Sc, J^A (12×m, rows on SIMILARITY_BLADES) and J^G (7×m) from X_c and ∂X_c/∂q.

    ``dX`` is one multivector whose coefficients are arrays of length m (one entry per
    joint), e.g. from :func:`coop_ga.cooperative.primitive_jacobian` stacked.
    """
    c, dc, r, dr, o, do = readout_derivatives(kind, X, dX)
    m = len(np.atleast_1d(dc[0]))
    zeros = np.zeros(m)
    # V_T = 1 − ½ c e∞ (c2 − s R c1 = c because the unit primitive is centred at 0)
    T = Multivector((0, _b("e1inf"), _b("e2inf"), _b("e3inf")), (1.0, -0.5 * c[0], -0.5 * c[1], -0.5 * c[2]))
    dT = Multivector((0, _b("e1inf"), _b("e2inf"), _b("e3inf")), (zeros, -0.5 * dc[0], -0.5 * dc[1], -0.5 * dc[2]))
    # V_R = N/|N|, N = 1 + o u  (Eq 26 corrected), normalised with Eq 79
    if o is not None:
        u = KIND_SPECS[kind].axis
        assert u is not None  # o is read only for kinds with an axis
        U = Multivector((_E1, _E2, _E3), u)
        N = 1.0 + Multivector((_E1, _E2, _E3), tuple(o)) * U
        dN = Multivector((_E1, _E2, _E3), tuple(do)) * U
        nn = N.norm_squared()  # = 2(1 + o·u)
        dnn = 2.0 * (dN * N.reverse()).get(0)
        R = N.scale(nn**-0.5)
        dR = dN.scale(nn**-0.5) - N.scale(0.5 * nn**-1.5) * Multivector.scalar(dnn)
    else:
        R = Multivector.scalar(1.0)
        dR = Multivector.scalar(zeros)
    # V_D = cosh(β/2) + sinh(β/2) e0∞, β = log r
    e0i = _b("e0inf")
    if r is not None:
        beta = float(np.log(r))
        ch, sh = np.cosh(0.5 * beta), np.sinh(0.5 * beta)
        dbeta = dr / r
        D = Multivector((0, e0i), (ch, sh))
        dD = Multivector((0, e0i), (0.5 * sh * dbeta, 0.5 * ch * dbeta))
    else:
        D = Multivector.scalar(1.0)
        dD = Multivector.scalar(zeros)
    V = (T * R * D).with_blades(SIMILARITY_BLADES)
    JA = (dT * R * D + T * dR * D + T * R * dD).with_blades(SIMILARITY_BLADES)  # Eq 29
    JG_biv = (V.reverse() * JA).grade(2).scale(-2.0)  # Eq 30
    JA_mat = np.array([np.broadcast_to(np.asarray(JA.get(k), float), (m,)) for k in SIMILARITY_BLADES])
    JG = np.array([np.broadcast_to(np.asarray(t, float), (m,)) for t in bivector_to_tangent(JG_biv)])
    return V, JA_mat, JG
