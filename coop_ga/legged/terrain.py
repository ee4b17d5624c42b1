"""Terrains as sets of planar patches (CGA planes), contact by point–plane incidence, landing of swing feet.

A :class:`Terrain` covers the xy plane of the world frame W (z up) with a rectangular grid of cells;
each cell carries one plane ``n · x = d`` (unit normal n with n_z > 0, offset d [m]).  The grid is
given by its *interior* cell boundaries ``x_edges`` (ascending, [m]) and ``y_edges``: with m edges along
x there are m + 1 cells, ``(−∞, e_0), [e_0, e_1), …, [e_{m−1}, +∞)`` — the outermost cells extend to
infinity, and a point exactly on an edge belongs to the cell on its +x (+y) side.  Heights are
discontinuous at the edges (risers are vertical); slopes are single planes.

Kinds (all deterministic; ``random`` under its seed):

* ``flat(height)``: one cell, the plane z = height;
* ``slope(angle_rad, direction, height)``: one plane through (0, 0, height) rising by tan(angle) per metre
  along the horizontal unit ``direction``;
* ``steps(step_height, step_length, start_x, n_steps)``: a staircase going **up along +x**: z = 0 for
  x < start_x, then n_steps treads of length ``step_length``, each ``step_height`` higher than the one
  before; the last one (z = n_steps · step_height) extends to +∞.  The defaults (0.03 m rises, 0.25 m
  treads) are climbable by the PhantomX-size hexapod (its feet reach ~0.1 m below the body at the stand
  pose) and long enough that a 4- or 5-foot stance often spans two treads (a non-coplanar stance);
* ``random(seed, tile, amplitude, extent)``: square tiles of side ``tile`` covering [−extent, extent]²,
  each a horizontal plane at a height drawn uniformly from [0, amplitude] by
  ``numpy.random.default_rng(seed)`` (row-major over y then x); outside the square z = 0.  The largest
  height difference between neighbouring tiles is below ``amplitude`` (default 0.025 m, walkable by a
  tripod with a 0.03–0.04 m lift).

Contact in CGA (hexapod seed §4: Π ∧ P = 0 at contact)
-------------------------------------------------------
For the plane Π = A ∧ B ∧ C ∧ e∞ of the cell under a point x, spanned by A = P(a), B = P(a + u),
C = P(a + v) with u × v = n, and the conformal point P = P(x), the only component of the 5-blade
Π ∧ P is ``⟨Π ∧ P⟩ = −((u × v) · (x − a)) e0123∞``.  Divided by the norm of the plane's direction part
(|u × v|, the norm of its e012∞, e013∞, e023∞ coefficients) it is the signed distance of x from the
plane (> 0 above, in the direction of n): :meth:`Terrain.signed_distance` computes exactly this, batched,
with the multivector code of :mod:`coop_ga.geometry` (a = the terrain point under x, so the primitive
is built next to the point and loses no precision).  A point is in contact when
|signed distance| ≤ tol.  The distance is to the plane of the cell *vertically below* the point (not
the Euclidean distance to a riser next to it).

Arrays (``to_arrays`` / ``from_arrays``; flat keys, all prefixed ``terrain_``, suitable for ``np.savez``
without pickling)
---------------------------------------------------------------------------------------------------
``terrain_kind``      0-d unicode array: "flat" | "slope" | "steps" | "random"
``terrain_x_edges``   (mx,) float [m]: interior cell boundaries along x, ascending (mx may be 0)
``terrain_y_edges``   (my,) float [m]: interior cell boundaries along y, ascending
``terrain_planes``    (my + 1, mx + 1, 4) float: cell [iy, ix] holds (n_x, n_y, n_z, d), the plane
                      n · x = d of that cell (n unit, n_z > 0) in W
``terrain_params``    (k,) float: the constructor's parameters (informative; see :meth:`Terrain.params`)
``terrain_seed``      0-d int: the seed (−1 for the deterministic kinds)

The cell of a point (x, y) is ``ix = searchsorted(x_edges, x, side="right")``, likewise iy; its height
is ``(d − n_x x − n_y y) / n_z``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..algebra.basis import blade_index
from ..errors import InvalidInputError
from ..geometry.primitives import Primitive, plane, point

__all__ = ["TERRAIN_KINDS", "Terrain"]

#: the kinds of :meth:`Terrain.make` (the walking experiment's ``--terrain``)
TERRAIN_KINDS = ("flat", "slope", "steps", "random")
#: :meth:`Terrain.steps` and :meth:`Terrain.max_height` refuse more cells / samples than this (bounded memory)
MAX_CELLS = 1_000_000

#: the slope of ``Terrain.make("slope")`` [rad] (≈ 5.7°)
DEFAULT_SLOPE = 0.1

_E0123INF = blade_index("e0123inf")[0]
_PLANE_DIR = tuple(blade_index(n)[0] for n in ("e012inf", "e013inf", "e023inf"))  # the plane's normal part

_PARAM_NAMES = {
    "flat": ("height",),
    "slope": ("angle_rad", "direction_x", "direction_y", "height"),
    "steps": ("step_height", "step_length", "start_x", "n_steps"),
    "random": ("tile", "amplitude", "extent"),
}


def _edges(e: Any, what: str) -> np.ndarray:
    a = validation.array(e, what).reshape(-1) if np.size(e) else np.zeros(0)
    if a.size > 1 and not np.all(np.diff(a) > 0):
        raise InvalidInputError(f"{what} must be strictly ascending, got {a.tolist()[:10]}")
    return a


@dataclass(frozen=True, eq=False)
class Terrain:
    """A set of planar patches (CGA planes) covering the xy plane of W; deterministic under a seed.

    Build with :meth:`flat`, :meth:`slope`, :meth:`steps`, :meth:`random` or :meth:`make`; the fields are
    the array layout of the module docstring (``planes`` (my + 1, mx + 1, 4): unit normal and offset of
    each cell, n · x = d).
    """

    kind: str
    x_edges: np.ndarray
    y_edges: np.ndarray
    planes: np.ndarray
    params: tuple[float, ...] = ()
    seed: int = -1

    def __post_init__(self) -> None:
        validation.choice(self.kind, TERRAIN_KINDS, "Terrain.kind")
        xe = _edges(self.x_edges, "x_edges")
        ye = _edges(self.y_edges, "y_edges")
        P = validation.array(self.planes, "planes")
        if P.shape != (ye.size + 1, xe.size + 1, 4):
            raise InvalidInputError(
                f"planes must have shape (len(y_edges) + 1, len(x_edges) + 1, 4) = ({ye.size + 1}, {xe.size + 1}, 4), "
                f"got {P.shape}"
            )
        nn = np.linalg.norm(P[..., :3], axis=-1)
        if not np.all(P[..., 2] > 1e-6 * nn) or not np.all(nn > 0):
            raise InvalidInputError(
                "every terrain plane needs a normal with n_z > 0 (no vertical or overhanging patches)"
            )
        P = P.copy()
        P /= nn[..., None]  # unit normals (d scales with them)
        for a in (xe, ye, P):
            a.setflags(write=False)
        object.__setattr__(self, "x_edges", xe)
        object.__setattr__(self, "y_edges", ye)
        object.__setattr__(self, "planes", P)
        object.__setattr__(self, "params", tuple(float(v) for v in self.params))
        object.__setattr__(self, "seed", int(self.seed))

    def __repr__(self) -> str:
        names = _PARAM_NAMES[self.kind]
        ps = ", ".join(f"{n}={v:g}" for n, v in zip(names, self.params))
        seed = f", seed={self.seed}" if self.kind == "random" else ""
        return f"Terrain.{self.kind}({ps}{seed}; {self.planes.shape[1]}×{self.planes.shape[0]} cells)"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Terrain):
            return NotImplemented
        return (
            self.kind == other.kind
            and np.array_equal(self.x_edges, other.x_edges)
            and np.array_equal(self.y_edges, other.y_edges)
            and np.array_equal(self.planes, other.planes)
        )

    __hash__ = None  # type: ignore[assignment]

    # ================================================================== constructors
    @classmethod
    def flat(cls, height: float = 0.0) -> Terrain:
        """The plane z = ``height`` [m]."""
        h = validation.scalar(height, "height")
        return cls("flat", np.zeros(0), np.zeros(0), np.array([[[0.0, 0.0, 1.0, h]]]), (h,))

    @classmethod
    def slope(cls, angle_rad: float, direction: Sequence[float] = (1.0, 0.0), height: float = 0.0) -> Terrain:
        """The plane through (0, 0, ``height``) rising by tan(``angle_rad``) per metre along the horizontal
        ``direction`` (2,) (normalised); |angle| < π/2 [rad]."""
        a = validation.scalar(angle_rad, "angle_rad")
        if not abs(a) < 0.5 * math.pi - 1e-6:
            raise InvalidInputError(f"angle_rad must be in (−π/2, π/2), got {a:g}")
        d = validation.vector(direction, 2, "direction")
        nd = float(np.linalg.norm(d))
        if not nd > 0:
            raise InvalidInputError("direction must be a non-zero horizontal 2-vector")
        d = d / nd
        h = validation.scalar(height, "height")
        t = math.tan(a)
        n = np.array([-t * d[0], -t * d[1], 1.0])
        n /= np.linalg.norm(n)
        return cls("slope", np.zeros(0), np.zeros(0), np.array([[[n[0], n[1], n[2], n[2] * h]]]), (a, d[0], d[1], h))

    @classmethod
    def steps(
        cls, step_height: float = 0.03, step_length: float = 0.25, start_x: float = 0.15, n_steps: int = 4
    ) -> Terrain:
        """A staircase up along +x: z = 0 for x < ``start_x`` [m], then ``n_steps`` rises of ``step_height`` [m]
        every ``step_length`` [m]; the top tread (z = n_steps · step_height) extends to +∞.  A negative
        ``step_height`` gives stairs down."""
        H = validation.scalar(step_height, "step_height")
        L = validation.positive(step_length, "step_length")
        x0 = validation.scalar(start_x, "start_x")
        n = validation.integer(n_steps, "n_steps", minimum=1)
        if n > MAX_CELLS:
            raise InvalidInputError(f"n_steps = {n} is above {MAX_CELLS} (one terrain cell per step)")
        edges = x0 + L * np.arange(n)
        if not np.all(np.isfinite(edges)) or not np.isfinite(H * n):
            raise InvalidInputError(
                "the staircase overflows: start_x + n_steps·step_length or n_steps·step_height is not finite"
            )
        planes = np.zeros((1, n + 1, 4))
        planes[0, :, 2] = 1.0
        planes[0, :, 3] = H * np.arange(n + 1)
        return cls("steps", edges, np.zeros(0), planes, (H, L, x0, float(n)))

    @classmethod
    def random(cls, seed: int = 0, tile: float = 0.08, amplitude: float = 0.025, extent: float = 3.0) -> Terrain:
        """A height field of square horizontal tiles of side ``tile`` [m] over [−extent, extent]² [m], heights
        [m] uniform in [0, ``amplitude``] from ``numpy.random.default_rng(seed)``; z = 0 outside."""
        s = validation.integer(seed, "seed", minimum=0)
        t = validation.positive(tile, "tile")
        amp = validation.nonnegative(amplitude, "amplitude")
        ext = validation.positive(extent, "extent")
        m = 2.0 * ext / t
        if not m <= 4000:
            raise InvalidInputError(
                f"random terrain of {m:.3g}×{m:.3g} tiles is too large (at most 4000 per side); use a larger tile or a "
                "smaller extent"
            )
        m = math.ceil(m - 1e-9)
        edges = -ext + t * np.arange(m + 1)
        heights = np.zeros((m + 2, m + 2))
        heights[1:-1, 1:-1] = np.random.default_rng(s).uniform(0.0, amp, size=(m, m))
        planes = np.zeros((m + 2, m + 2, 4))
        planes[..., 2] = 1.0
        planes[..., 3] = heights
        return cls("random", edges, edges.copy(), planes, (t, amp, ext), seed=s)

    @classmethod
    def make(cls, kind: str, seed: int = 0) -> Terrain:
        """The default terrain of ``kind`` (one of :data:`TERRAIN_KINDS`; the walking experiment's
        ``--terrain``): flat z = 0, a slope of :data:`DEFAULT_SLOPE` rad up along +x, the default steps,
        or the default random tiles under ``seed``."""
        validation.choice(kind, TERRAIN_KINDS, "terrain kind")
        if kind == "flat":
            return cls.flat()
        if kind == "slope":
            return cls.slope(DEFAULT_SLOPE)
        if kind == "steps":
            return cls.steps()
        return cls.random(seed=seed)

    # ================================================================== queries
    def _cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ix = np.searchsorted(self.x_edges, xy[..., 0], side="right")
        iy = np.searchsorted(self.y_edges, xy[..., 1], side="right")
        return iy, ix

    def _xy(self, xy: Any, what: str = "xy") -> np.ndarray:
        a = validation.array(xy, what)
        if a.ndim == 0 or a.shape[-1] != 2:
            raise InvalidInputError(f"{what} must have shape (..., 2) [m], got {a.shape}")
        return a

    def _pts(self, points: Any, what: str = "points") -> np.ndarray:
        a = validation.array(points, what)
        if a.ndim == 0 or a.shape[-1] != 3:
            raise InvalidInputError(f"{what} must have shape (..., 3) [m], got {a.shape}")
        return a

    def plane_params(self, xy: Any) -> np.ndarray:
        """(n_x, n_y, n_z, d) of the cell under each ``xy`` (..., 2): shape (..., 4), n · x = d in W."""
        a = self._xy(xy)
        iy, ix = self._cells(a)
        return self.planes[iy, ix]

    def height(self, xy: Any) -> np.ndarray:
        """Terrain height z [m] under ``xy`` (..., 2) [m] in W: shape (...,)."""
        a = self._xy(xy)
        P = self.plane_params(a)
        return (P[..., 3] - P[..., 0] * a[..., 0] - P[..., 1] * a[..., 1]) / P[..., 2]

    def normal(self, xy: Any) -> np.ndarray:
        """Unit upward normal of the patch under ``xy`` (..., 2): shape (..., 3), in W."""
        return self.plane_params(xy)[..., :3].copy()

    def land(self, xy: Any) -> np.ndarray:
        """The terrain point under ``xy`` (..., 2) [m]: shape (..., 3) = (x, y, height(x, y)) in W (where a swing
        foot aimed at xy touches down)."""
        a = self._xy(xy)
        return np.concatenate([a, self.height(a)[..., None]], axis=-1)

    def _plane_primitive(self, xy: np.ndarray) -> Primitive:
        """The CGA plane(s) Π = P(a) ∧ P(a + u) ∧ P(a + v) ∧ e∞ of the cells under xy (N, 2) or (2,), with
        a = the terrain point under xy and u × v = n (unit): the normal points up, |Π| = 1."""
        a = self.land(xy)
        n = self.normal(xy)
        u = np.stack([n[..., 2], np.zeros_like(n[..., 0]), -n[..., 0]], axis=-1)
        u /= np.linalg.norm(u, axis=-1, keepdims=True)
        v = np.cross(n, u)
        return plane(a, a + u, a + v)

    def plane_at(self, xy: Any) -> Primitive:
        """The CGA plane (direct form, ``kind == "plane"``, normal up, unit weight) of the patch under one
        ``xy`` (2,) [m] in W."""
        a = validation.vector(xy, 2, "xy")
        return self._plane_primitive(a)

    def signed_distance(self, points: Any) -> np.ndarray:
        """Signed distance [m] of ``points`` (..., 3) in W from the plane of the patch vertically below each:
        ``−⟨Π ∧ P⟩_{e0123∞} / |Π|`` (module docstring), > 0 above the terrain; shape (...,)."""
        p = self._pts(points)
        flat = p.reshape(-1, 3)
        if flat.shape[0] == 0:
            return np.zeros(p.shape[:-1])
        Pi = self._plane_primitive(flat[:, :2])
        X = Pi ^ point(flat)
        wedge = np.asarray(X.get(_E0123INF), float) * np.ones(flat.shape[0])
        norm = np.sqrt(sum(np.asarray(Pi.get(b), float) ** 2 for b in _PLANE_DIR) * np.ones(flat.shape[0]))
        return (-wedge / norm).reshape(p.shape[:-1])

    def in_contact(self, points: Any, tol: float = 1e-3) -> np.ndarray:
        """True where |:meth:`signed_distance`| ≤ ``tol`` [m]: points (..., 3) → (...,) bool."""
        t = validation.nonnegative(tol, "tol")
        return np.abs(self.signed_distance(points)) <= t

    def max_height(self, xy0: Any, xy1: Any, samples: int = 64) -> float:
        """Highest terrain height [m] on the straight segment xy0 → xy1 (2,) in W: the heights at ``samples``
        points and at every cell boundary the segment crosses (both sides), so steps are never missed."""
        a = validation.vector(xy0, 2, "xy0")
        b = validation.vector(xy1, 2, "xy1")
        n = validation.integer(samples, "samples", minimum=2)
        if n > MAX_CELLS:
            raise InvalidInputError(f"samples = {n} is above {MAX_CELLS}")
        s = [np.linspace(0.0, 1.0, n)]
        d = b - a
        for k, edges in ((0, self.x_edges), (1, self.y_edges)):
            if abs(d[k]) > 0 and edges.size:
                t = (edges - a[k]) / d[k]
                t = t[(t >= 0) & (t <= 1)]
                s.append(np.clip(np.concatenate([t - 1e-9, t + 1e-9]), 0.0, 1.0))
        ts = np.concatenate(s)
        return float(np.max(self.height(a + ts[:, None] * d)))

    # ================================================================== clearance of bodies
    def _cell_boxes(self, iy: np.ndarray, ix: np.ndarray) -> tuple[np.ndarray, ...]:
        """x/y bounds (±inf outside the grid) of cells (iy, ix) (indices into the grid)."""
        xe = np.concatenate([[-np.inf], self.x_edges, [np.inf]])
        ye = np.concatenate([[-np.inf], self.y_edges, [np.inf]])
        return xe[ix], xe[ix + 1], ye[iy], ye[iy + 1]

    def solid_distance(self, points: Any) -> np.ndarray:
        """Signed Euclidean distance [m] of ``points`` (..., 3) in W from the terrain *solid* (the cells'
        prisms ``{xy in the cell, z ≤ its plane}``, risers included): > 0 in the air, < 0 inside.

        One-cell terrains (flat, slope): the plane's signed distance, exact.  Several cells: the distance to the
        union of the prisms of the cells within two cells of each point's own, exact for horizontal cells (the
        kinds ``steps`` and ``random``) up to ``2 · min(cell size)``, and capped there (a lower bound beyond);
        a tilted finite cell's top is taken at its height over the point's nearest xy of the cell.  Inside a
        prism the value is minus the smaller of the depth below its top and the horizontal distance to a
        side whose neighbour lies below the point (the way out)."""
        p = self._pts(points)
        flat = p.reshape(-1, 3)
        if self.planes.shape[:2] == (1, 1):
            n, d = self.planes[0, 0, :3], self.planes[0, 0, 3]
            return (flat @ n - d).reshape(p.shape[:-1])
        out = np.empty(flat.shape[0])
        for a in range(0, flat.shape[0], 20_000):
            out[a : a + 20_000] = self._grid_distance(flat[a : a + 20_000])
        return out.reshape(p.shape[:-1])

    def _grid_distance(self, P: np.ndarray) -> np.ndarray:
        """:meth:`solid_distance` of points (n, 3) on a multi-cell terrain."""
        ny, nx = self.planes.shape[:2]
        iy0, ix0 = self._cells(P[:, :2])
        sizes = [np.diff(e) for e in (self.x_edges, self.y_edges) if e.size > 1]
        cap = 2.0 * float(min(float(np.min(z)) for z in sizes)) if sizes else np.inf
        d = np.arange(-2, 3)
        iy = np.clip(iy0[:, None, None] + d[None, :, None], 0, ny - 1)  # (n, 5, 1)
        ix = np.clip(ix0[:, None, None] + d[None, None, :], 0, nx - 1)  # (n, 1, 5)
        x0, x1, y0, y1 = self._cell_boxes(iy, ix)
        X, Y, Z = (P[:, k, None, None] for k in range(3))
        cx, cy = np.clip(X, x0, x1), np.clip(Y, y0, y1)
        pl = self.planes[iy, ix]  # (n, 5, 5, 4)
        top = (pl[..., 3] - pl[..., 0] * cx - pl[..., 1] * cy) / pl[..., 2]
        gap = (X - cx) ** 2 + (Y - cy) ** 2 + np.maximum(Z - top, 0.0) ** 2
        best = np.sqrt(gap.reshape(len(P), -1).min(axis=1))
        out = np.minimum(best, cap)
        inside = best == 0.0
        if np.any(inside):
            out[inside] = -self._depth(P[inside], iy0[inside], ix0[inside])
        return out

    def _depth(self, P: np.ndarray, iy: np.ndarray, ix: np.ndarray) -> np.ndarray:
        """How deep points (n, 3) lie inside their own cell's prism: the smaller of the depth below its top and
        the horizontal distance to a side whose neighbour's top is below the point."""
        ny, nx = self.planes.shape[:2]
        h = self.height(P[:, :2])
        depth = h - P[:, 2]
        x0, x1, y0, y1 = self._cell_boxes(iy, ix)
        for dist, jy, jx in (
            (P[:, 0] - x0, iy, ix - 1),
            (x1 - P[:, 0], iy, ix + 1),
            (P[:, 1] - y0, iy - 1, ix),
            (y1 - P[:, 1], iy + 1, ix),
        ):
            ok = (jy >= 0) & (jy < ny) & (jx >= 0) & (jx < nx)
            jy_, jx_ = np.clip(jy, 0, ny - 1), np.clip(jx, 0, nx - 1)
            pl = self.planes[jy_, jx_]
            h_n = (pl[:, 3] - pl[:, 0] * P[:, 0] - pl[:, 1] * P[:, 1]) / pl[:, 2]
            lower = ok & (h_n < P[:, 2])
            depth = np.where(lower, np.minimum(depth, dist), depth)
        return depth

    def capsule_clearance(self, a: Any, b: Any, radius: Any, spacing: float = 0.002) -> np.ndarray:
        """A lower bound of the clearance [m] of capsules (segments a → b (..., 3) in W, ``radius`` (...) [m])
        above the terrain solid (:meth:`solid_distance`): the smallest distance of points ``spacing`` [m] apart
        on the segment, minus the radius and minus ``spacing / 2`` (a point of the segment is at most that far
        from a sample, and the distance is 1-Lipschitz).  < 0: the capsule may touch or cut the terrain."""
        A = self._pts(a, "a")
        B = self._pts(b, "b")
        r = validation.array(radius, "radius")
        h = validation.positive(spacing, "spacing")
        A, B = np.broadcast_arrays(A, B)
        length = float(np.max(np.linalg.norm(B - A, axis=-1))) if A.size else 0.0
        n = max(2, math.ceil(length / h) + 1)
        if n * max(A.size // 3, 1) > 50 * MAX_CELLS:
            raise InvalidInputError(
                f"capsule_clearance: {n} samples on {A.size // 3} segments is too many; raise spacing"
            )
        s = np.linspace(0.0, 1.0, n)
        pts = A[..., None, :] + s[:, None] * (B - A)[..., None, :]
        d = self.solid_distance(pts).min(axis=-1)
        step = np.linalg.norm(B - A, axis=-1) / (n - 1)
        return d - np.broadcast_to(r, d.shape) - 0.5 * step

    # ================================================================== arrays
    def to_arrays(self) -> dict[str, np.ndarray]:
        """The terrain as flat arrays with keys prefixed ``terrain_`` (module docstring), for ``np.savez``."""
        return {
            "terrain_kind": np.array(self.kind),
            "terrain_x_edges": self.x_edges.copy(),
            "terrain_y_edges": self.y_edges.copy(),
            "terrain_planes": self.planes.copy(),
            "terrain_params": np.array(self.params, dtype=float),
            "terrain_seed": np.array(self.seed, dtype=np.int64),
        }

    @classmethod
    def from_arrays(cls, d: Mapping[str, Any]) -> Terrain:
        """The terrain from :meth:`to_arrays` output (a dict or an ``np.load`` NpzFile; extra keys ignored)."""
        if not isinstance(d, Mapping):
            raise InvalidInputError(
                f"d must be a dict of terrain arrays (Terrain.to_arrays(), np.load(...)), got {d!r}"
            )
        need = ("terrain_kind", "terrain_x_edges", "terrain_y_edges", "terrain_planes")
        missing = [k for k in need if k not in d]
        if missing:
            raise InvalidInputError(f"d: the terrain arrays are missing {missing} (have {sorted(d.keys())[:20]})")
        kind = str(np.asarray(d["terrain_kind"]).item())
        params = tuple(np.asarray(d["terrain_params"], float).reshape(-1)) if "terrain_params" in d else ()
        seed = int(np.asarray(d["terrain_seed"]).item()) if "terrain_seed" in d else -1
        return cls(
            kind,
            np.asarray(d["terrain_x_edges"], float),
            np.asarray(d["terrain_y_edges"], float),
            np.asarray(d["terrain_planes"], float),
            params,
            seed,
        )
