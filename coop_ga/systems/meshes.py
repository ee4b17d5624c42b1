"""Triangle meshes of visual geometry objects, in the object's own frame (no drawing: the systems sit below viz).

The mesh-loading half of :mod:`coop_ga.viz.mesh`, moved here so that layers below
:mod:`coop_ga.viz` (:mod:`coop_ga.collision` fits its capsules to these vertices) can use it;
:mod:`coop_ga.viz.mesh` re-exports every public name.

* :class:`TriMesh` — vertices (n, 3) [m], faces (m, 3) vertex indices, unit vertex normals (n, 3);
* :func:`object_mesh` — the triangles of one ``pinocchio.GeometryObject`` in *its own frame*
  (the mesh as loaded by coal/assimp with the URDF's scale; primitive shapes — Box, Sphere,
  Ellipsoid, Cylinder, Cone, Capsule — tessellated), cached per process by mesh file and
  scale (or shape and size), so three Pandas read and convert each link once.

The object's pose in its parent joint frame is ``obj.placement`` (Pinocchio's convention);
its world pose at q is ``geom_data.oMg[i]`` after ``pinocchio.updateGeometryPlacements``.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError

__all__ = ["TriMesh", "object_key", "object_mesh"]


@dataclass(frozen=True)
class TriMesh:
    """A triangle mesh: ``vertices`` (n, 3) [m], ``faces`` (m, 3) vertex indices, unit vertex
    ``normals`` (n, 3) (area-weighted face normals, for smooth shading)."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    def area(self) -> float:
        """Surface area [m²]."""
        return float(_face_areas(self.vertices, self.faces).sum())

    def transformed(self, R: np.ndarray, t: np.ndarray) -> TriMesh:
        """The mesh moved by the rigid motion x ↦ R x + t (R (3, 3), t (3,) [m])."""
        Rm = validation.array(R, "R", shape=(3, 3))
        tv = validation.vector(t, 3, "t [m]")
        return TriMesh(self.vertices @ Rm.T + tv, self.faces, self.normals @ Rm.T)

    @staticmethod
    def merge(meshes: list[TriMesh]) -> TriMesh:
        """One mesh holding every triangle of ``meshes``."""
        if not meshes:
            return TriMesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros((0, 3)))
        offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
        return TriMesh(
            np.vstack([m.vertices for m in meshes]),
            np.vstack([m.faces + o for m, o in zip(meshes, offsets)]),
            np.vstack([m.normals for m in meshes]),
        )


def _face_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)


def _vertex_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Unit vertex normals: the sum of the (area-weighted) normals of the faces around each vertex."""
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N = np.zeros_like(V)
    for k in range(3):
        np.add.at(N, F[:, k], fn)
    n = np.linalg.norm(N, axis=1, keepdims=True)
    return np.divide(N, n, out=np.tile([0.0, 0.0, 1.0], (len(V), 1)), where=n > 1e-300)


def _mesh(V: Any, F: Any, normals: Any = None) -> TriMesh:
    V = np.ascontiguousarray(V, dtype=float).reshape(-1, 3)
    F = np.ascontiguousarray(F, dtype=np.int64).reshape(-1, 3)
    N = _vertex_normals(V, F) if normals is None else np.asarray(normals, float).reshape(-1, 3)
    for a in (V, F, N):
        a.setflags(write=False)
    return TriMesh(V, F, N)


# ====================================================================== shapes
def _box(half: np.ndarray) -> TriMesh:
    """An axis-aligned box of half sides ``half`` [m] about the origin; 4 vertices per side (flat shading)."""
    V: list[np.ndarray] = []
    F: list[list[int]] = []
    N: list[np.ndarray] = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = np.zeros(3)
            n[axis] = sign
            u, v = np.eye(3)[(axis + 1) % 3], np.eye(3)[(axis + 2) % 3]
            if sign < 0:
                u, v = v, u
            c = n * half
            corners = [c + su * u * half + sv * v * half for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            o = len(V)
            V += corners
            N += [n] * 4
            F += [[o, o + 1, o + 2], [o, o + 2, o + 3]]
    return _mesh(V, F, N)


def _revolved(profile: list[tuple[float, float]], m: int = 48) -> TriMesh:
    """Surface of revolution about z of a (radius, z) polyline; flat caps where the profile
    starts/ends off the axis.  Vertices are not shared between profile segments, so each band
    (side, cap) is shaded on its own."""
    t = np.linspace(0.0, 2.0 * np.pi, m, endpoint=False)
    ring = np.column_stack([np.cos(t), np.sin(t)])
    V: list[np.ndarray] = []
    F: list[np.ndarray] = []
    N: list[np.ndarray] = []

    def band(r0: float, z0: float, r1: float, z1: float) -> None:
        o = sum(len(v) for v in V)
        dz, dr = z1 - z0, r1 - r0
        nr, nz = dz, -dr  # outward normal of the profile segment
        ln = math.hypot(nr, nz) or 1.0
        nrm = np.column_stack([ring * (nr / ln), np.full(m, nz / ln)])
        V.append(
            np.vstack([np.column_stack([ring * r0, np.full(m, z0)]), np.column_stack([ring * r1, np.full(m, z1)])])
        )
        N.append(np.vstack([nrm, nrm]))
        i = np.arange(m)
        j = (i + 1) % m
        F.append(
            np.vstack([np.column_stack([o + i, o + j, o + m + j]), np.column_stack([o + i, o + m + j, o + m + i])])
        )

    def cap(r: float, z: float, up: bool) -> None:
        o = sum(len(v) for v in V)
        V.append(np.vstack([[0.0, 0.0, z], np.column_stack([ring * r, np.full(m, z)])]))
        N.append(np.tile([0.0, 0.0, 1.0 if up else -1.0], (m + 1, 1)))
        i = np.arange(m)
        j = (i + 1) % m
        tri = (
            np.column_stack([np.zeros(m, np.int64), 1 + i, 1 + j])
            if up
            else np.column_stack([np.zeros(m, np.int64), 1 + j, 1 + i])
        )
        F.append(o + tri)

    if profile[0][0] > 0:
        cap(profile[0][0], profile[0][1], up=False)
    for (r0, z0), (r1, z1) in itertools.pairwise(profile):
        band(r0, z0, r1, z1)
    if profile[-1][0] > 0:
        cap(profile[-1][0], profile[-1][1], up=True)
    return _mesh(np.vstack(V), np.vstack(F), np.vstack(N))


def _sphere(radius: float, m: int = 24) -> TriMesh:
    """UV sphere of ``radius`` [m] about the origin, smooth normals."""
    pol = np.linspace(0.0, np.pi, m // 2 + 1)
    az = np.linspace(0.0, 2.0 * np.pi, m, endpoint=False)
    P, A = np.meshgrid(pol, az, indexing="ij")
    N = np.stack([np.sin(P) * np.cos(A), np.sin(P) * np.sin(A), np.cos(P)], axis=-1).reshape(-1, 3)
    F = []
    rows = m // 2 + 1
    for a in range(rows - 1):
        for b in range(m):
            i0, i1 = a * m + b, a * m + (b + 1) % m
            j0, j1 = i0 + m, i1 + m
            F += [[i0, j0, j1], [i0, j1, i1]]
    Fa = np.array(F)
    Fa = Fa[(Fa[:, 0] != Fa[:, 1]) & (Fa[:, 1] != Fa[:, 2])]
    return _mesh(radius * N, Fa, N)


def _hemisphere_profile(radius: float, z: float, up: bool, k: int = 6) -> list[tuple[float, float]]:
    a = np.linspace(0.0, 0.5 * np.pi, k + 1)
    pts = [(radius * math.cos(x), z + (1 if up else -1) * radius * math.sin(x)) for x in a]
    return pts if up else pts[::-1]


def _shape_mesh(geom: Any) -> TriMesh | None:
    """Tessellation of a coal primitive shape (Box, Cylinder, Sphere, Capsule, Cone, Ellipsoid), or None."""
    kind = type(geom).__name__
    if kind == "Box":
        return _box(np.asarray(geom.halfSide, float))
    if kind == "Sphere":
        return _sphere(float(geom.radius))
    if kind == "Ellipsoid":
        s = _sphere(1.0)
        return _mesh(s.vertices * np.asarray(geom.radii, float), s.faces)
    if kind in ("Cylinder", "Cone", "Capsule"):
        r, h = float(geom.radius), float(geom.halfLength)
        if kind == "Cylinder":
            return _revolved([(r, -h), (r, h)])
        if kind == "Cone":
            return _revolved([(r, -h), (0.0, h)])
        return _revolved(_hemisphere_profile(r, -h, up=False) + _hemisphere_profile(r, h, up=True)[1:])
    return None


def _shape_key(geom: Any) -> tuple[Any, ...] | None:
    kind = type(geom).__name__
    params = {
        "Box": ("halfSide",),
        "Sphere": ("radius",),
        "Ellipsoid": ("radii",),
        "Cylinder": ("radius", "halfLength"),
        "Cone": ("radius", "halfLength"),
        "Capsule": ("radius", "halfLength"),
    }.get(kind)
    if params is None:
        return None
    return (kind, *(tuple(np.round(np.atleast_1d(np.asarray(getattr(geom, p), float)), 12)) for p in params))


def _bvh_mesh(geom: Any) -> TriMesh:
    """Vertices and triangles of a coal BVH model (a loaded mesh; the URDF scale is already applied)."""
    V = np.array(geom.vertices(), dtype=float).reshape(-1, 3)
    n = int(geom.num_tris)
    F = np.empty((n, 3), np.int64)
    for i in range(n):
        t = geom.tri_indices(i)
        F[i] = (t[0], t[1], t[2])
    return _mesh(V, F)


# ====================================================================== caches
_OBJECT_CACHE: dict[Any, TriMesh | None] = {}
_KEEP: dict[Any, Any] = {}  # geometries keyed by id(): kept alive while cached


def _object_key(obj: Any) -> Any:
    geom = obj.geometry
    path = str(getattr(obj, "meshPath", "") or "")
    if path and hasattr(geom, "num_tris"):
        return ("mesh", path, tuple(np.round(np.asarray(obj.meshScale, float), 12)))
    k = _shape_key(geom)
    if k is not None:
        return k
    _KEEP[id(geom)] = geom
    return ("object", id(geom))


def _geometry_object(obj: Any) -> Any:
    import pinocchio as pin

    if not isinstance(obj, pin.GeometryObject):
        raise InvalidInputError(f"obj must be a pinocchio.GeometryObject, got {type(obj).__name__}")
    return obj


def object_mesh(obj: Any) -> TriMesh | None:
    """Triangles of a ``pinocchio.GeometryObject`` in the object's own frame (metres), or None for a
    shape that cannot be tessellated (e.g. a half-space).  Cached per process by mesh file + scale
    (or by shape and size)."""
    key = _object_key(_geometry_object(obj))
    if key not in _OBJECT_CACHE:
        geom = obj.geometry
        _OBJECT_CACHE[key] = _bvh_mesh(geom) if hasattr(geom, "num_tris") else _shape_mesh(geom)
    return _OBJECT_CACHE[key]


def object_key(obj: Any) -> Any:
    """The cache key of a ``pinocchio.GeometryObject``'s triangles: ``("mesh", path, scale)`` for a
    loaded mesh, ``(shape, sizes…)`` for a primitive shape, ``("object", id)`` otherwise."""
    return _object_key(_geometry_object(obj))
