"""Robot surfaces from their visual geometry: triangle meshes in the world frame at a configuration.

A system's visual ``pinocchio.GeometryModel`` (:meth:`coop_ga.systems.System.visual_model`:
the URDF ``<visual>`` meshes of example-robot-data's panda, G1 and Allegro — ``.dae`` /
``.STL`` read by coal/assimp, extensions in any case — and the boxes, cylinders and spheres
of our own iiwa14 and hexapod URDFs) is turned into triangles here:

* :func:`object_mesh` — the triangles of one geometry object in *its own frame* (the mesh
  as loaded, with the URDF's scale; primitive shapes tessellated), cached per process by
  mesh file and scale (or shape and size), so three Pandas read and convert each link once
  (defined in :mod:`coop_ga.systems.meshes` with :class:`TriMesh`, re-exported here);
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

import math
from typing import Any

import numpy as np

from ..diagnostics import warn
from ..errors import CoopGAError, RendererUnavailableError, RenderWarning

# the mesh loading (TriMesh, object_mesh and its cache) lives in coop_ga.systems.meshes, so that
# coop_ga.collision (below viz) fits capsules to the same vertices; re-exported here unchanged
from ..systems.meshes import (  # noqa: F401  (private names kept importable from viz.mesh)
    _KEEP,
    _OBJECT_CACHE,
    TriMesh,
    _face_areas,
    _mesh,
    _object_key,
    _shape_key,
    _shape_mesh,
    _vertex_normals,
    object_mesh,
)

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


# ====================================================================== caches
_DECIMATED: dict[tuple[Any, float], TriMesh] = {}
_AREA: dict[Any, float] = {}
_VTK_NORMALS: dict[int, TriMesh] = {}  # by id() of a cached (full or decimated) mesh


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
