"""Robot surfaces from their visual geometry: triangle meshes in the world frame at a configuration.

A system's visual ``pinocchio.GeometryModel`` (:meth:`coop_ga.systems.System.visual_model`:
the URDF ``<visual>`` meshes of example-robot-data's panda, G1 and Allegro — ``.dae`` /
``.STL`` read by coal/assimp, extensions in any case — and the boxes, cylinders and spheres
of our own iiwa14 and hexapod URDFs) is turned into triangles here:

* :func:`object_mesh` — the triangles of one geometry object in *its own frame* (the mesh
  as loaded, with the URDF's scale; primitive shapes tessellated), cached per process by
  mesh file and scale (or shape and size), so three Pandas read and convert each link once;
* :func:`decimate` — vertex clustering on a grid of cell size ``cell`` [m] (a heavy mesh for
  the matplotlib renderer: a G1's 290 000 triangles become ~10 000), cached as well;
* :func:`robot_mesh` — per frame: ``pinocchio.updateGeometryPlacements`` at q, then every
  object's triangles moved by its world pose ``oMg`` and merged into one :class:`TriMesh`
  (vertices (n, 3) [m], faces (m, 3), unit vertex normals (n, 3), world frame).

A system without visual geometry (a user model from :func:`coop_ga.systems.from_model` without
``visual_model=``) gives None, and the renderers draw its skeleton instead, with a
:class:`RenderWarning`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..diagnostics import warn
from ..errors import CoopGAError, RendererUnavailableError, RenderWarning

__all__ = [
    "RenderWarning",
    "RendererUnavailableError",
    "TriMesh",
    "decimate",
    "object_mesh",
    "object_placements",
    "robot_mesh",
    "visual_geometry",
]


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
        return TriMesh(self.vertices @ R.T + t, self.faces, self.normals @ R.T)

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
_DECIMATED: dict[tuple[Any, float], TriMesh] = {}
_KEEP: dict[Any, Any] = {}  # geometries keyed by id(): kept alive while cached
_AREA: dict[Any, float] = {}
_VTK_NORMALS: dict[int, TriMesh] = {}  # by id() of a cached (full or decimated) mesh


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


def object_mesh(obj: Any) -> TriMesh | None:
    """Triangles of a ``pinocchio.GeometryObject`` in the object's own frame (metres), or None for a
    shape that cannot be tessellated (e.g. a half-space).  Cached per process by mesh file + scale
    (or by shape and size)."""
    key = _object_key(obj)
    if key not in _OBJECT_CACHE:
        geom = obj.geometry
        _OBJECT_CACHE[key] = _bvh_mesh(geom) if hasattr(geom, "num_tris") else _shape_mesh(geom)
    return _OBJECT_CACHE[key]


def decimate(mesh: TriMesh, cell: float) -> TriMesh:
    """Vertex clustering: vertices in the same cube of side ``cell`` [m] merge (at their mean),
    collapsed and duplicate triangles are dropped, normals recomputed.

    The output has at most about 2·area/cell² triangles (cell = 0.018 m turns a G1's 290 000
    triangles into ~12 000); shapes smaller than ``cell`` shrink to nothing.
    """
    V, F = mesh.vertices, mesh.faces
    if len(F) == 0 or cell <= 0:
        return mesh
    k = np.floor((V - V.min(axis=0)) / cell).astype(np.int64)
    dims = k.max(axis=0) + 1
    key = (k[:, 0] * dims[1] + k[:, 1]) * dims[2] + k[:, 2]
    _, inv = np.unique(key, return_inverse=True)
    inv = inv.reshape(-1)
    cnt = np.bincount(inv).astype(float)
    Vn = np.column_stack([np.bincount(inv, V[:, j]) / cnt for j in range(3)])
    Fn = inv[F]
    Fn = Fn[(Fn[:, 0] != Fn[:, 1]) & (Fn[:, 1] != Fn[:, 2]) & (Fn[:, 0] != Fn[:, 2])]
    if len(Fn):
        s = np.sort(Fn, axis=1)
        n = len(Vn)
        _, first = np.unique((s[:, 0] * n + s[:, 1]) * n + s[:, 2], return_index=True)
        Fn = Fn[np.sort(first)]
    return _mesh(Vn, Fn)


def _cell_for(total_area: float, max_faces: int) -> float:
    """Grid cell [m] for about ``max_faces`` triangles over ``total_area`` [m²], rounded up to a
    power of 2^(1/4) so that robots of similar size share the decimated meshes in the cache."""
    c = math.sqrt(2.0 * total_area / max(int(max_faces), 1))
    return float(2.0 ** (math.ceil(4.0 * math.log2(c)) / 4.0))


def visual_geometry(system: Any) -> Any:
    """The visual ``pinocchio.GeometryModel`` of ``system`` (:meth:`System.visual_model`), or None
    — with a :class:`RenderWarning` naming the reason — if it has none or it cannot be read."""
    name = getattr(system, "name", "?")
    get = getattr(system, "visual_model", None)
    if get is None:
        _notice(f"system '{name}' has no visual geometry: drawing its skeleton", key=f"novisual:{name}")
        return None
    try:
        gm = get()
    except CoopGAError as e:
        _notice(f"visual geometry of system '{name}' unavailable ({e}): drawing its skeleton", key=f"novisual:{name}")
        return None
    if gm is None or gm.ngeoms == 0:
        why = "built without visual_model= or visuals=" if gm is None else "its URDF has no <visual> elements"
        _notice(f"system '{name}' has no visual geometry ({why}): drawing its skeleton", key=f"novisual:{name}")
        return None
    return gm


def object_placements(system: Any, q: Any) -> np.ndarray | None:
    """World poses (G, 4, 4) of the G visual objects of ``system`` at ``q`` (nq,) [rad | m]
    (``pinocchio.updateGeometryPlacements``; translations in metres), or None without visual geometry."""
    import pinocchio as pin

    gm = visual_geometry(system)
    if gm is None:
        return None
    m = system.model
    q = np.asarray(q, dtype=float).reshape(-1)
    if q.shape != (m.nq,):
        from ..errors import InvalidInputError

        raise InvalidInputError(
            f"q must have {m.nq} entries for system {getattr(system, 'name', '?')!r}, got {q.shape}"
        )
    d = m.createData()
    gd = gm.createData()
    pin.forwardKinematics(m, d, q)
    pin.updateGeometryPlacements(m, d, gm, gd)
    return np.array([np.asarray(M.homogeneous) for M in gd.oMg]).reshape(-1, 4, 4)


def robot_mesh(
    system: Any,
    q: Any,
    *,
    max_faces: int | None = None,
    exclude: Any = (),
    placements: Any = None,
    shrink: float = 1.0,
    vtk_normals: bool = False,
) -> TriMesh | None:
    """All visual triangles of ``system`` at configuration ``q`` (nq,) [rad | m], world frame [m].

    Per call: forward kinematics and ``pinocchio.updateGeometryPlacements`` at q
    (:func:`object_placements`, or the ``placements`` (G, 4, 4) given), then each object's
    cached mesh moved by its world pose ``oMg``.  ``max_faces``: decimate (vertex clustering,
    one grid cell for the whole robot) to about that many triangles — the decimated meshes
    are cached too.  ``exclude``: indices of visual objects to leave out.  ``shrink``: scale
    every object about its bounding-box centre (in its own frame).  ``vtk_normals``: shading
    normals from VTK's ``vtkPolyDataNormals`` (winding made consistent, vertices split at
    edges sharper than 40°; once per mesh) instead of the area-weighted vertex normals — the
    meshes of the URDFs we load have a few flipped and doubled triangles, whose averaged
    normals show as dark patches when smooth-shaded.  Returns None when the system has no
    visual geometry (see :func:`visual_geometry`).
    """
    gm = visual_geometry(system)
    if gm is None:
        return None
    poses = object_placements(system, q) if placements is None else np.asarray(placements, float)
    assert poses is not None
    skip = {int(i) for i in exclude}
    parts: list[tuple[TriMesh, Any, np.ndarray]] = []
    for i, o in enumerate(gm.geometryObjects):
        mesh = None if i in skip else object_mesh(o)
        if mesh is not None and mesh.n_faces:
            parts.append((mesh, _object_key(o), poses[i]))
    if max_faces is not None and sum(p[0].n_faces for p in parts) > max_faces:
        for mesh, key, _ in parts:
            if key not in _AREA:
                _AREA[key] = mesh.area()
        cell = _cell_for(sum(_AREA[key] for _, key, _ in parts), max_faces)
        out = []
        for mesh, key, M in parts:
            dk = (key, cell)
            if dk not in _DECIMATED:
                # a mesh already coarser than the grid is kept as it is
                coarse = mesh.n_faces <= 2.0 * _AREA[key] / cell**2
                _DECIMATED[dk] = mesh if coarse else decimate(mesh, cell)
            out.append((_DECIMATED[dk], key, M))
        parts = out
    if vtk_normals:
        done = []
        for mesh, key, M in parts:
            if id(mesh) not in _VTK_NORMALS:
                _KEEP[id(mesh)] = mesh
                _VTK_NORMALS[id(mesh)] = _with_vtk_normals(mesh)
            done.append((_VTK_NORMALS[id(mesh)], key, M))
        parts = done
    if shrink != 1.0:
        parts = [(_shrunk(mesh, shrink), key, M) for mesh, key, M in parts]
    return TriMesh.merge([mesh.transformed(M[:3, :3], M[:3, 3]) for mesh, _, M in parts])


def _with_vtk_normals(mesh: TriMesh) -> TriMesh:
    """The mesh with consistent winding and split-vertex normals from ``vtkPolyDataNormals`` (PyVista)."""
    import importlib

    pv = importlib.import_module("pyvista")
    poly = pv.PolyData.from_regular_faces(mesh.vertices, mesh.faces)
    out = poly.compute_normals(
        cell_normals=False, point_normals=True, split_vertices=True, consistent_normals=True, feature_angle=40.0
    )
    F = np.asarray(out.regular_faces if hasattr(out, "regular_faces") else out.faces.reshape(-1, 4)[:, 1:])
    return _mesh(np.asarray(out.points, float), F, np.asarray(out.point_data["Normals"], float))


def _shrunk(mesh: TriMesh, s: float) -> TriMesh:
    V = mesh.vertices
    c = 0.5 * (V.min(axis=0) + V.max(axis=0))
    return TriMesh(c + s * (V - c), mesh.faces, mesh.normals)


# ====================================================================== notices
_NOTICED: set[str] = set()


def _notice(message: str, *, key: str) -> None:
    """A one-line :class:`RenderWarning`, once per process and condition (15 figures, one notice)."""
    if key in _NOTICED:
        return
    _NOTICED.add(key)
    warn(f"coop_ga.viz: {message}", RenderWarning, key=key)
