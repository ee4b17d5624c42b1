"""Gaits: one phase-table generator for the tripod, ripple and wave gaits of any walker with n ≥ 4 legs,
and the swing-foot arc.

Phase table
-----------
Every leg i runs the same cycle of period ``T``: it **lifts off** at the phase offset φ_i ∈ [0, 1),
swings for the fraction σ = 1 − β of the cycle (β: the duty factor, the stance fraction), touches down
at φ_i + σ and stands until the next lift-off.  With the cycle phase u_i(t) = frac(t / T − φ_i), leg i
is in swing for u_i ∈ [0, σ) and in stance for u_i ∈ [σ, 1).

Legs are numbered as in this package's LEG ORDER, generalised to n legs: the left side front → rear,
then the right side front → rear (``("lf", "lm", "lr", "rf", "rm", "rr")`` for n = 6; the left side
has ⌈n/2⌉ legs).  One formula gives every gait: with j the index of a leg on its side counted **from
the rear** and s = 0 (left) / 1 (right),

    φ(j, s) = frac(s · Δ + j · σ),

a metachronal wave running rear → front along each side, the right side shifted by Δ.

======  ======================  =========================  ===============  ==========================
gait    swing fraction σ        side shift Δ               duty β (n = 6)   legs in swing at a time
======  ======================  =========================  ===============  ==========================
tripod  1/2                     1/2 (n even only)          1/2              n/2 (the two "tripods")
ripple  2/n                     1/2 (n even), 1/n (odd)    2/3              2
wave    1/n                     ⌈n/2⌉/n (½ for n even)     5/6              1
======  ======================  =========================  ===============  ==========================

For n = 6 this gives the textbook tables (e.g. KevinOchs/hexapod_ros, mithi/hexapod, goik):
tripod groups (lf, lr, rm) at φ = 0 and (rf, lm, rr) at φ = ½ (the two tripods of the registered
``hexapod`` system); ripple lift-offs every T/6 in the order lr, rf, lm, rr, lf, rm with two legs
in the air at a time (β = 2/3); wave lr, lm, lf, rr, rm, rf, one leg at a time (β = 5/6).  For n = 4
the tripod and the ripple are both the trot (diagonal pairs), which is not statically stable.  A
tripod needs two equal halves, so it refuses an odd n.  A custom ``duty`` keeps the gait's offsets
and changes only the swing length.

Swing arc
---------
:func:`swing_arc` moves a foot from its lift-off point p0 to its foothold p1 (world frame):
the height rises from z0 to the apex z_top = max(z0, z1) + lift over the first half and falls to z1
over the second (two smoothsteps, C¹ at the apex), and the horizontal motion starts only once the foot
is clear (a delayed smoothstep).  Position and velocity (∂p/∂s) are continuous, and the velocity is
zero at lift-off and touch-down, so the arc joins the stance phase (foot at rest in the world) with a
continuous velocity: C¹ at lift-off and touch-down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InvalidInputError
from ..validation import array, choice, integer, positive, scalar

__all__ = ["GAITS", "GaitTable", "leg_names", "phase_table", "swing_arc"]

#: the gaits :func:`phase_table` builds.
GAITS: tuple[str, ...] = ("tripod", "ripple", "wave")

#: horizontal motion of :func:`swing_arc` waits this fraction of the swing at each end (pure lift / set-down).
_SWING_DELAY = 0.2
#: phases within this of a lift-off / touch-down boundary snap to it (t / T is rarely exact in floats).
_PHASE_EPS = 1e-9


#: :meth:`GaitTable.min_stance` and :meth:`GaitTable.diagram` refuse more samples than this (bounded memory)
MAX_SAMPLES = 10_000_000


def _samples(samples: Any) -> int:
    n = integer(samples, "samples", minimum=1)
    if n > MAX_SAMPLES:
        raise InvalidInputError(f"samples = {n} is above {MAX_SAMPLES} per cycle")
    return n


def leg_names(n_legs: int) -> tuple[str, ...]:
    """Leg names for ``n_legs`` legs in this package's order: left front → rear, then right front → rear.

    n = 6: ``("lf", "lm", "lr", "rf", "rm", "rr")`` (LEG ORDER); n = 4: ``("lf", "lr", "rf", "rr")``;
    otherwise ``l0 … l{k-1}``, ``r0 …`` numbered from the front."""
    n = integer(n_legs, "n_legs", minimum=4)
    if n == 6:
        return ("lf", "lm", "lr", "rf", "rm", "rr")
    if n == 4:
        return ("lf", "lr", "rf", "rr")
    n_left = (n + 1) // 2
    return tuple(f"l{i}" for i in range(n_left)) + tuple(f"r{i}" for i in range(n - n_left))


@dataclass(frozen=True)
class GaitTable:
    """A periodic gait (module docstring): leg i lifts off at phase ``offsets[i]``, swings for
    ``1 − duty`` of the cycle, then stands.

    Attributes:
        gait: "tripod" | "ripple" | "wave".
        legs: (n,) leg names in the package's leg order (:func:`leg_names`).
        offsets: (n,) lift-off phases φ_i ∈ [0, 1) [cycles].
        duty: the duty factor β ∈ (0, 1): the fraction of a cycle each leg is in stance.
        period: cycle time T [s].
    """

    gait: str
    legs: tuple[str, ...]
    offsets: np.ndarray
    duty: float
    period: float = 1.0

    def __post_init__(self) -> None:
        choice(self.gait, GAITS, "gait")
        if isinstance(self.legs, str) or not all(isinstance(x, str) for x in self.legs) or not self.legs:
            raise InvalidInputError(f"legs must be a non-empty tuple of leg names, got {self.legs!r}")
        n = len(self.legs)
        off = array(self.offsets, "offsets")
        if off.shape != (n,) or np.any(off < 0.0) or np.any(off >= 1.0):
            raise InvalidInputError(f"offsets must be {n} lift-off phases in [0, 1) (one per leg), got {off.tolist()}")
        off.setflags(write=False)
        duty = scalar(self.duty, "duty")
        if not 0.0 < duty < 1.0:
            raise InvalidInputError(f"duty must be in (0, 1) (the stance fraction of a cycle), got {duty}")
        object.__setattr__(self, "legs", tuple(self.legs))
        object.__setattr__(self, "offsets", off)
        object.__setattr__(self, "duty", duty)
        object.__setattr__(self, "period", positive(self.period, "period"))

    @property
    def n_legs(self) -> int:
        """Number of legs n."""
        return len(self.legs)

    @property
    def swing_fraction(self) -> float:
        """σ = 1 − β: the fraction of a cycle each leg is in the air."""
        return 1.0 - self.duty

    @property
    def swing_time(self) -> float:
        """σ · T [s]: the duration of one swing."""
        return self.swing_fraction * self.period

    def phase(self, t: object) -> np.ndarray:
        """Cycle phases u_i(t) = frac(t / T − φ_i) ∈ [0, 1), shape (..., n) for t of shape (...) [s]."""
        tt = array(t, "t")
        u = np.mod(tt[..., None] / self.period - self.offsets, 1.0)
        u = np.where(np.abs(u - np.round(u)) < _PHASE_EPS, np.round(u), u)
        snap = np.abs(u - self.swing_fraction) < _PHASE_EPS
        u = np.where(snap, self.swing_fraction, u)
        return np.mod(u, 1.0)

    def stance(self, t: object) -> np.ndarray:
        """(..., n) bool: leg i is in stance at time t [s] (u_i ≥ σ; lift-off at u = 0 is swing)."""
        return self.phase(t) >= self.swing_fraction

    def swing_progress(self, t: object) -> np.ndarray:
        """(..., n) in [0, 1): how far each leg is through its swing (u_i / σ); NaN for stance legs."""
        u = self.phase(t)
        return np.where(u < self.swing_fraction, u / self.swing_fraction, np.nan)

    def stance_progress(self, t: object) -> np.ndarray:
        """(..., n) in [0, 1): how far each leg is through its stance ((u_i − σ) / β); NaN for swing legs."""
        u = self.phase(t)
        return np.where(u >= self.swing_fraction, (u - self.swing_fraction) / self.duty, np.nan)

    def min_stance(self, samples: int = 3600) -> int:
        """The smallest number of stance legs over one cycle (sampled at ``samples`` phases, which include
        every lift-off and touch-down of the default tables)."""
        t = np.arange(_samples(samples)) * (self.period / samples)
        return int(self.stance(t).sum(axis=-1).min())

    def diagram(self, samples: int = 600) -> tuple[np.ndarray, np.ndarray]:
        """The gait diagram over one cycle: (t (samples,) [s], stance (samples, n) bool)."""
        t = np.arange(_samples(samples)) * (self.period / samples)
        return t, self.stance(t)


def phase_table(gait: str, n_legs: int = 6, duty: float | None = None, *, period: float = 1.0) -> GaitTable:
    """The phase table of ``gait`` for ``n_legs`` legs (module docstring: φ(j, s) = frac(s Δ + j σ)).

    Args:
        gait: "tripod" | "ripple" | "wave".
        n_legs: n ≥ 4 (the tripod needs an even n).
        duty: the duty factor β ∈ (0, 1); default the gait's own: tripod 1/2, ripple 1 − 2/n (2/3 for 6
            legs), wave 1 − 1/n (5/6 for 6 legs).  A larger β than the default keeps more legs on the
            ground; a smaller one lets swings overlap beyond the gait's pattern.
        period: cycle time T [s].

    Returns a :class:`GaitTable`.  Raises :class:`~coop_ga.errors.InvalidInputError` for an unknown
    gait, n < 4, an odd n for the tripod, or β outside (0, 1).
    """
    g = choice(gait, GAITS, "gait")
    n = integer(n_legs, "n_legs", minimum=4)
    T = positive(period, "period")
    if g == "tripod" and n % 2:
        raise InvalidInputError(
            f"the tripod gait alternates two equal halves of the legs: n_legs must be even, got {n}"
        )
    n_left = (n + 1) // 2
    if g == "tripod":
        sigma, shift = 0.5, 0.5
    elif g == "ripple":
        sigma, shift = 2.0 / n, (0.5 if n % 2 == 0 else 1.0 / n)
    else:
        sigma, shift = 1.0 / n, n_left / n
    beta = 1.0 - sigma
    if duty is not None:
        beta = scalar(duty, "duty")
        if not 0.0 < beta < 1.0:
            raise InvalidInputError(f"duty must be in (0, 1) (the stance fraction of a cycle), got {beta}")
    offsets = np.empty(n)
    for i in range(n):
        side, k = (0, i) if i < n_left else (1, i - n_left)
        size = n_left if side == 0 else n - n_left
        j = size - 1 - k  # counted from the rear
        offsets[i] = math.fmod(side * shift + j * sigma, 1.0)
    offsets = np.where(np.abs(offsets - 1.0) < _PHASE_EPS, 0.0, offsets)
    offsets.setflags(write=False)
    return GaitTable(gait=g, legs=leg_names(n), offsets=offsets, duty=float(beta), period=T)


def _smoothstep(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """h(x) = 3x² − 2x³ on [0, 1] (clipped outside) and h'(x)."""
    xc = np.clip(x, 0.0, 1.0)
    inside = (x > 0.0) & (x < 1.0)
    return xc * xc * (3.0 - 2.0 * xc), np.where(inside, 6.0 * xc * (1.0 - xc), 0.0)


def swing_arc(p0: object, p1: object, lift: float, s: object) -> tuple[np.ndarray, np.ndarray]:
    """A swing foot's arc from lift-off ``p0`` to touch-down ``p1`` (module docstring).

    Args:
        p0: (3,) lift-off point [m], any frame with z up (the world frame W in :func:`~coop_ga.legged.walk.walk`).
        p1: (3,) touch-down point [m], same frame.
        lift: clearance of the apex above the higher end point [m] ≥ 0: z_top = max(z0, z1) + lift.
        s: swing progress ∈ [0, 1], scalar or (...,) array (0 = lift-off, 1 = touch-down).

    Returns:
        p: (..., 3) position on the arc [m]; p(0) = p0, p(1) = p1, continuous (C¹) on [0, 1]; the horizontal
            part moves monotonically from p0 to p1 and the height never drops below min(z0, z1) nor exceeds z_top.
        v: (..., 3) its derivative ∂p/∂s [m per unit s] (divide by the swing time for a velocity in m/s);
            v(0) = v(1) = 0, continuous on [0, 1].
    """
    a = array(p0, "p0", shape=(3,))
    b = array(p1, "p1", shape=(3,))
    h_lift = scalar(lift, "lift")
    if h_lift < 0:
        raise InvalidInputError(f"lift must be >= 0 [m], got {h_lift}")
    ss = array(s, "s")
    if np.any(ss < -1e-12) or np.any(ss > 1.0 + 1e-12):
        raise InvalidInputError(f"s must lie in [0, 1], got values in [{ss.min()}, {ss.max()}]")
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused below
        ss = np.clip(ss, 0.0, 1.0)
        d = _SWING_DELAY
        # horizontal: a smoothstep over [d, 1 − d]
        hx, dhx = _smoothstep((ss - d) / (1.0 - 2.0 * d))
        dhx = dhx / (1.0 - 2.0 * d)
        # vertical: z0 → z_top over [0, ½], z_top → z1 over [½, 1]
        z0, z1 = a[2], b[2]
        z_top = max(z0, z1) + h_lift
        up, dup = _smoothstep(2.0 * ss)
        down, ddown = _smoothstep(2.0 * ss - 1.0)
        first = ss <= 0.5
        z = np.where(first, z0 + (z_top - z0) * up, z_top + (z1 - z_top) * down)
        dz = np.where(first, (z_top - z0) * 2.0 * dup, (z1 - z_top) * 2.0 * ddown)
        p = np.empty((*ss.shape, 3))
        v = np.empty((*ss.shape, 3))
        for k in range(2):
            p[..., k] = a[k] + (b[k] - a[k]) * hx
            v[..., k] = (b[k] - a[k]) * dhx
        p[..., 2] = z
        v[..., 2] = dz
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(v))):
        raise InvalidInputError("swing_arc(p0, p1, lift): the arc overflows; rescale the end points and the lift")
    return p, v
