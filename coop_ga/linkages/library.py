"""Classic planar linkages in one line, and the closed forms they are checked against.

* :func:`four_bar` — the 4-bar (``four_bar(ground, crank, coupler, rocker, branch=+1)``);
* :func:`slider_crank` — the seed's 4-bar with a prismatic joint: 3 revolute joints and a
  slider on the vertical line between (0, 3) and (0, 5) (seed 004, Fig. 1b);
* :func:`watt_six_bar` — a Watt II 6-bar (two 4-bars in series sharing the ternary rocker);
* :func:`ten_bar` — a multi-loop 10-bar: the Watt 6-bar plus two dyads.
* closed forms: :func:`grashof` (classification), :func:`freudenstein_output` (the output angle
  of Freudenstein's equation, both branches), :func:`crank_limits` (the crank's toggle angles of
  a non-Grashof 4-bar), :func:`dyad` (circle–circle intersection).

Counting (Grübler–Kutzbach, planar, simple joints): mobility = 3(n − 1) − 2j.  The seed's
captions are inconsistent with it: "6 bars, 5 revolute joints, 1 DOF" gives 3·5 − 10 = 5, and
"10 bars, 7 revolute joints, 1 DOF" gives 27 − 14 = 13.  One DOF needs j = (3(n − 1) − 1)/2:
7 joints for 6 bars and 13 for 10 bars (n counts the ground).  We built those: the 6-bar has 6
links (ground included) and 7 revolute joints; the 10-bar 10 links and 13 revolute joints;
:attr:`Linkage.grubler_dof` is 1 for each (tested).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from .model import (
    MAX_COORDINATE,
    Link,
    Linkage,
    LinkageError,
    LinkageMotion,
    Prismatic,
    Revolute,
    _planar_point,
)

#: the keyword options of :meth:`Linkage.track` that :meth:`FourBar.solve` and :meth:`FourBar.simulate` pass on
TRACK_OPTIONS = ("tol", "max_iter", "guard", "min_step", "max_step", "max_substeps")

__all__ = [
    "FourBar",
    "crank_limits",
    "dyad",
    "four_bar",
    "freudenstein_output",
    "grashof",
    "slider_crank",
    "ten_bar",
    "watt_six_bar",
]


def _length(x: Any, what: str) -> float:
    """A link length [m]: > 0, finite, at most :data:`~coop_ga.linkages.model.MAX_COORDINATE`."""
    v = validation.positive(x, f"{what} [m]")
    if v > MAX_COORDINATE:
        raise InvalidInputError(f"{what} = {v:g} m is beyond {MAX_COORDINATE:g} m")
    return v


def _lengths(ground: Any, crank: Any, coupler: Any, rocker: Any) -> tuple[float, float, float, float]:
    """The four link lengths of a 4-bar, checked (each > 0 and finite) [m]."""
    return (
        _length(ground, "ground"),
        _length(crank, "crank"),
        _length(coupler, "coupler"),
        _length(rocker, "rocker"),
    )


_RATIO_OVERFLOW = (
    "the link lengths (ground, crank, coupler, rocker) = {lengths} m differ by too many orders of magnitude: "
    "their ratios overflow; express them in one unit near their size"
)


def _branch(branch: Any, what: str = "branch") -> int:
    if isinstance(branch, (bool, np.bool_)) or not isinstance(branch, (int, np.integer)) or branch not in (1, -1):
        raise InvalidInputError(f"{what} must be the integer +1 or -1 (the assembly mode), got {branch!r}")
    return int(branch)


def dyad(p: Any, q: Any, r_p: float, r_q: float, branch: int = 1) -> np.ndarray:
    """The point at distance ``r_p`` from p and ``r_q`` from q (2,) [m], left of p→q for branch +1.

    Raises :class:`LinkageError` when the circles do not meet (saying by how much).
    """
    p = np.asarray(_planar_point(p, "p [m]"))
    q = np.asarray(_planar_point(q, "q [m]"))
    r_p, r_q = _length(r_p, "r_p"), _length(r_q, "r_q")
    branch = _branch(branch)
    e = q - p
    L = float(np.hypot(*e))
    if L < 1e-15:
        raise LinkageError("dyad: the two centres coincide")
    if L > r_p + r_q or L < abs(r_p - r_q):
        gap = L - (r_p + r_q) if L > r_p + r_q else abs(r_p - r_q) - L
        raise LinkageError(f"dyad cannot close: the centres are {L:.6g} m apart, out of range by {gap:.3g} m")
    x = (L * L + r_p * r_p - r_q * r_q) / (2 * L)
    h = np.sqrt(max(r_p * r_p - x * x, 0.0))
    u = e / L
    return p + x * u + branch * h * np.array([-u[1], u[0]])


def grashof(ground: float, crank: float, coupler: float, rocker: float) -> str:
    """Grashof class of a 4-bar from its link lengths [m].

    s + l < p + q (Grashof): "crank-rocker" (crank shortest), "double-crank" (ground shortest),
    "rocker-crank" (rocker shortest), "double-rocker" (coupler shortest); s + l = p + q (to 1e-12
    relative): "change-point"; s + l > p + q: "triple-rocker" (non-Grashof: no link turns fully).
    """
    L = np.array(_lengths(ground, crank, coupler, rocker))
    s, l_ = L.min(), L.max()
    pq = L.sum() - s - l_
    if abs(s + l_ - pq) <= 1e-12 * L.sum():
        return "change-point"
    if s + l_ > pq:
        return "triple-rocker"
    return ("double-crank", "crank-rocker", "double-rocker", "rocker-crank")[int(np.argmin(L))]


def freudenstein_output(ground: float, crank: float, coupler: float, rocker: float, theta2: Any) -> np.ndarray:
    """Both rocker angles θ4 [rad] solving Freudenstein's equation at crank angles θ2 (T,) → (T, 2).

    K1 cos θ4 − K2 cos θ2 + K3 = cos(θ2 − θ4), K1 = d/a, K2 = d/c, K3 = (a² − b² + c² + d²)/(2ac)
    (a crank, b coupler, c rocker, d ground; crank pivot at the origin, rocker pivot at (d, 0),
    θ4 the angle of the rocker tip seen from its pivot).  Written as P cos θ4 + Q sin θ4 = −R:
    θ4 = atan2(Q, P) ± arccos(−R/√(P² + Q²)), column 0 with +, column 1 with −.

    Raises :class:`LinkageError` naming the first crank angle where the linkage cannot be assembled
    (|−R/√(P² + Q²)| > 1 beyond rounding; :func:`crank_limits` gives the toggle angles).
    """
    d, a, b, c = (np.float64(v) for v in _lengths(ground, crank, coupler, rocker))
    t2 = validation.array(theta2, "theta2 [rad]")
    with np.errstate(over="ignore", divide="ignore", invalid="ignore", under="ignore"):
        K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    if not (np.isfinite(K1) and np.isfinite(K2) and np.isfinite(K3)):
        raise InvalidInputError(_RATIO_OVERFLOW.format(lengths=(float(d), float(a), float(b), float(c))))
    P = K1 - np.cos(t2)
    Q = -np.sin(t2)
    R = K3 - K2 * np.cos(t2)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = -R / np.hypot(P, Q)
    bad = ~(np.abs(ratio) <= 1.0 + 1e-12)
    if np.any(bad):
        first = float(t2.reshape(-1)[int(np.flatnonzero(bad.reshape(-1))[0])])
        raise LinkageError(
            f"theta2: the 4-bar ({ground:g}, {crank:g}, {coupler:g}, {rocker:g}) cannot be assembled at "
            f"{int(bad.sum())} of {bad.size} crank angles, first θ2 = {first:.6g} rad; its toggle angles are "
            f"±{list(crank_limits(ground, crank, coupler, rocker))} rad (crank_limits)"
        )
    acos = np.arccos(np.clip(ratio, -1.0, 1.0))
    base = np.arctan2(Q, P)
    return np.stack([base + acos, base - acos], axis=-1)


def crank_limits(ground: float, crank: float, coupler: float, rocker: float) -> tuple[float, ...]:
    """The crank angles [rad, in [0, π]] where a 4-bar reaches a toggle: |A − D| = b + c or |b − c|.

    |A − D|² = a² + d² − 2ad cos θ2; each limit that exists is returned (its mirror −θ is one too).
    """
    d, a, b, c = (np.float64(v) for v in _lengths(ground, crank, coupler, rocker))
    out = []
    for L in (b + c, abs(b - c)):
        with np.errstate(over="ignore", divide="ignore", invalid="ignore", under="ignore"):
            cs = (a * a + d * d - L * L) / (2 * a * d)
        if not np.isfinite(cs):
            raise InvalidInputError(_RATIO_OVERFLOW.format(lengths=(float(d), float(a), float(b), float(c))))
        if -1 <= cs <= 1:
            out.append(float(np.arccos(cs)))
    return tuple(sorted(out))


class FourBar(Linkage):
    """The 4-bar O–A–B–D: crank OA (pivot O at the origin), coupler AB, rocker DB, ground OD along +x.

    ``coupler_point`` (u, v) [m]: an extra coupler point P = A + u ê + v ê⊥ (ê along A→B at the
    reference configuration), whose path is the coupler curve.
    """

    def __init__(
        self,
        ground: float,
        crank: float,
        coupler: float,
        rocker: float,
        branch: int = 1,
        coupler_point: Sequence[float] = (0.5, 0.5),
    ) -> None:
        ground, crank, coupler, rocker = _lengths(ground, crank, coupler, rocker)
        self.lengths = {"ground": ground, "crank": crank, "coupler": coupler, "rocker": rocker}
        self.branch = _branch(branch)
        self.coupler_point = np.asarray(_planar_point(coupler_point, "coupler_point (u, v) [m]"))
        self.kind = grashof(ground, crank, coupler, rocker)
        phi0 = self._reference_angle()
        pts = self.closed_form(phi0)
        O, A, B, D = pts
        u = (B - A) / np.linalg.norm(B - A)
        P = A + self.coupler_point[0] * u + self.coupler_point[1] * np.array([-u[1], u[0]])
        super().__init__(
            [
                Link("ground", {"O": O, "D": D}),
                Link("crank", {"O": O, "A": A}),
                Link("coupler", {"A": A, "B": B, "P": P}),
                Link("rocker", {"D": D, "B": B}),
            ],
            [
                Revolute(("crank", "A"), ("coupler", "A")),
                Revolute(("coupler", "B"), ("rocker", "B")),
                Revolute(("rocker", "D"), ("ground", "D")),
            ],
            name=f"four_bar({ground:g}, {crank:g}, {coupler:g}, {rocker:g}, branch={branch:+d})",
        )

    def _reference_angle(self) -> float:
        a, b, c, d = (self.lengths[k] for k in ("crank", "coupler", "rocker", "ground"))
        grid = np.linspace(-np.pi, np.pi, 721)
        dist = np.sqrt(a * a + d * d - 2 * a * d * np.cos(grid))
        margin = np.minimum(b + c - dist, dist - abs(b - c))
        if margin.max() <= 0:
            raise LinkageError(f"{self.lengths} cannot be assembled at any crank angle")
        return float(grid[int(np.argmax(margin))]) if margin[360] <= 1e-9 else 0.0

    def closed_form(self, phi: float) -> np.ndarray:
        """O, A, B, D (4, 2) [m] at crank angle φ [rad] by circle intersection on this branch."""
        phi = validation.scalar(phi, "phi [rad]")
        a, b, c, d = (self.lengths[k] for k in ("crank", "coupler", "rocker", "ground"))
        A = a * np.array([np.cos(phi), np.sin(phi)])
        D = np.array([d, 0.0])
        B = dyad(A, D, b, c, self.branch)
        return np.array([[0.0, 0.0], A, B, D])

    def assembled(self, phi: float) -> np.ndarray:
        """Moving-link motors (4 n,) of the closed-form assembly on this branch at φ [rad]."""
        _, A, B, D = self.closed_form(phi)
        return self.motors_from_points({"coupler": {"A": A, "B": B}, "rocker": {"D": D, "B": B}})

    def solve(self, crank_angles: Sequence[float] | np.ndarray, **options: Any) -> LinkageMotion:
        """:meth:`Linkage.track` from the closed-form assembly at ``crank_angles[0]`` (partial motions allowed);
        ``options`` are :meth:`Linkage.track`'s keywords."""
        unknown = sorted(set(options) - set(TRACK_OPTIONS))
        if unknown:
            raise InvalidInputError(f"unknown option(s) {unknown} for track; the options are {list(TRACK_OPTIONS)}")
        angles, _ = self._track_args(crank_angles, None)
        return self.track(angles, self.assembled(float(angles[0])), **options)

    def simulate(self, crank_angles: Sequence[float] | np.ndarray, **options: Any) -> np.ndarray:
        """Joint positions (T, 4, 2) [m]: crank pivot O, crank tip A, rocker tip B, rocker pivot D.

        Raises :class:`LinkageError` naming the crank angle where the linkage cannot move on (a
        toggle or the end of its range); :meth:`solve` returns the partial motion instead.
        """
        motion = self.solve(crank_angles, **options)
        if not motion.complete:
            raise LinkageError(f"{self.name}: {motion.message}; use .solve() for the partial motion")
        names = ("crank.O", "crank.A", "rocker.B", "rocker.D")
        return np.stack([motion.point(n) for n in names], axis=1)


def four_bar(ground: float, crank: float, coupler: float, rocker: float, branch: int = 1) -> FourBar:
    """The 4-bar of the four link lengths [m]; ground along +x from the crank pivot at the origin.

    ``branch=+1`` puts the rocker tip B to the left of the line from the crank tip A to the rocker
    pivot D, ``−1`` to its right (the two assembly modes).  ``four_bar(...).simulate(angles)``
    returns (T, 4, 2) joint positions: crank pivot, crank tip, rocker tip, rocker pivot.
    """
    return FourBar(ground, crank, coupler, rocker, branch)


def slider_crank(crank: float = 1.0, rod: float = 4.0) -> Linkage:
    """The seed's 4-bar with a prismatic joint (seed 004, Fig. 1b): crank OA about the origin, rod
    AS, a slider block S on the vertical guide through (0, 3) and (0, 5) of the ground.

    With crank 1 and rod 4 the slider's height is ``y = sin φ + √(16 − cos² φ)`` ∈ [3, 5], so it
    traces exactly the seed's segment between (0, 3) and (0, 5).  3 revolute joints (crank
    bearing, A, S) and 1 prismatic: 3·3 − 2·4 = 1 DOF.
    """
    crank, rod = _length(crank, "crank"), _length(rod, "rod")
    if not rod > crank:
        raise InvalidInputError(
            f"slider_crank needs rod > crank [m] (the crank turns fully), got crank={crank}, rod={rod}"
        )
    A = np.array([crank, 0.0])
    S = np.array([0.0, np.sqrt(rod * rod - crank * crank)])
    return Linkage(
        [
            Link("ground", {"O": (0.0, 0.0), "G1": (0.0, 3.0), "G2": (0.0, 5.0)}),
            Link("crank", {"O": (0.0, 0.0), "A": A}),
            Link("rod", {"A": A, "S": S}),
            Link("slider", {"S": S, "S_left": S + (-0.25, 0.0), "S_right": S + (0.25, 0.0)}),
        ],
        [
            Revolute(("crank", "A"), ("rod", "A")),
            Revolute(("rod", "S"), ("slider", "S")),
            Prismatic(("slider", "S"), ("ground", "G1", "G2")),
        ],
        name="slider_crank",
    )


def _rot(v: np.ndarray, ang: float) -> np.ndarray:
    c, s = np.cos(ang), np.sin(ang)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


#: geometry of the Watt II 6-bar [m]: a crank-rocker 4-bar (O2 A B O4) whose ternary rocker
#: (O4, B, C) drives a second 4-bar (O4 C E O6).  Pivots and lengths chosen so that both dyads
#: keep ≥ 0.2 m of closure margin over the full crank cycle (checked in the tests).
WATT: dict[str, Any] = {
    "O2": (0.0, 0.0), "O4": (2.0, 0.0), "O6": (3.3, 2.3),
    "crank": 0.5, "coupler": 2.0, "rocker": 1.5, "rocker_C": (1.0, np.deg2rad(35.0)),
    "coupler2": 2.6, "output": 0.75,
}  # fmt: skip


def _watt_points(phi: float) -> dict[str, np.ndarray]:
    W = WATT
    O2, O4, O6 = (np.asarray(W[k], float) for k in ("O2", "O4", "O6"))
    A = O2 + W["crank"] * np.array([np.cos(phi), np.sin(phi)])
    B = dyad(A, O4, W["coupler"], W["rocker"], 1)
    rC, aC = W["rocker_C"]
    C = O4 + rC * _rot((B - O4) / np.linalg.norm(B - O4), aC)
    E = dyad(C, O6, W["coupler2"], W["output"], 1)
    return {"O2": O2, "O4": O4, "O6": O6, "A": A, "B": B, "C": C, "E": E}


def watt_six_bar(phi0: float = 0.0) -> Linkage:
    """A Watt II 6-bar: 6 links (ground, crank, coupler, ternary rocker, coupler 2, output) and 7
    revolute joints (O2, A, B, O4, C, E, O6): 3·5 − 2·7 = 1 DOF.  Reference configuration: the
    closed-form assembly at crank angle ``phi0`` [rad]."""
    p = _watt_points(validation.scalar(phi0, "phi0 [rad]"))
    return Linkage(_watt_links(p), _watt_joints(), pivot="O2", name="watt_six_bar")


def _watt_links(p: dict[str, np.ndarray]) -> list[Link]:
    return [
        Link("ground", {"O2": p["O2"], "O4": p["O4"], "O6": p["O6"]}),
        Link("crank", {"O2": p["O2"], "A": p["A"]}),
        Link("coupler", {"A": p["A"], "B": p["B"]}),
        Link("rocker", {"O4": p["O4"], "B": p["B"], "C": p["C"]}),
        Link("coupler2", {"C": p["C"], "E": p["E"]}),
        Link("output", {"O6": p["O6"], "E": p["E"]}),
    ]


def _watt_joints() -> list[Revolute | Prismatic]:
    return [
        Revolute(("crank", "A"), ("coupler", "A")),
        Revolute(("coupler", "B"), ("rocker", "B")),
        Revolute(("rocker", "O4"), ("ground", "O4")),
        Revolute(("rocker", "C"), ("coupler2", "C")),
        Revolute(("coupler2", "E"), ("output", "E")),
        Revolute(("output", "O6"), ("ground", "O6")),
    ]


#: the two extra dyads of the 10-bar [m]: F on the coupler (offset from A along/left of A→B),
#: dyad F–G–O8; H on coupler 2 (offset from C along/left of C→E), dyad H–K–O10.
TEN: dict[str, Any] = {
    "F": (1.0, 0.6), "O8": (0.6, 2.6), "FG": 1.5, "GO8": 0.85,
    "H": (0.9, -0.5), "O10": (3.6, 0.0), "HK": 1.2, "KO10": 1.0,
}  # fmt: skip


def _ten_points(phi: float) -> dict[str, np.ndarray]:
    p = _watt_points(phi)
    T = TEN

    def offset(a: np.ndarray, b: np.ndarray, uv: tuple[float, float]) -> np.ndarray:
        u = (b - a) / np.linalg.norm(b - a)
        return a + uv[0] * u + uv[1] * np.array([-u[1], u[0]])

    p["F"] = offset(p["A"], p["B"], T["F"])
    p["O8"] = np.asarray(T["O8"], float)
    p["G"] = dyad(p["F"], p["O8"], T["FG"], T["GO8"], 1)
    p["H"] = offset(p["C"], p["E"], T["H"])
    p["O10"] = np.asarray(T["O10"], float)
    p["K"] = dyad(p["H"], p["O10"], T["HK"], T["KO10"], -1)
    return p


def ten_bar(phi0: float = 0.0) -> Linkage:
    """A multi-loop 10-bar: the Watt 6-bar plus two dyads (F–G–O8 on the coupler, H–K–O10 on coupler 2).

    10 links (ground with 5 pivots O2, O4, O6, O8, O10; crank; ternary coupler A B F; ternary
    rocker O4 B C; ternary coupler 2 C E H; output; G-links FG, GO8; K-links HK, KO10) and 13
    revolute joints: 3·9 − 2·13 = 1 DOF (the seed's caption says 7 joints; see the module docstring).
    """
    p = _ten_points(validation.scalar(phi0, "phi0 [rad]"))
    links = _watt_links(p)
    links[0] = Link("ground", {k: p[k] for k in ("O2", "O4", "O6", "O8", "O10")})
    links[2] = Link("coupler", {"A": p["A"], "B": p["B"], "F": p["F"]})
    links[4] = Link("coupler2", {"C": p["C"], "E": p["E"], "H": p["H"]})
    links += [
        Link("link_FG", {"F": p["F"], "G": p["G"]}),
        Link("link_GO8", {"G": p["G"], "O8": p["O8"]}),
        Link("link_HK", {"H": p["H"], "K": p["K"]}),
        Link("link_KO10", {"K": p["K"], "O10": p["O10"]}),
    ]
    joints = _watt_joints() + [
        Revolute(("coupler", "F"), ("link_FG", "F")),
        Revolute(("link_FG", "G"), ("link_GO8", "G")),
        Revolute(("link_GO8", "O8"), ("ground", "O8")),
        Revolute(("coupler2", "H"), ("link_HK", "H")),
        Revolute(("link_HK", "K"), ("link_KO10", "K")),
        Revolute(("link_KO10", "O10"), ("ground", "O10")),
    ]
    return Linkage(links, joints, pivot="O2", name="ten_bar")
