"""Screw exponential and logarithm of the motor and similarity groups, and interpolation (seed 001).

Seed 001 ("Path Planning and Interpolation"): ``M(t) = M0 exp(t log(M̃0 M1))`` with the
*group* exponential ``exp(−½ Λ)`` of a motor bivector ``Λ = θ L* + d n∞`` — the screw
motion about a fixed axis at constant speed.  That is **not** :func:`coop_ga.geometry.exp`: the
paper's chart (Eq 72/76) is ``V_T(t) V_R(θ) V_D(β)``, whose straight lines are the
*decoupled* path (translation lerped, rotation slerped, scale geometric).  Both share the
rotation and the scale; they differ in the translation coordinate only::

    chart:  b_chart = [θ, β, t]      V = V_T(t) V_R(θ) V_D(β)          (Eq 76)
    group:  b_screw = [θ, β, v]      V = exp(−½ B(b_screw)),   t = W(θ, β) v

with ``B(b) = tangent_to_bivector(b)`` (coop_ga.geometry.groups) and
``W = ∫₀¹ e^{τ(β I + [ω]×)} dτ``, ω = (θ23, −θ13, θ12) the rotation vector [rad] in
Euclidean coordinates.  ``(ω, v)`` is the body twist of Pinocchio's ``LOCAL`` frame:
``b_screw`` of a motor equals ``LOCAL_TO_TANGENT @ pinocchio.log6(M)`` (rows ``[ω_z, −ω_y,
ω_x, 0, v_x, v_y, v_z]``), so :func:`interpolate` of motors equals
``pinocchio.SE3.Interpolate`` (tested to 1e-12 in ``tests/geometry/test_interpolation.py``).
That ``exp(−½ B)`` is the true exponential of the bivector (its power series in the
geometric product) is also tested.

Motors (β = 0): closed forms, exact through θ → 0 (series below |θ| = 0.1)::

    W  = I + (1 − cos φ)/φ² [ω]× + (φ − sin φ)/φ³ [ω]×²,  φ = |ω|
    W⁻¹ = I − ½ [ω]× + (1 − (φ/2) cot(φ/2))/φ² [ω]×²

``W⁻¹`` is finite for φ < 2π; the logarithm returns φ ∈ [0, π], so W⁻¹ is always well
conditioned (its coefficient is 1/π² at φ = π).  A pure translation (φ = 0) gives
``v = t`` (the screw axis is at infinity, pitch ∞): the path is then a straight line.

Double cover: V and −V are the same transformation.  The logarithm first negates a
relative versor whose rotor part has a negative scalar (``coop_ga.geometry.log`` does), so the
rotation angle is in [0, π]: **interpolation takes the shortest rotation**, and
``interpolate(V0, V1, t)`` is the same path for V1 and −V1.  ``interpolate(V0, V1, 1)``
is therefore ±V1 (the same transformation); compare elements with ``apply`` or matrices,
not coefficient signs.  At exactly φ = π both directions are equally short; the one the
versor's bivector part encodes is taken (Pinocchio's log3 may choose the other).

Similarities (β ≠ 0, scale s = e^β): the group exponential of ``[θ, β, v]`` is the
one-parameter subgroup ``x ↦ e^{τβ} R(τω) x + W(τθ, τβ) v``.  The screw motion about the
body frame and the dilation about the body origin do **not** commute (``V_D V_T(t) Ṽ_D =
V_T(e^β t)``), so "screw then scale" and "scale then screw" are different paths, and
neither is a one-parameter subgroup.  We take the group exponential: for β ≠ 0 the
matrix ``βI + [ω]×`` is invertible and the path is a *spiral similarity* — a rotation
about an axis through the fixed point ``c = −(βI + [ω]×)⁻¹ v`` combined with a scaling
about c (these two do commute); the pitch of the screw is absorbed in the choice of c.
For β → 0 it tends continuously to the motor screw.  So a circle or sphere interpolated
this way keeps its kind, its radius is ``r0^{1−t} r1^{t}`` (geometric, constant log-rate),
and its centre moves on the spiral.  W is computed by ``scipy.linalg.expm`` of the 6×6
block ``[[βI + [ω]×, I], [0, 0]]`` (accurate to ~1e-15 relative; no thresholds).

Numeric only (numpy floats), not CasADi.  Cost: see ``benchmarks/motor_fk.py``.
"""

from __future__ import annotations

import math
from typing import Any, overload

import numpy as np

from ..algebra.multivector import Multivector
from ..errors import InvalidInputError
from .groups import MOTOR_BLADES, Motor, Rotor, Similarity, Translator, VersorGroup, exp, log

__all__ = ["interpolate", "reference_trajectory", "screw_axis", "screw_exp", "screw_log"]

_SERIES = 0.1  # below this rotation angle φ [rad] the W, W⁻¹ coefficients use series (truncation < 3e-16)


def _hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _omega(theta: np.ndarray) -> np.ndarray:
    """Euclidean rotation vector (3,) of the tangent slots [θ12, θ13, θ23]."""
    return np.array([theta[2], -theta[1], theta[0]])


def _w_motor(w: np.ndarray, inverse: bool) -> np.ndarray:
    """W(ω) (or W⁻¹) of the motor group, closed form with series below φ = 0.1."""
    phi2 = float(w @ w)
    phi = math.sqrt(phi2)
    K = _hat(w)
    K2 = K @ K
    if inverse:
        if phi < _SERIES:
            c = 1.0 / 12.0 + phi2 * (1.0 / 720.0 + phi2 * (1.0 / 30240.0 + phi2 / 1209600.0))
        else:
            h = 0.5 * phi
            c = (1.0 - h * math.cos(h) / math.sin(h)) / phi2
        return np.eye(3) - 0.5 * K + c * K2
    if phi < _SERIES:
        a = 0.5 - phi2 * (1.0 / 24.0 - phi2 * (1.0 / 720.0 - phi2 / 40320.0))
        b = 1.0 / 6.0 - phi2 * (1.0 / 120.0 - phi2 * (1.0 / 5040.0 - phi2 / 362880.0))
    else:
        sh = math.sin(0.5 * phi)
        a = 2.0 * sh * sh / phi2
        b = (phi - math.sin(phi)) / (phi2 * phi)
    return np.eye(3) + a * K + b * K2


def _w_similarity(w: np.ndarray, beta: float) -> np.ndarray:
    """W = ∫₀¹ exp(τ(βI + [ω]×)) dτ (3×3), by the block matrix exponential."""
    from scipy.linalg import expm

    Z = np.zeros((6, 6))
    Z[:3, :3] = beta * np.eye(3) + _hat(w)
    Z[:3, 3:] = np.eye(3)
    return np.asarray(expm(Z)[:3, 3:])


def _w(w: np.ndarray, beta: float) -> np.ndarray:
    return _w_motor(w, inverse=False) if beta == 0.0 else _w_similarity(w, beta)


def _w_inv_apply(w: np.ndarray, beta: float, t: np.ndarray) -> np.ndarray:
    if beta == 0.0:
        return _w_motor(w, inverse=True) @ t
    return np.linalg.solve(_w_similarity(w, beta), t)


def _as_element(V: Any, what: str) -> VersorGroup:
    if isinstance(V, VersorGroup):
        return V
    if isinstance(V, Multivector):
        if V.is_symbolic:
            raise InvalidInputError(f"{what}: interpolation is numeric only, got a symbolic (CasADi) Multivector")
        if all(b in MOTOR_BLADES for b in V.blades):
            return Motor(V)
        return Similarity.coerce(V, what)
    raise InvalidInputError(
        f"{what} must be a Motor, Similarity (or Rotor, Translator, Dilator) or a numeric versor Multivector, "
        f"got {type(V).__name__}"
    )


def _rigid(V: VersorGroup) -> bool:
    return isinstance(V, (Motor, Rotor, Translator))


def _tangent7(b: Any) -> tuple[np.ndarray, bool]:
    a = np.asarray(b, dtype=float) if not isinstance(b, Multivector) else None
    if a is None or a.shape not in ((6,), (7,)):
        raise InvalidInputError(
            "screw tangent must be a 6-vector [θ12, θ13, θ23, v1, v2, v3] (motor) or a 7-vector "
            f"[θ12, θ13, θ23, β, v1, v2, v3] (similarity), got {type(b).__name__} of shape {np.shape(b)}"
        )
    if not np.all(np.isfinite(a)):
        raise InvalidInputError(f"screw tangent contains NaN or inf: {a.tolist()}")
    if a.shape == (6,):
        return np.array([a[0], a[1], a[2], 0.0, a[3], a[4], a[5]]), True
    return a.copy(), False


def screw_log(V: Any) -> np.ndarray:
    """Screw logarithm: the group tangent ``b`` (7,) with ``V = ±exp(−½ B(b))`` (module docstring).

    ``V``: a :class:`Motor`/:class:`Similarity` (or subgroup element, or numeric versor
    Multivector).  Returns ``[θ12, θ13, θ23, β, v1, v2, v3]`` in the slots of
    :data:`~coop_ga.geometry.groups.TANGENT_BASIS`: θ [rad] the rotation (angle |θ| in
    [0, π], the shortest of the double cover), β = log scale (0 for motors), v [m] the
    translational part of the twist (``v = W⁻¹ t``, not the translation t of the chart
    :func:`coop_ga.geometry.log`).  For a motor, ``b[[0,1,2,4,5,6]] == LOCAL_TO_TANGENT @ log6(M)``
    without the β row (Pinocchio's ``LOCAL`` twist ``[v; ω]``).
    """
    E = _as_element(V, "V")
    lg = np.asarray(log(E.versor), dtype=float)
    theta, beta, t = lg[0:3], float(lg[3]), lg[4:7]
    if _rigid(E):
        beta = 0.0
    v = _w_inv_apply(_omega(theta), beta, t)
    return np.array([theta[0], theta[1], theta[2], beta, v[0], v[1], v[2]])


def screw_exp(b: Any) -> VersorGroup:
    """Screw (group) exponential ``exp(−½ B(b))`` (seed 001 "Motor Logarithm", inverse of :func:`screw_log`).

    ``b``: a 6-vector ``[θ12, θ13, θ23, v1, v2, v3]`` → :class:`Motor`, or a 7-vector
    ``[θ12, θ13, θ23, β, v1, v2, v3]`` → :class:`Similarity`; θ [rad], β log-scale, v [m].
    Any finite θ is accepted (|θ| > π wraps; ``screw_log`` returns the shortest tangent).
    """
    a, motor = _tangent7(b)
    theta, beta, v = a[0:3], float(a[3]), a[4:7]
    t = _w(_omega(theta), beta) @ v
    V = exp(np.array([theta[0], theta[1], theta[2], beta, t[0], t[1], t[2]]))
    if motor:
        return Motor(V.project(MOTOR_BLADES), check=False)
    return Similarity(V, check=False)


def screw_axis(M: Any) -> dict[str, Any]:
    """Screw parameters of a motor (Chasles; seed 001 ``log M = ½(θ L* + d n∞)``).

    Returns ``{"angle": θ [rad] in [0, π], "translation": d [m] along the axis,
    "direction": unit axis (3,), "point": the axis point closest to the origin (3,) [m] or
    None, "pitch": d/θ [m/rad] or inf}``.  For a pure translation (θ = 0) the axis is at
    infinity: direction = t/|t|, point None, pitch inf; for the identity direction is
    (0, 0, 1) by convention and d = 0.
    """
    E = _as_element(M, "M")
    if not _rigid(E) and abs(float(np.asarray(log(E.versor))[3])) > 1e-12:
        raise InvalidInputError(
            "screw_axis(M) needs a rigid motion (a Motor); a similarity with scale ≠ 1 has no screw"
        )
    b = screw_log(E)
    w = _omega(b[0:3])
    v = b[4:7]
    phi = float(np.linalg.norm(w))
    if phi == 0.0:
        n = float(np.linalg.norm(v))
        u = v / n if n > 0 else np.array([0.0, 0.0, 1.0])
        return {"angle": 0.0, "translation": n, "direction": u, "point": None, "pitch": math.inf}
    u = w / phi
    d = float(u @ v)
    c = np.cross(w, v) / (phi * phi)
    return {"angle": phi, "translation": d, "direction": u, "point": c, "pitch": d / phi}


def _times(t: Any) -> tuple[np.ndarray, bool]:
    if isinstance(t, (bool, np.bool_, str, bytes)) or t is None:
        raise InvalidInputError(f"t must be a real number or a 1-D array of them, got {t!r}")
    try:
        a = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(f"t must be a real number or a 1-D array of them, got {t!r}") from None
    if a.ndim > 1:
        raise InvalidInputError(f"t must be a scalar or 1-D, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InvalidInputError(f"t must be finite, got {a.tolist()}")
    return a.reshape(-1), a.ndim == 0


@overload
def interpolate(V0: Any, V1: Any, t: float, *, path: str = "screw") -> VersorGroup: ...
@overload
def interpolate(V0: Any, V1: Any, t: Any, *, path: str = "screw") -> VersorGroup | list[VersorGroup]: ...
def interpolate(V0: Any, V1: Any, t: Any, *, path: str = "screw") -> VersorGroup | list[VersorGroup]:
    """``V(t) = V0 exp(t log(Ṽ0 V1))`` with the screw exponential/logarithm (seed 001; module docstring).

    ``V0, V1``: motors or similarities (group elements, or numeric versor Multivectors).
    ``t``: a real number → one element; a 1-D array (N,) → a ``list`` of N elements.  The
    result is a :class:`Motor` when both ends are rigid (Motor, Rotor, Translator),
    otherwise a :class:`Similarity`.  t ∈ [0, 1] goes from V0 to ±V1 (module docstring,
    double cover: the shortest rotation); other t extrapolate along the same
    one-parameter subgroup.  The relative motion is in V0's (body) frame, as
    ``pinocchio.SE3.Interpolate(A, B, t) = A exp6(t log6(A⁻¹ B))``.

    ``path="screw"`` (default): constant screw velocity (motors: rotation about and
    translation along one fixed axis; similarities: spiral similarity about a fixed point,
    scale ``s^t``).  ``path="chart"``: the straight line of the paper's chart
    (Eq 76), ``V0 exp_chart(t log_chart(Ṽ0 V1))`` = lerp of the position, slerp of the
    rotation, geometric scale — the decoupled path, for comparison.
    """
    if path not in ("screw", "chart"):
        raise InvalidInputError(f"path must be 'screw' or 'chart', got {path!r}")
    A = _as_element(V0, "V0")
    Bm = _as_element(V1, "V1")
    ts, scalar = _times(t)
    rigid = _rigid(A) and _rigid(Bm)
    A = A if rigid else A.as_similarity()
    if rigid and not isinstance(A, Motor):
        A = Motor(A.versor.with_blades(MOTOR_BLADES), check=False)
    D = A.inverse() @ Bm
    out: list[VersorGroup] = []
    if path == "chart":
        lg = np.asarray(log(D.versor), dtype=float)
        if rigid:
            lg[3] = 0.0
        for s in ts:
            E = exp(s * lg)
            step: VersorGroup = Motor(E.project(MOTOR_BLADES), check=False) if rigid else Similarity(E, check=False)
            out.append(A @ step)
    else:
        b = screw_log(D)
        bb = b[[0, 1, 2, 4, 5, 6]] if rigid else b
        for s in ts:
            out.append(A @ screw_exp(s * bb))
    return out[0] if scalar else out


def reference_trajectory(
    V0: Any, V1: Any, duration: float, n: int, *, profile: str = "minimum_jerk"
) -> tuple[np.ndarray, list[VersorGroup], np.ndarray]:
    """A smooth reference from V0 to V1 along the screw path, for the (cooperative) controllers.

    ``V(t) = V0 exp(s(t/T) b)``, ``b = screw_log(Ṽ0 V1)``, with the time scaling
    ``s(τ) = 10τ³ − 15τ⁴ + 6τ⁵`` (``profile="minimum_jerk"``: zero velocity and acceleration at
    both ends) or ``s(τ) = τ`` (``"linear"``: constant screw velocity).  ``duration`` T [s] > 0,
    ``n`` ≥ 2 samples.  Returns ``(t (n,) [s], poses (list of n Motors or Similarities),
    twists (n, 7))``: the body-frame velocity in :data:`~coop_ga.geometry.groups.TANGENT_BASIS`
    slots, ``ṡ(t) b`` [rad/s, 1/s, m/s] — exact, because b commutes with exp(s b) (the
    velocity bivector of Eq 8, ``−2 Ṽ V̇``, of the path).
    """
    if profile not in ("minimum_jerk", "linear"):
        raise InvalidInputError(f"profile must be 'minimum_jerk' or 'linear', got {profile!r}")
    if isinstance(duration, (bool, np.bool_)) or not isinstance(duration, (int, float, np.floating, np.integer)):
        raise InvalidInputError(f"duration must be a number of seconds, got {duration!r}")
    if not (math.isfinite(float(duration)) and float(duration) > 0):
        raise InvalidInputError(f"duration must be finite and > 0, got {duration}")
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 2:
        raise InvalidInputError(f"n must be an integer ≥ 2, got {n!r}")
    T = float(duration)
    t = np.linspace(0.0, T, int(n))
    tau = t / T
    if profile == "linear":
        sv, sd = tau, np.full_like(tau, 1.0 / T)
    else:
        sv = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)
        sd = 30.0 * tau**2 * (1.0 - tau) ** 2 / T
    A = _as_element(V0, "V0")
    Bm = _as_element(V1, "V1")
    rigid = _rigid(A) and _rigid(Bm)
    poses = interpolate(A, Bm, sv)
    assert isinstance(poses, list)
    b = screw_log((A if rigid else A.as_similarity()).inverse() @ Bm)
    if rigid:
        b[3] = 0.0
    return t, poses, sd[:, None] * b[None, :]
