"""Feasibility of what is returned: the strictly feasible references and the blends toward them (package docstring
of :mod:`coop_ga.control.ilqr`, "Feasibility of what is returned")."""

from __future__ import annotations

import numpy as np

from .problem import ReachingOCP

__all__ = ["reference_controls", "restore", "restore_joints", "strictly_inside"]


def reference_controls(ocp: ReachingOCP) -> np.ndarray:
    """A strictly feasible guess: rest, or braking to rest from q̇_init within 90 % of the acceleration limits."""
    T, n, dt = ocp.horizon, ocp.nq, ocp.dt
    u = np.zeros((T, n))
    v0 = ocp.qd_init
    if not np.any(v0):
        return u
    with np.errstate(divide="ignore"):
        t_stop = np.maximum(0.2, np.abs(v0) / (0.9 * ocp.a_max))  # [s]: at least 0.2 s, within the limit
    steps = np.minimum(np.ceil(t_stop / dt).astype(int), T)
    for j in range(n):
        if v0[j] != 0.0:
            u[: steps[j], j] = -v0[j] / (steps[j] * dt)
    return u


def restore(ocp: ReachingOCP, u: np.ndarray, u_ref: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Smallest β ∈ [0, 1] with ``(1 − β) u + β u_ref`` feasible (constraints affine in u); None if u_ref is not
    strictly feasible."""
    q, qd = ocp.rollout(u)
    qr, qdr = ocp.rollout(u_ref)
    c, cr = ocp.constraint_values(q, qd), ocp.constraint_values(qr, qdr)
    ca = np.concatenate([c.ravel(), (np.abs(u) - ocp.a_max).ravel()])
    # |u| ≤ a is convex, not affine; the blend stays within it because both ends are (u is clipped)
    cra = np.concatenate([cr.ravel(), (np.abs(u_ref) - ocp.a_max).ravel()])
    if np.max(ca, initial=-np.inf) <= 0.0:
        return u, 0.0
    if np.max(cra, initial=-np.inf) >= 0.0:
        return None
    bad = ca > 0
    beta = float(np.max(ca[bad] / (ca[bad] - cra[bad])))
    beta = min(1.0, beta * (1.0 + 1e-9) + 1e-15)
    return (1.0 - beta) * u + beta * u_ref, beta


def strictly_inside(ocp: ReachingOCP, u: np.ndarray) -> np.ndarray:
    """Per joint (nq,): whether the trajectory of ``u`` is strictly inside every bound of that joint at the knots
    1 … n (positions and velocities) and strictly below its acceleration bound."""
    q, qd = ocp.rollout(u)
    c = ocp.constraint_values(q, qd)  # (n, 4, nq), −inf where a bound is infinite
    return np.all(c < 0.0, axis=(0, 1)) & np.all(np.abs(u) < ocp.a_max, axis=0)


def _joint_inside(ocp: ReachingOCP, j: int, uj: np.ndarray) -> bool:
    """Whether joint j alone, driven by ``uj`` (n,), stays strictly inside its bounds at the knots 1 … n."""
    qd = ocp.qd_init[j] + np.cumsum(ocp.dt * uj)
    q = ocp.q_init[j] + np.cumsum(ocp.dt * np.concatenate([[ocp.qd_init[j]], qd[:-1]]) + ocp.h * uj)
    lo, hi, v, a = ocp.q_lower[j], ocp.q_upper[j], ocp.v_max[j], ocp.a_max[j]
    return bool(np.all((q > lo) & (q < hi) & (np.abs(qd) < v) & (np.abs(uj) < a)))


def _joint_reference(ocp: ReachingOCP, j: int) -> np.ndarray | None:
    """Controls (n,) of joint j alone that keep it strictly inside its bounds, or None if there are none of this form.

    Braking to rest at 90 % of the acceleration bound (10 rad/s² where it is infinite), then a bang-bang move of at
    most 0.05 rad inward (toward the middle of the range; from rest on a position bound this is what makes the
    reference strictly feasible).  A joint moving out through a bound it sits on cannot brake in time; if its
    acceleration bound allows (> 2.1 |q̇₀|/Δt, always when it is infinite) it first reverses its velocity in one knot
    ("bounce": ``u₀ = −2.1 q̇₀/Δt``, so that q₁ = q₀ − 0.05 Δt q̇₀ is inside), then brakes and moves inward.
    """
    T, dt, v0, q0 = ocp.horizon, ocp.dt, ocp.qd_init[j], ocp.q_init[j]
    a = 0.9 * ocp.a_max[j] if np.isfinite(ocp.a_max[j]) else 10.0  # [rad/s²]
    plain = _joint_inward(ocp, j, np.zeros(T), a, 0, v0, q0)
    if _joint_inside(ocp, j, plain):
        return plain
    if v0 == 0.0 or T < 3:
        return None
    bounce = np.zeros(T)
    bounce[0] = -2.1 * v0 / dt  # q̇₁ = −1.1 q̇₀, q₁ = q₀ − 0.05 Δt q̇₀
    bounce = _joint_inward(ocp, j, bounce, a, 1, -1.1 * v0, q0 - 0.05 * dt * v0)
    return bounce if _joint_inside(ocp, j, bounce) else None


def _joint_inward(ocp: ReachingOCP, j: int, uj: np.ndarray, a: float, start: int, v: float, q: float) -> np.ndarray:
    """Fill ``uj[start:]``: from velocity v at position q (knot ``start``), brake to rest at deceleration ≤ a, then move
    inward by at most 0.05 rad (k knots at +a, k at −a: rest to rest, a displacement of a (k Δt)²)."""
    T, dt = ocp.horizon, ocp.dt
    m = min(int(np.ceil(abs(v) / (a * dt))), T - start) if v != 0.0 else 0
    if m:
        uj[start : start + m] = -v / (m * dt)
    q_stop = q + 0.5 * v * m * dt  # exact for the constant deceleration (ZOH)
    lo, hi = ocp.q_lower[j], ocp.q_upper[j]
    width, rest = hi - lo, T - start - m
    if not width > 0.0 or rest < 2:
        return uj
    delta = min(0.05, 0.25 * width) if np.isfinite(width) else 0.05
    v_cap = 0.9 * ocp.v_max[j] if np.isfinite(ocp.v_max[j]) else np.inf
    a = min(a, delta / dt**2, v_cap / dt)
    k = int(max(1, min(np.floor(np.sqrt(delta / a) / dt), np.floor(v_cap / (a * dt)), rest // 2)))
    sign = 1.0 if q_stop - lo <= hi - q_stop else -1.0
    i = start + m
    uj[i : i + k] += sign * a
    uj[i + k : i + 2 * k] -= sign * a
    return uj


def restore_joints(ocp: ReachingOCP, u: np.ndarray, u_ref: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Joint-by-joint feasibility blend: ``u_j ← (1 − β_j) u_j + β_j r_j`` for each joint j that leaves a bound, with
    r_j strictly feasible for joint j (the reference ``u_ref``'s column where it is, else :func:`_joint_reference`).

    The double integrator and the bounds are separable per joint, so each β_j is exact for its joint and the other
    joints are left alone.  Used when ``u_ref`` is not strictly feasible as a whole (a start on a position bound: rest
    there is feasible, not strictly).  Returns ``(u, max β_j)``, or None if a violating joint has no strictly feasible
    reference.
    """
    q, qd = ocp.rollout(u)
    ca = np.concatenate([ocp.constraint_values(q, qd), (np.abs(u) - ocp.a_max)[:, None, :]], axis=1)  # (n, 5, nq)
    bad = np.flatnonzero(np.max(ca, axis=(0, 1)) > 0.0)
    if not bad.size:
        return u, 0.0
    ref = u_ref.copy()
    ok = strictly_inside(ocp, ref)
    for j in bad:
        if not ok[j]:
            rj = _joint_reference(ocp, int(j))
            if rj is not None:
                ref[:, j] = rj
    if not np.all(strictly_inside(ocp, ref)[bad]):
        return None
    qr, qdr = ocp.rollout(ref)
    cr = np.concatenate([ocp.constraint_values(qr, qdr), (np.abs(ref) - ocp.a_max)[:, None, :]], axis=1)
    out = u.copy()
    beta_max = 0.0
    for j in bad:
        cj, crj = ca[:, :, j].ravel(), cr[:, :, j].ravel()
        viol = cj > 0
        beta = float(np.max(cj[viol] / (cj[viol] - crj[viol])))
        beta = min(1.0, beta * (1.0 + 1e-9) + 1e-15)
        out[:, j] = (1.0 - beta) * u[:, j] + beta * ref[:, j]
        beta_max = max(beta_max, beta)
    return out, beta_max
