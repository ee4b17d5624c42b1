"""What the viewer draws in a viser scene: robots from their visual meshes, primitives, end points, objects.

Every node is created once and then *moved* (its props assigned), so a frame sends poses, not meshes:

* :class:`RobotNode` — a system's visual geometry (:meth:`coop_ga.systems.System.visual_model`, the
  meshes of :func:`coop_ga.viz.object_mesh`): one batched mesh per distinct mesh file, one instance per
  visual object (three Pandas send each link once), posed by Pinocchio's
  ``updateGeometryPlacements`` at q (decimated to ``max_faces`` triangles per system for the browser,
  :func:`coop_ga.viz.decimate`); a system without visual geometry is drawn as its skeleton;
* :class:`PrimitiveNode` — any :class:`coop_ga.Primitive` in a colour of the paper's palette
  (:data:`coop_ga.viz.PALETTE`): circles, point pairs and lines as lines of constant screen width (dashed
  for a target), spheres and planes as translucent surfaces with an outline, points as dots;
* :class:`PointsNode` — markers (end points) and :class:`PathNode` — polylines (end-point paths);
* :class:`BodyNode` — a box, ball or cylinder of the physics scene (:mod:`coop_ga.sim` logs).

World frame, metres, z up.  Colours: any matplotlib colour spec.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry import center, closest_point_to_origin, direction, endpoints, kind_of, normal, radius
from ..viz.mesh import _cell_for, decimate, object_mesh, visual_geometry
from ..viz.primitives import circle_points, square_points
from ..viz.robots import skeleton
from ..viz.style import PALETTE

__all__ = [
    "BodyNode",
    "PathNode",
    "PointsNode",
    "PrimitiveGeometry",
    "PrimitiveNode",
    "RobotNode",
    "poses_to_wxyz",
    "primitive_geometry",
    "rgb255",
]

#: triangles per system sent to the browser (software WebGL draws ~10⁶ triangles at a few Hz)
DEFAULT_MAX_FACES = 150_000


def rgb255(color: Any) -> tuple[int, int, int]:
    """A matplotlib colour as 8-bit RGB."""
    from matplotlib.colors import to_rgb

    r, g, b = to_rgb(color)
    return (round(255 * r), round(255 * g), round(255 * b))


def poses_to_wxyz(R: np.ndarray) -> np.ndarray:
    """Quaternions (n, 4) ``(w, x, y, z)`` of rotation matrices (n, 3, 3) (magnitudes from the diagonal,
    signs from the skew part: vectorised, accurate to ~1e-8 — for display)."""
    R = np.asarray(R, float).reshape(-1, 3, 3)
    d0, d1, d2 = R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]
    q = 0.5 * np.sqrt(
        np.maximum(0.0, np.stack([1 + d0 + d1 + d2, 1 + d0 - d1 - d2, 1 - d0 + d1 - d2, 1 - d0 - d1 + d2], 1))
    )
    q[:, 1] = np.copysign(q[:, 1], R[:, 2, 1] - R[:, 1, 2])
    q[:, 2] = np.copysign(q[:, 2], R[:, 0, 2] - R[:, 2, 0])
    q[:, 3] = np.copysign(q[:, 3], R[:, 1, 0] - R[:, 0, 1])
    return q / np.linalg.norm(q, axis=1, keepdims=True)


# ====================================================================== robots
class RobotNode:
    """A system drawn from its visual meshes under the scene node ``name`` (module docstring).

    Args:
        scene: a viser ``SceneApi`` (``server.scene``).
        name: the node path, e.g. ``"/robot"``.
        system: a :class:`~coop_ga.systems.System`.
        color: surface colour (default :attr:`~coop_ga.viz.Palette.robot_mesh`).
        max_faces: decimate the whole robot to about this many triangles (None: as loaded).
    """

    def __init__(
        self, scene: Any, name: str, system: Any, *, color: Any = None, max_faces: int | None = DEFAULT_MAX_FACES
    ):
        import pinocchio as pin

        self.scene, self.name, self.system = scene, name, system
        self.color = rgb255(PALETTE.robot_mesh if color is None else color)
        self._pin = pin
        self.geometry = visual_geometry(system)
        self._data = system.model.createData()
        self._groups: list[tuple[Any, np.ndarray]] = []
        self._skeleton: Any = None
        if self.geometry is None:
            return
        self._gdata = self.geometry.createData()
        for mesh, idx in _mesh_groups(self.geometry, max_faces):
            n = len(idx)
            handle = scene.add_batched_meshes_simple(
                f"{name}/mesh{len(self._groups)}",
                mesh.vertices.astype(np.float32),
                mesh.faces.astype(np.uint32),
                batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
                batched_positions=np.zeros((n, 3)),
                batched_colors=np.tile(self.color, (n, 1)).astype(np.uint8),
                lod="off",
                side="double",
            )
            self._groups.append((handle, idx))

    def placements(self, q: Any) -> np.ndarray:
        """World poses (G, 4, 4) of the visual objects at q (nq,) (fixed base: the system's own world frame)."""
        pin = self._pin
        q = np.asarray(q, dtype=float).reshape(-1)
        pin.forwardKinematics(self.system.model, self._data, q)
        pin.updateGeometryPlacements(self.system.model, self._data, self.geometry, self._gdata)
        return np.array([M.homogeneous for M in self._gdata.oMg])

    def update(self, q: Any, base: np.ndarray | None = None) -> None:
        """Pose the robot at configuration q (nq,) [rad | m]; ``base`` (4, 4): a world pose of its root."""
        if self.geometry is None:
            self._update_skeleton(q, base)
            return
        P = self.placements(q)
        if base is not None:
            P = np.asarray(base, float) @ P
        W = poses_to_wxyz(P[:, :3, :3])
        for handle, idx in self._groups:
            handle.batched_positions = np.ascontiguousarray(P[idx, :3, 3])
            handle.batched_wxyzs = W[idx]

    def _update_skeleton(self, q: Any, base: np.ndarray | None) -> None:
        seg = skeleton(self.system, q).segments
        if base is not None:
            B = np.asarray(base, float)
            seg = seg @ B[:3, :3].T + B[:3, 3]
        if self._skeleton is None:
            self._skeleton = self.scene.add_line_segments(
                f"{self.name}/skeleton", seg, colors=self.color, thickness=4.0, thickness_units="screen"
            )
        else:
            self._skeleton.points = seg

    def remove(self) -> None:
        for handle, _ in self._groups:
            handle.remove()
        if self._skeleton is not None:
            self._skeleton.remove()


def _mesh_groups(geometry: Any, max_faces: int | None) -> list[tuple[Any, np.ndarray]]:
    """``(mesh, object indices)`` per distinct mesh of a GeometryModel, decimated to about ``max_faces``
    triangles in total (one grid cell for the whole robot, :func:`coop_ga.viz.decimate`)."""
    groups: dict[int, tuple[Any, list[int]]] = {}
    for i, o in enumerate(geometry.geometryObjects):
        mesh = object_mesh(o)
        if mesh is not None and mesh.n_faces:
            groups.setdefault(id(mesh), (mesh, []))[1].append(i)
    out = [(mesh, np.array(idx)) for mesh, idx in groups.values()]
    total = sum(mesh.n_faces * len(idx) for mesh, idx in out)
    if max_faces is not None and total > max_faces:
        cell = _cell_for(sum(mesh.area() * len(idx) for mesh, idx in out), max_faces)
        out = [(m if m.n_faces <= 2.0 * m.area() / cell**2 else decimate(m, cell), idx) for m, idx in out]
        out = [(m, idx) for m, idx in out if m.n_faces]
    return out


# ====================================================================== primitives
@dataclass
class PrimitiveGeometry:
    """What a primitive looks like, world frame [m]: ``segments`` (S, 2, 3) lines, ``points`` (M, 3)
    dots, ``sphere`` (centre (3,), radius) or None, ``quad`` (4, 3) plane square or None."""

    kind: str
    segments: np.ndarray
    points: np.ndarray
    sphere: tuple[np.ndarray, float] | None = None
    quad: np.ndarray | None = None


def _polyline(P: np.ndarray) -> np.ndarray:
    return np.stack([P[:-1], P[1:]], axis=1)


def primitive_geometry(X: Any, anchor: Any = None, extent: float = 1.0) -> PrimitiveGeometry:
    """The lines, dots and surfaces that show the primitive X (world frame, metres).

    Lines and planes are infinite: a segment of length ``extent`` [m] (a square of side ``extent``)
    is drawn about their point nearest ``anchor`` (3,) (default: nearest the origin).
    """
    kind = kind_of(X)
    none = np.zeros((0, 2, 3))
    a = None if anchor is None else np.asarray(anchor, float).reshape(3)
    if kind == "point":
        return PrimitiveGeometry(kind, none, np.asarray(center(X), float).reshape(1, 3))
    if kind == "point_pair":
        P = np.array([np.asarray(e, float).reshape(3) for e in endpoints(X)])
        return PrimitiveGeometry(kind, P.reshape(1, 2, 3), P)
    if kind == "circle":
        C = circle_points(center(X), float(radius(X)), normal(X), 120)
        return PrimitiveGeometry(kind, _polyline(C), np.zeros((0, 3)))
    if kind == "sphere":
        c, r = np.asarray(center(X), float).reshape(3), float(radius(X))
        return PrimitiveGeometry(kind, _polyline(circle_points(c, r, [0, 0, 1], 120)), np.zeros((0, 3)), (c, r))
    base = np.asarray(closest_point_to_origin(X), float).reshape(3)
    if kind == "line":
        k = np.asarray(direction(X), float).reshape(3)
        k = k / np.linalg.norm(k)
        foot = base if a is None else base + ((a - base) @ k) * k
        return PrimitiveGeometry(kind, np.array([[foot - 0.5 * extent * k, foot + 0.5 * extent * k]]), np.zeros((0, 3)))
    n = np.asarray(normal(X), float).reshape(3)
    n = n / np.linalg.norm(n)
    foot = base if a is None else a - ((a - base) @ n) * n
    Q = square_points(foot, n, extent)
    return PrimitiveGeometry(kind, _polyline(np.vstack([Q, Q[:1]])), np.zeros((0, 3)), quad=Q)


class PrimitiveNode:
    """A primitive under the scene node ``name``, redrawn by :meth:`update` (module docstring).

    Args:
        scene: a viser ``SceneApi``; name: the node path.
        color: any matplotlib colour (the paper's: :data:`coop_ga.viz.PALETTE`).
        width: line width [px].  dashed: every other segment left out (a target).
        marker: dot diameter [m] of points and point-pair ends.  opacity: of sphere and plane surfaces.
    """

    def __init__(
        self,
        scene: Any,
        name: str,
        color: Any,
        *,
        width: float = 4.0,
        dashed: bool = False,
        marker: float = 0.025,
        opacity: float = 0.25,
    ):
        self.scene, self.name = scene, name
        self.color = rgb255(color)
        self.width, self.dashed, self.marker, self.opacity = float(width), bool(dashed), float(marker), float(opacity)
        self.kind: str | None = None
        self._nodes: dict[str, Any] = {}

    def update(self, X: Any, anchor: Any = None, extent: float = 1.0) -> PrimitiveGeometry | None:
        """Draw X (None: hide); returns its :class:`PrimitiveGeometry`."""
        if X is None:
            for h in self._nodes.values():
                h.visible = False
            return None
        g = primitive_geometry(X, anchor, extent)
        seg = g.segments[::2] if self.dashed and len(g.segments) > 2 else g.segments
        if g.kind != self.kind:
            self._build(g, seg)
        else:
            self._move(g, seg)
        for h in self._nodes.values():
            h.visible = True
        return g

    def _build(self, g: PrimitiveGeometry, seg: np.ndarray) -> None:
        self.remove()
        self.kind = g.kind
        sc, n = self.scene, self.name
        if len(seg):
            self._nodes["lines"] = sc.add_line_segments(
                f"{n}/lines", seg, colors=self.color, thickness=self.width, thickness_units="screen"
            )
        if len(g.points):
            self._nodes["dots"] = sc.add_point_cloud(
                f"{n}/dots",
                g.points,
                colors=self.color,
                point_size=self.marker,
                point_shape="circle",
                precision="float32",
            )
        if g.sphere is not None:
            c, r = g.sphere
            self._nodes["surface"] = sc.add_icosphere(
                f"{n}/surface", radius=r, color=self.color, opacity=self.opacity, position=c, subdivisions=4
            )
        if g.quad is not None:
            self._nodes["surface"] = sc.add_mesh_simple(
                f"{n}/surface",
                g.quad,
                np.array([[0, 1, 2], [0, 2, 3]]),
                color=self.color,
                opacity=self.opacity,
                side="double",
            )

    def _move(self, g: PrimitiveGeometry, seg: np.ndarray) -> None:
        nodes = self._nodes
        if "lines" in nodes:
            nodes["lines"].points = seg
        if "dots" in nodes:
            nodes["dots"].points = g.points.astype(np.float32)
        if g.sphere is not None:
            nodes["surface"].radius = g.sphere[1]
            nodes["surface"].position = g.sphere[0]
        if g.quad is not None:
            nodes["surface"].vertices = g.quad.astype(np.float32)

    def remove(self) -> None:
        for h in self._nodes.values():
            h.remove()
        self._nodes.clear()
        self.kind = None


class PointsNode:
    """Dots (markers) at points (N, 3) [m], e.g. the end points; :meth:`update` moves them."""

    def __init__(self, scene: Any, name: str, color: Any = PALETTE.end_point, size: float = 0.02):
        self.scene, self.name, self.color, self.size = scene, name, rgb255(color), float(size)
        self._h: Any = None

    def update(self, points: Any) -> None:
        P = np.asarray(points, float).reshape(-1, 3).astype(np.float32)
        if self._h is None or len(P) != len(self._h.points):
            if self._h is not None:
                self._h.remove()
            self._h = self.scene.add_point_cloud(
                self.name, P, colors=self.color, point_size=self.size, point_shape="circle", precision="float32"
            )
        else:
            self._h.points = P


class PathNode:
    """Polylines (paths (k, N, 3) [m]: k curves of N points), drawn up to a count of points."""

    def __init__(self, scene: Any, name: str, color: Any = PALETTE.trajectory, width: float = 2.0):
        self.scene, self.name, self.color, self.width = scene, name, rgb255(color), float(width)
        self._h: Any = None

    def update(self, paths: Any, upto: int | None = None) -> None:
        P = np.asarray(paths, float)
        P = P[:, : (P.shape[1] if upto is None else max(int(upto), 0))]
        seg = np.concatenate([_polyline(c) for c in P]) if P.shape[1] >= 2 else np.zeros((0, 2, 3))
        if self._h is not None:
            self._h.remove()
            self._h = None
        if len(seg):
            self._h = self.scene.add_line_segments(
                self.name, seg, colors=self.color, thickness=self.width, thickness_units="screen"
            )


# ====================================================================== physics objects
@dataclass(frozen=True)
class BodyShape:
    """A geom of a free body of a MuJoCo scene: ``kind`` ``'box'`` (half sizes (3,)), ``'sphere'``
    (radius), ``'cylinder'``/``'capsule'`` (radius, half length); ``rgba`` (4,) in [0, 1]; its pose in the
    body (position (3,), quaternion wxyz (4,))."""

    kind: str
    size: tuple[float, ...]
    rgba: tuple[float, float, float, float]
    position: tuple[float, float, float]
    wxyz: tuple[float, float, float, float]


class BodyNode:
    """A free body of a physics log as simple shapes (boxes, balls, cylinders) under ``name``."""

    def __init__(self, scene: Any, name: str, shapes: list[BodyShape]):
        self._frame = scene.add_frame(name, show_axes=False)
        for i, s in enumerate(shapes):
            col = tuple(round(255 * c) for c in s.rgba[:3])
            kw = dict(color=col, position=s.position, wxyz=s.wxyz, opacity=s.rgba[3] if s.rgba[3] < 1 else None)
            if s.kind == "box":
                scene.add_box(f"{name}/geom{i}", dimensions=tuple(2 * x for x in s.size), **kw)
            elif s.kind == "sphere":
                scene.add_icosphere(f"{name}/geom{i}", radius=s.size[0], **kw)
            else:  # cylinder, or a capsule drawn as its cylinder
                scene.add_cylinder(f"{name}/geom{i}", radius=s.size[0], height=2 * s.size[1], **kw)

    def update(self, position: Any, wxyz: Any) -> None:
        """Pose the body: position (3,) [m], quaternion (w, x, y, z) (4,) in the world."""
        self._frame.position = np.asarray(position, float)
        self._frame.wxyz = np.asarray(wxyz, float)
