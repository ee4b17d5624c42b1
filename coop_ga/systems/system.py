"""Multi-chain robot systems: Pinocchio models plus the frames whose points span a primitive.

A :class:`System` bundles

* ``model`` — a fixed-base ``pinocchio.Model`` with revolute/prismatic joints only
  (robots combined with ``pinocchio.appendModel``, locked joints removed with
  ``pinocchio.buildReducedModel``);
* ``end_frames`` — frame names, one per chain, in the order the cooperative layer uses;
* ``q0``, ``q_lower``, ``q_upper``, ``joint_names`` — a nominal configuration and limits;
* ``tree`` — the :class:`~coop_ga.kinematics.chains.KinematicTree` (motor FK, Jacobians);
* ``visuals`` — where each robot's visual geometry comes from (:class:`VisualSource`: a URDF
  and its package folders, or a ``pinocchio.GeometryModel``, plus the frame-name prefix the
  robot got in the combined model); :meth:`System.visual_model` builds the visual
  ``pinocchio.GeometryModel`` that matches ``model`` (for :mod:`coop_ga.viz`).

Systems are registered by name in :mod:`coop_ga.systems.registry`; ``load(name)`` builds
(and caches) one.  Any URDF that Pinocchio loads becomes a system with :func:`from_urdf`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..diagnostics import warn
from ..errors import InvalidInputError, JointLimitWarning, UnknownNameError
from ..kinematics.chains import KinematicTree
from .limits import JointLimits

__all__ = [
    "ROBOTS_DIR",
    "System",
    "VisualSource",
    "append_robots",
    "from_model",
    "from_urdf",
    "prefixed",
]

#: Directory of the URDFs coop_ga ships (iiwa14, hexapod): package data of ``coop_ga.systems``,
#: located with :mod:`importlib.resources`, so it exists in a wheel install as in a checkout.
ROBOTS_DIR = Path(str(resources.files("coop_ga.systems") / "robots"))


@dataclass(frozen=True)
class VisualSource:
    """Where the visual geometry of one robot of a :class:`System` comes from.

    Either ``urdf`` (its ``<visual>`` elements are read with ``pinocchio.buildGeomFromUrdf``,
    meshes loaded by coal/assimp; ``package_dirs`` resolve ``package://`` URIs) or ``geometry``,
    a ``pinocchio.GeometryModel`` built for ``model``.  ``prefix`` is the prefix that robot's
    frame names carry in the system's model (:func:`prefixed`; ``""`` for a single robot).

    The geometry is matched to the system's (reduced, appended, prefixed) model by frame
    name: an object attached to link ``L`` of the source is attached to frame ``prefix + L``
    of the system, at the same pose relative to that link (:meth:`System.visual_model`).
    """

    urdf: Path | None = None
    package_dirs: tuple[str, ...] = ()
    prefix: str = ""
    geometry: Any = field(default=None, compare=False, repr=False)
    model: Any = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if (self.urdf is None) == (self.geometry is None):
            raise InvalidInputError("a VisualSource needs exactly one of urdf= or geometry= (with model=)")
        if self.geometry is not None and self.model is None:
            raise InvalidInputError(
                "VisualSource(geometry=...) also needs model=, the pinocchio.Model it was built for"
            )
        if self.urdf is not None:
            object.__setattr__(self, "urdf", Path(self.urdf))
        object.__setattr__(self, "package_dirs", tuple(str(d) for d in self.package_dirs))


#: Source geometry models already read, keyed by (URDF path, package dirs): (pin.Model, pin.GeometryModel).
_SOURCE_CACHE: dict[tuple[str, tuple[str, ...]], tuple[Any, Any]] = {}
_MESH_LOADER: Any = None


def _mesh_loader() -> Any:
    """One coal ``CachedMeshLoader`` per process (a mesh file is read once), or None without coal."""
    global _MESH_LOADER
    if _MESH_LOADER is None:
        try:
            import importlib

            _MESH_LOADER = importlib.import_module("coal").CachedMeshLoader()
        except ImportError:  # pragma: no cover - coal ships with the pin wheels
            _MESH_LOADER = False
    return _MESH_LOADER or None


def _source_geometry(src: VisualSource) -> tuple[Any, Any]:
    """(pin.Model, visual pin.GeometryModel) of a source, read once per process for a URDF."""
    import pinocchio as pin

    if src.geometry is not None:
        return src.model, src.geometry
    assert src.urdf is not None
    key = (str(src.urdf), src.package_dirs)
    if key not in _SOURCE_CACHE:
        if not src.urdf.exists():
            raise InvalidInputError(f"visual geometry: URDF file not found: {src.urdf}")
        model = pin.buildModelFromUrdf(str(src.urdf))
        try:
            geom = pin.buildGeomFromUrdf(
                model, str(src.urdf), pin.GeometryType.VISUAL, None, list(src.package_dirs), _mesh_loader()
            )
        except (ValueError, RuntimeError) as e:
            raise InvalidInputError(
                f"visual geometry of {src.urdf} could not be loaded ({e}); pass the folders that resolve its "
                "package:// URIs as package_dirs"
            ) from e
        _SOURCE_CACHE[key] = (model, geom)
    return _SOURCE_CACHE[key]


def _matched_geometry(model: Any, sources: Sequence[VisualSource]) -> tuple[Any, list[str]]:
    """The visual ``pin.GeometryModel`` of ``sources`` re-attached to ``model`` by frame name,
    and the names of the objects whose link is not a frame of ``model`` (skipped)."""
    import pinocchio as pin

    out = pin.GeometryModel()
    skipped: list[str] = []
    for src in sources:
        smodel, sgeom = _source_geometry(src)
        for obj in sgeom.geometryObjects:
            sframe = smodel.frames[obj.parentFrame]
            name = src.prefix + sframe.name
            if not model.existFrame(name, sframe.type):
                skipped.append(src.prefix + obj.name)
                continue
            fid = model.getFrameId(name, sframe.type)
            frame = model.frames[fid]
            new = obj.copy()
            new.name = src.prefix + obj.name
            new.parentJoint = frame.parentJoint
            new.parentFrame = fid
            # the object's pose in its link frame is kept; the link's pose in its (new) joint is the system's
            new.placement = frame.placement * sframe.placement.inverse() * obj.placement
            out.addGeometryObject(new)
    return out, skipped


@dataclass
class System:
    """A fixed-base multi-chain robot system (see module docstring)."""

    name: str
    model: Any
    end_frames: tuple[str, ...]
    q0: np.ndarray
    description: str = ""
    #: optional per-end-frame chain labels (e.g. "left wrist")
    labels: tuple[str, ...] = ()
    #: joint limits (default: read from the model, see :mod:`coop_ga.systems.limits`)
    limits: JointLimits | None = field(default=None, repr=False)
    #: where the robots' visual geometry comes from (:class:`VisualSource`; empty: none known)
    visuals: tuple[VisualSource, ...] = field(default=(), repr=False)
    tree: KinematicTree = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.end_frames = validation.frames(self.end_frames, [f.name for f in self.model.frames], "end_frames")
        self.tree = KinematicTree(self.model, self.end_frames)
        if self.limits is None:
            self.limits = JointLimits.from_model(self.model, self.joint_names)
        elif not isinstance(self.limits, JointLimits) or self.limits.joint_names != tuple(self.joint_names):
            raise InvalidInputError(f"limits of system '{self.name}' must be JointLimits for joints {self.joint_names}")
        self.q0 = np.array(self.q0, dtype=float)
        self.q0.setflags(write=False)
        if self.q0.shape != (self.model.nq,):
            raise InvalidInputError(
                f"q0 of system '{self.name}' must have {self.model.nq} entries, got {self.q0.shape}"
            )
        if not self.labels:
            self.labels = self.end_frames
        self.visuals = tuple(self.visuals)
        if not all(isinstance(v, VisualSource) for v in self.visuals):
            raise InvalidInputError(f"visuals of system '{self.name}' must be VisualSource objects")
        self._data = None
        self._visual: Any = None

    # ------------------------------------------------------------------ description
    @property
    def nq(self) -> int:
        """Number of joint coordinates (= DOF; revolute [rad] and prismatic [m])."""
        return int(self.model.nq)

    @property
    def n_chains(self) -> int:
        return len(self.end_frames)

    @property
    def joint_names(self) -> list[str]:
        """Joint names in q order (Pinocchio's order)."""
        m = self.model
        order = sorted(range(1, m.njoints), key=lambda j: m.idx_qs[j])
        return [m.names[j] for j in order if m.nqs[j] > 0]

    @property
    def q_lower(self) -> np.ndarray:
        """Lower position limits (nq,) [rad or m] (``limits.lower``; a copy)."""
        assert self.limits is not None
        return self.limits.lower.copy()

    @property
    def q_upper(self) -> np.ndarray:
        """Upper position limits (nq,) [rad or m] (``limits.upper``; a copy)."""
        assert self.limits is not None
        return self.limits.upper.copy()

    def with_limits(
        self,
        *,
        position: Any = None,
        velocity: Any = None,
        acceleration: Any = None,
        effort: Any = None,
        name: str | None = None,
    ) -> System:
        """A copy of this system with limits overridden by joint name (:meth:`JointLimits.replace`).

        ``position``: ``{joint: (lower, upper)}``; ``velocity``, ``acceleration``, ``effort``:
        ``{joint: value}`` or one value for every joint.  The model is shared (it is not
        modified); every controller reads the limits from :attr:`limits`.
        """
        assert self.limits is not None
        new = self.limits.replace(position=position, velocity=velocity, acceleration=acceleration, effort=effort)
        out = dataclasses.replace(self, name=name or self.name, limits=new)
        out._visual = self._visual  # same model, same visual geometry
        return out

    @property
    def data(self) -> Any:
        """A ``pinocchio.Data`` for this model (created once)."""
        if self._data is None:
            self._data = self.model.createData()
        return self._data

    def visual_model(self) -> Any:
        """The visual ``pinocchio.GeometryModel`` of this system, matched to :attr:`model`, or None.

        Built once per system from :attr:`visuals` (each source's URDF is read once per
        process, meshes by coal/assimp): every visual object of a source's link ``L`` is
        attached to the frame ``prefix + L`` of :attr:`model` — the frames survive
        ``buildReducedModel`` (locked links ride on their parent joint) and ``appendModel``
        (root links carry the base placement) — at the pose it has in that link's frame.
        Objects whose link is missing from the model are skipped (``visual_skipped``).
        Place it with ``pinocchio.updateGeometryPlacements(model, data, geom, geom_data, q)``;
        the world pose of object i is then ``geom_data.oMg[i]`` (rotation, translation [m]).

        Returns None when the system has no visual sources (e.g. :func:`from_model` without
        ``visual_model=``).  Raises :class:`InvalidInputError` if a URDF or mesh cannot be read.
        """
        if not self.visuals:
            return None
        if self._visual is None:
            self._visual = _matched_geometry(self.model, self.visuals)
        return self._visual[0]

    @property
    def visual_skipped(self) -> list[str]:
        """Names of visual objects not attached because their link is not a frame of the model."""
        return [] if self._visual is None else list(self._visual[1])

    def _joint_ids_in_q(self) -> list[int]:
        m = self.model
        return sorted((j for j in range(1, m.njoints) if m.nqs[j] > 0), key=lambda j: m.idx_qs[j])

    def chain_joints(self) -> list[list[str]]:
        """Names of the joints on each chain, root to tip."""
        return [[self.tree.joints[j].name for j in ch] for ch in self.tree.chains]

    # ------------------------------------------------------------------ input checks
    def check_q(self, q: Any, *, warn_limits: bool = True) -> np.ndarray:
        """Validate a configuration; returns a float copy.

        Raises :class:`InvalidInputError` for a wrong size and :class:`NonFiniteError`
        for NaN/inf.  Joint-limit violations emit a :class:`JointLimitWarning` naming the
        joints; q is never clipped.
        """
        a = validation.configuration(q, self.nq, owner=f"system '{self.name}'", joint_names=self.joint_names)
        if warn_limits and self.limits is not None:
            desc = self.limits.describe(a, tol=1e-12)
            if desc:
                warn(f"system '{self.name}': joint limits exceeded: {desc}", JointLimitWarning, key=self.name)
        return a

    def random_q(self, rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
        """Uniform random q inside the limits (``scale < 1`` shrinks the box around its middle).

        Joints without finite limits (models built in code get ±1.8e308) are sampled in
        [−π, π] (revolute) or [−1, 1] m (prismatic).
        """
        lo, hi = self.q_lower.copy(), self.q_upper.copy()
        unbounded = (hi - lo > 1e6) | ~np.isfinite(hi - lo)
        if np.any(unbounded):
            span = np.array(
                [
                    1.0 if self.model.joints[j].shortname().startswith("JointModelP") else np.pi
                    for j in self._joint_ids_in_q()
                ]
            )
            lo[unbounded], hi[unbounded] = -span[unbounded], span[unbounded]
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo) * scale
        return rng.uniform(mid - half, mid + half)

    # ------------------------------------------------------------------ kinematics
    def end_points(self, q: Any) -> np.ndarray:
        """End points [m] in the world frame, shape (k, 3), computed with motors."""
        return self.tree.end_points_array(self.check_q(q))

    def frame_motors(self, q: Any) -> list:
        """World motors of the end frames (equal to Pinocchio's ``oMf``)."""
        return self.tree.frame_motors(self.check_q(q))

    def __repr__(self) -> str:
        return f"System({self.name!r}, nq={self.nq}, end_frames={list(self.end_frames)})"


# ====================================================================== model tools
def prefixed(model: Any, prefix: str) -> Any:
    """A copy of ``model`` whose joint and frame names start with ``prefix``.

    ``pinocchio.appendModel`` refuses duplicate frame names, so copies of the same robot
    are renamed before appending.
    """
    import pinocchio as pin

    m = pin.Model(model)
    for i in range(1, m.njoints):
        m.names[i] = prefix + m.names[i]
    for i in range(len(m.frames)):
        f = m.frames[i]
        if f.name != "universe":
            f.name = prefix + f.name
            m.frames[i] = f
    return m


def append_robots(parts: Sequence[tuple[Any, Any]]) -> Any:
    """Combine ``(model, world_placement_SE3)`` pairs into one model with ``pinocchio.appendModel``.

    Each model is attached to the universe frame at its placement.  Rename copies of
    the same robot first with :func:`prefixed`.
    """
    import pinocchio as pin

    combined = pin.Model()
    for m, placement in parts:
        combined = pin.appendModel(combined, m, 0, placement)
    return combined


def _default_q0(model: Any) -> np.ndarray:
    """Neutral configuration, moved to mid-range for joints whose limits exclude it."""
    import pinocchio as pin

    q = np.array(pin.neutral(model), dtype=float)
    lo, hi = np.array(model.lowerPositionLimit), np.array(model.upperPositionLimit)
    bad = (q < lo) | (q > hi)
    q[bad] = 0.5 * (lo[bad] + hi[bad])
    return q


def from_model(
    model: Any,
    end_frames: Sequence[str],
    *,
    name: str = "custom",
    q0: Any = None,
    locked_joints: Sequence[str] = (),
    q_lock: Any = None,
    description: str = "",
    visual_model: Any = None,
    visuals: Sequence[VisualSource] = (),
) -> System:
    """Build a :class:`System` from a ``pinocchio.Model``.

    ``locked_joints`` (names) are removed with ``pinocchio.buildReducedModel`` at
    ``q_lock`` (default: the neutral configuration).  ``q0`` defaults to the neutral
    configuration, moved to mid-range where the limits exclude it.

    ``visual_model``: a visual ``pinocchio.GeometryModel`` built for ``model`` (before
    locking), so that :mod:`coop_ga.viz` draws the robot's meshes; or ``visuals``, the
    :class:`VisualSource` list of a combined model (one per robot, with its prefix).
    Without either the robot is drawn as a skeleton.
    """
    import pinocchio as pin

    sources = tuple(visuals)
    if visual_model is not None:
        sources += (VisualSource(geometry=visual_model, model=pin.Model(model)),)
    if locked_joints:
        known = set(model.names)
        missing = [j for j in locked_joints if j not in known]
        if missing:
            raise UnknownNameError(
                f"unknown joint(s) to lock: {missing}. Joints of the model: {', '.join(list(model.names)[1:])}"
            )
        ql = pin.neutral(model) if q_lock is None else np.asarray(q_lock, dtype=float)
        model = pin.buildReducedModel(model, [model.getJointId(j) for j in locked_joints], ql)
    if q0 is None:
        q0 = _default_q0(model)
    return System(
        name=name,
        model=model,
        end_frames=tuple(end_frames),
        q0=np.asarray(q0, dtype=float),
        description=description,
        visuals=sources,
    )


def _default_package_dirs(urdf: Path) -> tuple[str, ...]:
    """Folders that resolve ``package://NAME/...`` for a URDF inside its package: its parents."""
    p = urdf.resolve().parent
    return tuple(str(d) for d in [p, *list(p.parents)[:3]])


def from_urdf(
    urdf_path: str | Path,
    end_frames: Sequence[str],
    locked_joints: Sequence[str] = (),
    *,
    name: str | None = None,
    q0: Any = None,
    q_lock: Any = None,
    package_dirs: Sequence[str | Path] | None = None,
) -> System:
    """Build a system from any URDF Pinocchio loads (fixed base).

    ``package_dirs``: folders that resolve the ``package://`` mesh URIs of its ``<visual>``
    elements (default: the URDF's folder and three of its parents); the visual geometry is
    read only when the system is drawn (:meth:`System.visual_model`).

    Example::

        sys = coop_ga.systems.from_urdf("my_robot.urdf", ["left_tip", "right_tip", "thumb_tip"],
                                        locked_joints=["gripper_joint"])
        task = coop_ga.cooperative_task(sys, "circle")
    """
    import pinocchio as pin

    p = Path(urdf_path)
    if not p.exists():
        raise InvalidInputError(f"URDF file not found: {p}")
    model = pin.buildModelFromUrdf(str(p))
    dirs = _default_package_dirs(p) if package_dirs is None else tuple(str(d) for d in package_dirs)
    return from_model(
        model,
        end_frames,
        name=name or p.stem,
        q0=q0,
        locked_joints=locked_joints,
        q_lock=q_lock,
        description=f"from URDF {p}",
        visuals=(VisualSource(urdf=p.resolve(), package_dirs=dirs),),
    )
