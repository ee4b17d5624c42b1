"""Drawing the six primitive kinds, and the samplers behind them (one implementation each).

:func:`draw_primitive` draws any :class:`coop_ga.Primitive` (or primitive multivector)
on a matplotlib ``Axes3D`` from its read-outs (:func:`coop_ga.kind_of`,
:func:`~coop_ga.center`, :func:`~coop_ga.radius`, :func:`~coop_ga.normal`,
:func:`~coop_ga.direction`, :func:`~coop_ga.closest_point_to_origin`,
:func:`~coop_ga.endpoints`):

===========  ==========================================================================
kind         drawn as
===========  ==========================================================================
point        a marker
point_pair   its two points as markers and the segment between them
line         a finite segment: ``length`` [m] about its point nearest ``anchor``
             (default: nearest the origin), else clipped to the current axes box
circle       ``m`` samples (:func:`circle_points`), optionally its normal as an arrow
plane        a translucent square of side ``size`` [m] about its point nearest ``anchor``
sphere       a wireframe (:func:`sphere_mesh`)
===========  ==========================================================================

All coordinates are world coordinates in metres.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..geometry import KIND_SPECS, center, closest_point_to_origin, direction, endpoints, kind_of, normal, radius
from .axes import Drawn, axes_box
from .style import LINEWIDTH, PALETTE

__all__ = ["circle_points", "clip_line", "draw_primitive", "plane_basis", "sphere_mesh", "square_points"]


def _vec3(x: Any, what: str) -> np.ndarray:
    v = np.asarray(x, dtype=float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what} must be a finite 3-vector, got {np.asarray(x).tolist()!r}")
    return v


def plane_basis(normal: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Right-handed orthonormal (u, v, n) with n = normal/|normal| and u, v spanning the plane ⟂ n."""
    n = _vec3(normal, "normal")
    nn = float(np.linalg.norm(n))
    if nn < 1e-12:
        raise ValueError("the normal has zero length")
    n = n / nn
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    return u, np.cross(n, u), n


def circle_points(center: Any, radius: float, normal: Any, m: int = 120) -> np.ndarray:
    """(m+1, 3) points [m] of the circle with the given centre [m], radius [m] and normal
    (any length), closed (the last point equals the first), counter-clockwise about the normal."""
    c = _vec3(center, "center")
    u, v, _ = plane_basis(normal)
    t = np.linspace(0.0, 2.0 * np.pi, int(m) + 1)
    P = c + float(radius) * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))
    P[-1] = P[0]
    return P


def sphere_mesh(center: Any, radius: float, m: int = 24) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid (X, Y, Z), each of shape (m//2 + 1, m + 1), of the sphere with the given centre [m]
    and radius [m]: m meridian segments and m//2 latitude bands (for ``plot_wireframe``)."""
    c = _vec3(center, "center")
    r = float(radius)
    az, pol = np.meshgrid(np.linspace(0.0, 2.0 * np.pi, int(m) + 1), np.linspace(0.0, np.pi, max(int(m) // 2, 2) + 1))
    return (c[0] + r * np.cos(az) * np.sin(pol), c[1] + r * np.sin(az) * np.sin(pol), c[2] + r * np.cos(pol))


def square_points(center: Any, normal: Any, size: float) -> np.ndarray:
    """(4, 3) corners [m] of the square of side ``size`` [m] centred at ``center``, normal to ``normal``."""
    c = _vec3(center, "center")
    u, v, _ = plane_basis(normal)
    h = 0.5 * float(size)
    return np.array([c + h * (su * u + sv * v) for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


def clip_line(point: Any, direction: Any, lower: Any, upper: Any) -> np.ndarray | None:
    """The part (2, 3) [m] of the line ``point + s·direction`` inside the box [lower, upper],
    or None when the line misses the box."""
    p, d = _vec3(point, "point"), _vec3(direction, "direction")
    lo, hi = _vec3(lower, "lower"), _vec3(upper, "upper")
    s0, s1 = -np.inf, np.inf
    for i in range(3):
        if abs(d[i]) < 1e-15:
            if not lo[i] <= p[i] <= hi[i]:
                return None
            continue
        a, b = sorted(((lo[i] - p[i]) / d[i], (hi[i] - p[i]) / d[i]))
        s0, s1 = max(s0, a), min(s1, b)
    if not s0 < s1:
        return None
    return np.array([p + s0 * d, p + s1 * d])


def _foot(anchor: Any, base: np.ndarray, n_or_d: np.ndarray, role: str) -> np.ndarray:
    """Point of a line (role ``"direction"``, n_or_d = its direction) or plane (role ``"normal"``, n_or_d = its
    normal) nearest ``anchor``."""
    if anchor is None:
        return base
    a = _vec3(anchor, "anchor")
    k = n_or_d / np.linalg.norm(n_or_d)
    if role == "direction":
        return base + ((a - base) @ k) * k
    return a - ((a - base) @ k) * k


def draw_primitive(
    ax: Any,
    X: Any,
    *,
    color: Any = None,
    lw: float | None = None,
    ls: str = "-",
    alpha: float = 1.0,
    label: str | None = None,
    m: int = 120,
    size: float | None = None,
    length: float | None = None,
    anchor: Any = None,
    normal_arrow: bool = False,
    marker_size: float = 40.0,
    zorder: float | None = None,
) -> Drawn:
    """Draw the primitive ``X`` (any of the six kinds, see the module docstring) on a 3-D axes.

    Args:
        ax: a matplotlib ``Axes3D``.
        X: a :class:`coop_ga.Primitive` (or a primitive multivector; its kind is inferred).
        color: matplotlib colour (default ``PALETTE.primitive``).
        lw: matplotlib line width.
        ls: matplotlib line style.
        alpha: matplotlib opacity.
        label: legend label, given to one artist only.
        zorder: matplotlib drawing order.
        m: samples of a circle, meridians of a sphere (``m // 5``, at least 12).
        size: side [m] of a plane's square (default: the smallest side of the current axes box).
        length: length [m] of a line's segment (default: the line clipped to the current axes box;
            set the limits first).
        anchor: (3,) [m] point whose foot on a line / plane centres the segment / square
            (default: the point nearest the origin).
        normal_arrow: also draw a circle's normal as an arrow of half its radius.

    Returns a :class:`~coop_ga.viz.axes.Drawn` with the artists and the points drawn (N, 3) [m].
    """
    spec = KIND_SPECS[kind_of(X)]
    col = PALETTE.primitive if color is None else color
    wire_lw = LINEWIDTH["wire"] if lw is None else lw
    lw = LINEWIDTH["primitive"] if lw is None else lw
    kw: dict[str, Any] = {"color": col, "alpha": alpha}
    if zorder is not None:
        kw["zorder"] = zorder
    pen = _Pen(ax, Drawn(), kw, lw, ls, marker_size)
    if spec.dimension == 0:  # a point or a point pair: markers (joined for a pair)
        P = np.asarray(center(X), float).reshape(1, 3) if spec.n_points == 1 else _pair_points(X)
        if len(P) > 1:
            pen.line(P, label)
        pen.markers(P, None if len(P) > 1 else label)
    elif spec.flat:
        flat = _draw_flat(pen, X, spec.axis_role, label, col, size, length, anchor)
        if flat is None:  # a line that misses the axes box: nothing to draw
            return pen.out
        P = flat
    elif spec.axis_role == "normal":  # a circle
        c, r, n = np.asarray(center(X), float), float(radius(X)), np.asarray(normal(X), float)
        P = circle_points(c, r, n, m)
        pen.line(P, label)
        if normal_arrow:
            pen.out.artists.append(ax.quiver(*c, *(0.5 * r * n), lw=max(lw * 0.6, 0.8), arrow_length_ratio=0.25, **kw))
            P = np.vstack([P, c, c + 0.5 * r * n])
    else:  # a sphere: a wireframe
        c, r = np.asarray(center(X), float), float(radius(X))
        xs, ys, zs = sphere_mesh(c, r, max(m // 5, 12))
        pen.out.artists.append(ax.plot_wireframe(xs, ys, zs, lw=wire_lw, label=label, **{**kw, "alpha": 0.5 * alpha}))
        P = np.stack([xs.ravel(), ys.ravel(), zs.ravel()], axis=1)
    pen.out.points = np.asarray(P, dtype=float).reshape(-1, 3)
    return pen.out


class _Pen:
    """The artists of one :func:`draw_primitive` call and how it draws lines and markers."""

    def __init__(self, ax: Any, out: Drawn, kw: dict[str, Any], lw: float, ls: str, marker_size: float):
        self.ax, self.out, self.kw, self.lw, self.ls, self.marker_size = ax, out, kw, lw, ls, marker_size

    def line(self, P: np.ndarray, lab: str | None) -> None:
        self.out.artists += self.ax.plot(P[:, 0], P[:, 1], P[:, 2], lw=self.lw, ls=self.ls, label=lab, **self.kw)

    def markers(self, P: np.ndarray, lab: str | None) -> None:
        self.out.artists.append(
            self.ax.scatter(P[:, 0], P[:, 1], P[:, 2], s=self.marker_size, depthshade=False, label=lab, **self.kw)
        )


def _pair_points(X: Any) -> np.ndarray:
    """The two points (2, 3) [m] of a point pair."""
    return np.array([np.asarray(p, float).reshape(3) for p in endpoints(X)])


def _draw_flat(
    pen: _Pen,
    X: Any,
    role: Any,
    label: str | None,
    col: Any,
    size: float | None,
    length: float | None,
    anchor: Any,
) -> np.ndarray | None:
    """A line's segment or a plane's square about the foot of ``anchor``; the points drawn (None: the line
    misses the axes box)."""
    ax = pen.ax
    k = np.asarray(direction(X) if role == "direction" else normal(X), float)
    p = _foot(anchor, np.asarray(closest_point_to_origin(X), float), k, role)
    if role == "direction":  # a line
        if length is not None:
            P = np.array([p - 0.5 * float(length) * k, p + 0.5 * float(length) * k])
        else:
            seg = clip_line(p, k, *axes_box(ax))
            if seg is None:
                return None
            P = seg
        pen.line(P, label)
        return P
    if size is None:
        lo, hi = axes_box(ax)
        size = float(np.min(hi - lo))
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    P = square_points(p, k, size)
    poly = Poly3DCollection(
        [P],
        facecolor=col,
        edgecolor=col,
        linewidths=pen.lw * 0.5,
        linestyles=pen.ls,
        alpha=0.25 * pen.kw["alpha"],
        label=label,
    )
    if "zorder" in pen.kw:
        poly.set_zorder(pen.kw["zorder"])
    ax.add_collection3d(poly)
    pen.out.artists.append(poly)
    return P
