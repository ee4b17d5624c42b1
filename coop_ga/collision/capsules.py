"""Robot bodies as capsules: a segment rigidly attached to a link frame plus a radius.

A :class:`Capsule` is the set of points within ``radius`` of the segment [a, b], with a and b
given in the coordinates of a Pinocchio frame (a link's BODY frame).  Its world segment at q is
``[oMf(q)·a, oMf(q)·b]``; every distance of :mod:`coop_ga.collision.distance` takes it from there.

:func:`fit_capsules` fits one bounding capsule per link to the link's mesh vertices
(``source="collision"``: the URDF's ``<collision>`` elements, read with
``pinocchio.buildGeomFromUrdf(..., pin.COLLISION)``; ``source="visual"``:
:meth:`coop_ga.systems.System.visual_model`):

1. the axis u is the principal axis (largest eigenvalue of the vertex covariance, PCA);
2. the axis line passes through the centre of the vertices' bounding rectangle in the plane
   perpendicular to u (or through their mean, whichever gives the smaller radius);
   ``radius = max_i ρ_i`` with ρ_i the distance of vertex i from that line;
3. with ``τ_i`` the coordinate of vertex i along u and ``h_i = sqrt(radius² − ρ_i²)``, the
   shortest enclosing segment is ``[max_i(τ_i − h_i) … min_i(τ_i + h_i)]`` reversed:
   ``t0 = min_i(τ_i + h_i)``, ``t1 = max_i(τ_i − h_i)``.  If ``t0 ≤ t1`` the segment is
   [t0, t1]; otherwise every τ in [t1, t0] is within ``h_i`` of every τ_i and the capsule
   degenerates to a ball at the midpoint (a sphere-like link).

Every vertex is then within ``radius`` of the segment (up to the added ``1e-9`` m), which
``tests/collision/test_capsules.py`` checks on every link of the registered arms.  The capsule
is a bound, not the minimum-volume capsule: for the Panda it is ~1–2 cm fatter than the mesh.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError, UnknownNameError
from .distance import MAX_COORDINATE

__all__ = ["Capsule", "capsule_chain", "fit_capsule", "fit_capsules", "link_meshes"]

#: radius padding [m] so that enclosure survives floating-point round-off
_PAD = 1e-9
#: vertex coordinates [m] beyond this are refused (the vertex covariance XᵀX must not overflow)
_MAX_VERTEX = 1e100


def _points(points: Any, what: str) -> np.ndarray:
    """Points (n, 3) [m] (one point (3,) gives n = 1), finite (a new array)."""
    P = validation.array(points, what)
    if P.ndim == 1 and P.shape == (3,):
        P = P.reshape(1, 3)
    if P.ndim != 2 or P.shape[1] != 3:
        raise InvalidInputError(f"{what} must be points of shape (n, 3) [m] (or one point (3,)), got shape {P.shape}")
    if P.size and float(np.max(np.abs(P))) > MAX_COORDINATE:
        raise InvalidInputError(f"{what} reach {float(np.max(np.abs(P))):.3g} m, beyond ±{MAX_COORDINATE:g} m")
    return P


def check_system(system: Any, what: str = "system") -> Any:
    """``system`` if it is a :class:`coop_ga.systems.System`, else :class:`InvalidInputError` naming ``what``."""
    from ..systems.system import System

    if not isinstance(system, System):
        raise InvalidInputError(
            f"{what} must be a coop_ga.systems.System (coop_ga.systems.load(name) or from_urdf(...)), "
            f"got {type(system).__name__}"
        )
    return system


@dataclass(frozen=True, eq=False)
class Capsule:
    """A capsule rigidly attached to a Pinocchio frame.

    frame: name of the frame (of ``system.model``) the segment is attached to;
    a, b: (3,) segment ends in that frame's coordinates [m];
    radius: [m] (≥ 0);
    chain: index of the chain (end point of the system) the body belongs to (:func:`capsule_chain`;
    an arm's world-fixed base link belongs to that arm), −1 for a body shared by several chains
    (a torso) or by none;
    link: a label (the link name, defaults to ``frame``).
    """

    frame: str
    a: np.ndarray
    b: np.ndarray
    radius: float
    chain: int = -1
    link: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.frame, str) or not self.frame:
            raise InvalidInputError(f"Capsule.frame must be a non-empty frame name, got {self.frame!r}")
        for k in ("a", "b"):
            v = validation.vector(getattr(self, k), 3, f"Capsule.{k} (a segment end [m])")
            if float(np.max(np.abs(v))) > MAX_COORDINATE:
                raise InvalidInputError(f"Capsule.{k} = {v.tolist()} is beyond ±{MAX_COORDINATE:g} m")
            v.setflags(write=False)
            object.__setattr__(self, k, v)
        r = validation.nonnegative(self.radius, "Capsule.radius [m]")
        if r > MAX_COORDINATE:
            raise InvalidInputError(f"Capsule.radius = {r:g} m is beyond {MAX_COORDINATE:g} m")
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "chain", validation.integer(self.chain, "Capsule.chain (a chain index, −1: none)",
                                                             minimum=-1))  # fmt: skip
        if not isinstance(self.link, str):
            raise InvalidInputError(f"Capsule.link must be a string (a label), got {self.link!r}")
        if not self.link:
            object.__setattr__(self, "link", self.frame)

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Capsule)
            and (self.frame, self.radius, self.chain, self.link) == (other.frame, other.radius, other.chain, other.link)
            and bool(np.array_equal(self.a, other.a) and np.array_equal(self.b, other.b))
        )

    def __hash__(self) -> int:
        return hash((self.frame, tuple(self.a.tolist()), tuple(self.b.tolist()), self.radius, self.chain, self.link))

    @property
    def length(self) -> float:
        """|b − a| [m]."""
        return float(np.linalg.norm(self.b - self.a))

    def contains(self, points: Any, tol: float = 0.0) -> np.ndarray:
        """(n,) bool: points (n, 3) in the frame's coordinates [m] within ``radius + tol`` of the segment
        (``tol`` ≥ 0 [m])."""
        t = validation.nonnegative(tol, "tol [m]")
        return self.point_distance(points) <= self.radius + t

    def point_distance(self, points: Any) -> np.ndarray:
        """(n,) distance [m] of points (n, 3) or one point (3,) (frame coordinates) from the segment [a, b]."""
        P = _points(points, "points")
        d = self.b - self.a
        L2 = float(d @ d)
        t = np.zeros(len(P)) if L2 <= 1e-24 else np.clip((P - self.a) @ d / L2, 0.0, 1.0)
        return np.linalg.norm(P - (self.a + t[:, None] * d), axis=1)


# ====================================================================== fitting
def fit_capsule(vertices: Any, axis: Any = None) -> tuple[np.ndarray, np.ndarray, float]:
    """``(a, b, radius)``: a capsule enclosing every row of ``vertices`` (n, 3) [m] (module docstring).

    ``axis``: the capsule's direction (3,) in the vertices' frame instead of the principal axis (step 1), for a
    link whose vertices are not spread along its length: PCA weights vertices by count, so a finely tessellated
    servo horn across a link turns the axis across the link too (the hexapod's femur: a capsule of radius 42.6
    mm along the horn around a 40 × 32 mm servo box; along the link 26.9 mm).

    Raises :class:`InvalidInputError` for an empty or non-finite vertex array, vertices beyond ±1e100 m, or a
    zero or non-finite ``axis``.
    """
    V = _points(vertices, "vertices")
    if len(V) == 0:
        raise InvalidInputError("fit_capsule needs at least one vertex: vertices is empty")
    if float(np.max(np.abs(V))) > _MAX_VERTEX:
        raise InvalidInputError(
            f"vertices reach {float(np.max(np.abs(V))):.3g} m, beyond ±{_MAX_VERTEX:g} m (their covariance would "
            "overflow); express the mesh in a unit nearer to its size"
        )
    mean = V.mean(axis=0)
    X = V - mean
    if axis is None:
        _, E = np.linalg.eigh(X.T @ X)
        u, e1, e2 = E[:, 2], E[:, 1], E[:, 0]
    else:
        u, e1, e2 = _frame_along(axis)
    tau = X @ u
    perp = np.stack([X @ e1, X @ e2], axis=1)
    best: tuple[float, np.ndarray] | None = None
    for c2 in (np.zeros(2), 0.5 * (perp.min(axis=0) + perp.max(axis=0))):
        rho = np.linalg.norm(perp - c2, axis=1)
        R = float(rho.max())
        if best is None or R < best[0]:
            best = (R, c2)
    assert best is not None
    R, c2 = best
    rho = np.linalg.norm(perp - c2, axis=1)
    h = np.sqrt(np.maximum(R * R - rho * rho, 0.0))
    t0, t1 = float(np.min(tau + h)), float(np.max(tau - h))
    if t0 > t1:
        t0 = t1 = 0.5 * (t0 + t1)
    origin = mean + c2[0] * e1 + c2[1] * e2
    a, b = origin + t0 * u, origin + t1 * u
    # exact enclosure radius of the final segment (≤ R up to round-off)
    d = b - a
    L2 = float(d @ d)
    t = np.zeros(len(V)) if L2 <= 1e-24 else np.clip((V - a) @ d / L2, 0.0, 1.0)
    R = max(R, float(np.linalg.norm(V - (a + t[:, None] * d), axis=1).max()))
    return a, b, R + _PAD


def _frame_along(axis: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u, e1, e2): the unit vector of ``axis`` (3,) and two unit vectors completing an orthonormal frame."""
    w = validation.vector(axis, 3, "axis (the capsule's direction)")
    n = float(np.linalg.norm(w))
    if not n > 1e-12:
        raise InvalidInputError(f"axis must be a nonzero direction (3,), got {w.tolist()}")
    u = w / n
    e1 = np.cross(u, np.eye(3)[int(np.argmin(np.abs(u)))])
    e1 /= np.linalg.norm(e1)
    return u, e1, np.cross(u, e1)


# ====================================================================== link meshes
_GEOM_CACHE: dict[tuple[str, tuple[str, ...], str], tuple[Any, Any]] = {}


def _source_geometry(src: Any, kind: str) -> tuple[Any, Any]:
    """(pin.Model, pin.GeometryModel of ``kind`` "collision"/"visual") of a VisualSource with a URDF,
    read once per process."""
    import pinocchio as pin

    key = (str(src.urdf), tuple(src.package_dirs), kind)
    if key not in _GEOM_CACHE:
        model = pin.buildModelFromUrdf(str(src.urdf))
        gtype = pin.GeometryType.COLLISION if kind == "collision" else pin.GeometryType.VISUAL
        try:
            geom = pin.buildGeomFromUrdf(model, str(src.urdf), gtype, None, list(src.package_dirs))
        except (ValueError, RuntimeError) as e:
            raise InvalidInputError(f"{kind} geometry of {src.urdf} could not be loaded ({e})") from e
        _GEOM_CACHE[key] = (model, geom)
    return _GEOM_CACHE[key]


def link_meshes(system: Any, source: str = "collision") -> dict[str, np.ndarray]:
    """``{frame name: vertices (n, 3)}`` of every link of ``system`` that has geometry, the vertices
    in that frame's coordinates [m] (all geometry objects of one link merged).

    ``source="collision"`` reads each robot's URDF ``<collision>`` elements (a URDF without any, and
    a robot given by a ``GeometryModel`` instead of a URDF, fall back to the visual geometry);
    ``"visual"`` the ``<visual>`` elements, as :meth:`System.visual_model` does.  An object whose
    link is not a frame of ``system.model`` is skipped.
    """
    from ..systems.meshes import object_mesh

    check_system(system)
    validation.choice(source, ("collision", "visual"), "source")
    model = system.model
    out: dict[str, list[np.ndarray]] = {}

    def add(frame_name: str, ftype: Any, V_frame: np.ndarray) -> None:
        if not model.existFrame(frame_name, ftype):
            return
        out.setdefault(frame_name, []).append(V_frame)

    def obj_vertices(obj: Any, frame_placement: Any) -> np.ndarray | None:
        mesh = object_mesh(obj)
        if mesh is None or len(mesh.vertices) == 0:
            return None
        M = frame_placement.inverse() * obj.placement  # object frame → link frame
        return np.asarray(mesh.vertices, float) @ np.asarray(M.rotation).T + np.asarray(M.translation)

    for src in getattr(system, "visuals", ()):
        if src.urdf is None:
            smodel, sgeom = src.model, src.geometry
        else:
            smodel, sgeom = _source_geometry(src, source)
            if source == "collision" and len(sgeom.geometryObjects) == 0:
                smodel, sgeom = _source_geometry(src, "visual")  # a URDF without <collision>
        for obj in sgeom.geometryObjects:
            sframe = smodel.frames[obj.parentFrame]
            V = obj_vertices(obj, sframe.placement)
            if V is not None:
                add(src.prefix + sframe.name, sframe.type, V)
    if not getattr(system, "visuals", ()):
        raise InvalidInputError(
            f"system '{getattr(system, 'name', '?')}' has no visual/collision sources: pass capsules= explicitly"
        )
    return {k: np.vstack(v) for k, v in out.items()}


def _root_group(model: Any, fid: int) -> int:
    """The frame just below the universe on the frame path of ``fid`` (a world-fixed base's id)."""
    f = fid
    for _ in range(len(model.frames)):
        parent = int(model.frames[f].parentFrame)
        if f == 0 or parent == 0 or parent == f:
            return f
        f = parent
    return f  # pragma: no cover - frame trees are finite


def capsule_chain(system: Any, frame: str) -> int:
    """Index of the chain whose joints move ``frame`` — the only chain containing the frame's parent
    joint; for a body fixed to the world, the only chain whose first joint is mounted on that body
    (an arm's base link belongs to its arm).  −1 if no chain or several chains qualify (a shared
    torso, a base carrying several arms)."""
    model = check_system(system).model
    if not isinstance(frame, str):
        raise InvalidInputError(f"frame must be a frame name (str), got {type(frame).__name__} {frame!r}")
    if not model.existFrame(frame):
        raise UnknownNameError(f"unknown frame '{frame}' of system '{system.name}'")
    fid = model.getFrameId(frame)
    j = int(model.frames[fid].parentJoint)
    chains = system.tree.chains
    if j == 0:
        root = _root_group(model, fid)
        owners = set()
        for i, ch in enumerate(chains):
            if not ch:
                continue
            for f in model.frames:
                if int(f.parentJoint) == ch[0] and int(model.frames[int(f.parentFrame)].parentJoint) == 0:
                    if _root_group(model, int(f.parentFrame)) == root:
                        owners.add(i)
                    break
        return owners.pop() if len(owners) == 1 else -1
    while j > 0:
        owners_j = [i for i, ch in enumerate(chains) if j in ch]
        if owners_j:
            return owners_j[0] if len(owners_j) == 1 else -1
        j = int(model.parents[j])  # a joint on no chain (a branch off it): its ancestors' chains
    return -1


def fit_capsules(system: Any, source: str = "collision", links: Iterable[str] | None = None) -> tuple[Capsule, ...]:
    """One bounding capsule per link mesh of ``system`` (:func:`link_meshes`, :func:`fit_capsule`).

    ``links``: frame names to keep (default: every link with geometry), in the model's frame order.
    Each capsule encloses every vertex of its link's meshes (PCA axis + extent, module docstring).
    Raises :class:`UnknownNameError` for a requested link without geometry.
    """
    if links is not None and (isinstance(links, str) or not isinstance(links, Iterable)):
        raise InvalidInputError(f"links must be a list of frame names (or None: every link), got {links!r}")
    meshes = link_meshes(system, source)
    model = system.model
    names = sorted(meshes, key=lambda n: model.getFrameId(n))
    if links is not None:
        wanted: Sequence[str] = list(links)
        if not all(isinstance(n, str) for n in wanted):
            raise InvalidInputError(f"links must be frame names (str), got {wanted!r}")
        missing = [n for n in wanted if n not in meshes]
        if missing:
            raise UnknownNameError(
                f"no {source} geometry for link(s) {missing} of system '{system.name}'; links with geometry: {names}"
            )
        names = [n for n in names if n in set(wanted)]
    out = []
    for n in names:
        a, b, r = fit_capsule(meshes[n])
        out.append(Capsule(frame=n, a=a, b=b, radius=r, chain=capsule_chain(system, n), link=n))
    return tuple(out)
