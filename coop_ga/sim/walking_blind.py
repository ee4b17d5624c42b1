"""Blind footholds that keep the shins off risers the walker has not seen: the probing swing.

Blind (:class:`~coop_ga.sim.walking.WalkingOptions` ``blind=True``), a foot lands where the touch sensor says
the ground is; the foot ball then clears the terrain, but the shin capsule (radius 24.7 mm, 15.7 mm wider than
the 9 mm ball, its end cap ~33 mm up the tibia) reaches further: as the body moves over a stance foot its tibia
turns upright, and a riser standing a little ahead of the foot meets the shin, not the ball.  Measured in MuJoCo
(the short ripple walk on steps, blind): a front foot landed with its ball 1 mm short of the second riser and its
shin leaned on the riser's top edge for 1.8 s (1796 physics steps, up to 2.6 mm deep).

Nothing the foot feels at such a touchdown tells the riser is there, so the swing looks for it first: it ends
with a **probe** — the arc goes :func:`shin_reach` − r past the foothold at ``probe_height`` above the expected
ground (the ball's bottom; risers lower than that cannot reach the shin), comes back over the foothold and
descends onto it.  A riser within the shin's reach is then a face the moving ball touches (its contact normal is
horizontal: the walker's ``face_tilt`` test) and the walker steps over it onto the tread (the shin leaning back
over the edge stays above the tread: its end cap is above the ball's lowest point); a tread higher than
expected is touched on the way and is the foothold.

:func:`shin_reach` is the geometric part: per leg, how far ahead of the foot-ball centre (along the walking
direction) a riser of height ``guard`` [m] must stand for every leg capsule (coxa, femur, shin;
:func:`coop_ga.legged.contact.leg_segments`) to clear it at every body pose of a stance — the nominal stance
(:func:`~coop_ga.sim.walking.nominal_feet`) with the body moved over the stroke along x and raised by up to
``rise`` (a body standing higher over this foot, e.g. when the other feet are on a higher tread).  For the
registered hexapod (0.08 m stroke, 1.5 cm rise) toward a 3 cm riser: 18.9 mm for the front legs, 25.9 mm for the
middle, 39.4 mm for the rear legs (whose knees stand ahead of their feet); toward the walker's default guard of
3.5 cm: 21.0, 27.4 and 42.1 mm, so that the probes reach 15, 21 and 36 mm past the foothold.

Cost: the probing arc covers the stroke plus the probe, and the way back the probe again, in the same swing time
(the joint targets then hit the servos' speed limit more often: ``speed_limited_plans``).

The low approach
----------------
A down-step's edge *behind* the foothold is the other danger, for a leg whose shin lies behind its foot (the
front legs: :func:`shin_reach` toward −x of a 35 mm ledge 42.1 mm, toward +x 21.0 mm): the arc crosses the
edge high, and the foot descending past it lays its shin on the edge once it is more than 12 mm below its top
(19.9 mm behind the ball at 12.5 mm, 26.8 mm at 15 mm).  So such a leg's probing arc comes down to a small height
above the expected ground as far before the foothold as its shin reaches back (:func:`approach_lengths`:
33.1 mm) and goes on from there (``probe_path(approach=…, low_height=…)``): a ledge there higher than the
ball is then touched by the ball itself — the foot lands on its tread, behind the edge, or steps over its face —
and the final descent stays within what the shin clears.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..legged.gait import swing_arc

__all__ = ["PROBE_DESCENT", "approach_lengths", "probe_path", "probe_reaches", "riser_distance", "shin_reach"]

#: the fraction of a probing swing that descends onto the foothold (the last part)
PROBE_DESCENT = 0.1


def _smooth(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def riser_distance(a: np.ndarray, b: np.ndarray, rho: float, guard: float, samples: int = 24) -> float:
    """The smallest distance e [m] ahead (along +x) of a riser's face from the origin such that the capsule
    (a, b, rho) — points in a frame with x the walking direction, z up from the ground — clears the riser
    {x ≥ e, z ≤ guard} (infinitely wide): a capsule point P at height w needs ``e ≥ P_x + √(ρ² − max(w − guard,
    0)²)`` where ``w − guard < ρ``.  −inf when no point is low enough to reach it."""
    t = np.linspace(0.0, 1.0, samples)[:, None]
    P = a + t * (b - a)
    over = np.maximum(P[:, 2] - guard, 0.0)
    low = over < rho
    if not np.any(low):
        return -math.inf
    return float(np.max(P[low, 0] + np.sqrt(rho * rho - over[low] ** 2)))


def shin_reach(
    legs: Any,
    options: Any,
    *,
    guard: float = 0.03,
    stroke: float = 0.08,
    rise: float = 0.015,
    direction: Any = (1.0, 0.0),
) -> np.ndarray:
    """(6,) [m] per leg (:data:`~coop_ga.sim.hexapod.HEXAPOD_LEGS` order): how far from its foot-ball centre,
    along ``direction`` (a horizontal vector in the body frame; default +x, ahead), a ledge of height ``guard``
    must stand for the leg's capsules to clear it over a stance (module docstring): body positions over
    ``stroke`` [m] along x around the nominal stance, raised by 0 … ``rise`` [m]; the foot's ground at z = 0.
    Toward −x it is the distance a foot must keep past the edge of a tread it stepped down from."""
    from ..legged.contact import leg_segments
    from .walking import nominal_feet
    from .walking_kin import FastLegs

    u = np.asarray(direction, float).reshape(-1)[:2]
    nu = float(np.hypot(u[0], u[1]))
    if not nu > 0.0:
        raise ValueError(f"direction must be a nonzero horizontal vector, got {direction!r}")
    u = u / nu
    to_u = np.array([[u[0], u[1], 0.0], [-u[1], u[0], 0.0], [0.0, 0.0, 1.0]])  # x' along the direction
    fl = FastLegs(legs)
    r = float(legs.foot_radius)
    nom = nominal_feet(legs, options)
    feet = nom + np.array([0.0, 0.0, options.ride_height + r])  # ball centres on the ground z = 0 (W = B + lift)
    out = np.full(6, -math.inf)
    order = [list(legs.legs).index(n) for n in _hexapod_legs()]
    for dx in np.linspace(-0.5 * stroke, 0.5 * stroke, 5):
        for dz in (0.0, 0.5 * rise, rise):
            body = np.array([dx, 0.0, options.ride_height + r + dz])
            q, margin = fl.ik(feet - body)
            if np.any(margin < 0):
                continue  # beyond the legs' reach: not a stance pose
            A, B, rho = leg_segments(legs, body, np.eye(3), q)
            for i, j in enumerate(order):
                origin = np.array([feet[i, 0], feet[i, 1], 0.0])
                for k in range(3):
                    a, b = to_u @ (A[j, k] - origin), to_u @ (B[j, k] - origin)
                    out[i] = max(out[i], riser_distance(a, b, float(rho[k]), guard))
    return np.maximum(out, r)


def probe_reaches(legs: Any, options: Any) -> np.ndarray:
    """(6,) [m] how far each leg's blind swing probes past its foothold (:class:`~coop_ga.sim.walking.WalkingOptions`
    ``probe_guard``, ``probe_margin``): its :func:`shin_reach` toward a ``probe_guard`` riser − the ball's radius +
    ``probe_margin``; zeros unless blind with feedback and ``probe_guard`` > 0 (no probe)."""
    if not (options.blind and options.feedback and options.probe_guard > 0):
        return np.zeros(6)
    reach = shin_reach(legs, options, guard=options.probe_guard)
    return np.maximum(reach - float(legs.foot_radius), 0.0) + options.probe_margin


def approach_lengths(legs: Any, options: Any) -> np.ndarray:
    """(6,) [m] how far before its foothold each leg's blind probing swing comes down to the probe's height
    (module docstring, "The low approach"): for a leg whose shin lies behind its foot (its :func:`shin_reach`
    toward −x beyond that toward +x, both toward a ``probe_guard`` ledge: the front legs, 42.1 vs 21.0 mm for the
    registered hexapod) that reach − the ball's radius (33.1 mm); zeros for the other legs and unless blind with
    feedback and ``probe_guard`` > 0 (no probe)."""
    if not (options.blind and options.feedback and options.probe_guard > 0):
        return np.zeros(6)
    back = shin_reach(legs, options, guard=options.probe_guard, direction=(-1.0, 0.0))
    ahead = shin_reach(legs, options, guard=options.probe_guard)
    return np.where(back > ahead + 1e-9, back - float(legs.foot_radius), 0.0)


def _hexapod_legs() -> tuple[str, ...]:
    from .hexapod import HEXAPOD_LEGS

    return HEXAPOD_LEGS


def probe_path(
    p0: np.ndarray,
    p1: np.ndarray,
    lift: float,
    reach: float,
    height: float,
    s: np.ndarray,
    direction: np.ndarray | None = None,
    approach: float = 0.0,
    low_height: float | None = None,
) -> np.ndarray:
    """A probing swing (module docstring) sampled at progress ``s`` (n,) → (n, 3) [m]: :func:`swing_arc` from
    ``p0`` (3,) to the far point ``reach`` [m] past ``p1`` (3,) along ``direction`` (horizontal; default: the
    swing's, ``p1 − p0``) at ``height`` [m] above ``p1``, back over ``p1`` at that height, then down to ``p1`` over
    the last :data:`PROBE_DESCENT` of the swing (each part at rest at its ends).  The arc and the way back share
    the rest so that their horizontal speeds peak alike (the arc moves horizontally over the middle 60 % of its
    time): the arc ends at ``f = (1 − PROBE_DESCENT) (L + reach) / (L + 1.6 reach)`` (L: the swing's horizontal
    length).  With ``approach`` [m] > 0 the arc comes down ``approach`` before ``p1`` (at most half of L) to
    ``low_height`` [m] above ``p1`` (default ``height``) and the foot goes on from there straight to the far
    point (module docstring, "The low approach"); the arc, that straight part and the way back then share the
    time in proportion to 2.5 × and 1.5 × their horizontal lengths (their peak speeds over their means).  Without a direction (a swing shorter
    than 5 mm horizontally) or reach it is the plain arc."""
    d = np.asarray((p1 - p0) if direction is None else direction, float)[:2]
    nd = float(np.hypot(d[0], d[1]))
    if nd < 0.005 or reach <= 0.0:
        return swing_arc(p0, p1, lift, s)[0]
    u = np.array([d[0] / nd, d[1] / nd, 0.0])
    top = np.array([p1[0], p1[1], p1[2] + height])
    far = top + reach * u
    L = float(np.hypot(*(far - p0)[:2])) - reach
    a = min(max(approach, 0.0), 0.5 * L)
    f2 = 1.0 - PROBE_DESCENT
    f1 = f2 * (L + reach) / (L + 1.6 * reach)
    fa = f2 * 2.5 * (L - a) / (2.5 * (L - a) + 1.5 * (a + 2.0 * reach)) if a > 0.0 else f1
    low = top - a * u  # where the arc comes down (to the probe's height, or low_height above p1)
    if low_height is not None:
        low[2] = p1[2] + low_height
    out = np.empty((len(s), 3))
    m = s <= fa
    out[m] = swing_arc(p0, low if a > 0.0 else far, lift, s[m] / fa)[0]
    if a > 0.0:  # on at that height to the far point
        f1 = fa + (f2 - fa) * (a + reach) / (a + 2.0 * reach)
        m = (s > fa) & (s <= f1)
        out[m] = low + _smooth((s[m] - fa) / (f1 - fa))[:, None] * (far - low)
    b = (s > f1) & (s <= f2)
    out[b] = far + _smooth((s[b] - f1) / (f2 - f1))[:, None] * (top - far)
    c = s > f2
    out[c] = top + _smooth((s[c] - f2) / (1.0 - f2))[:, None] * (p1 - top)
    return out
