"""Multi-chain robot systems: Pinocchio models plus the frames whose points span a primitive.

A :class:`System` bundles

* ``model`` — a ``pinocchio.Model`` with revolute/prismatic joints (robots combined with
  ``pinocchio.appendModel``, locked joints removed with ``pinocchio.buildReducedModel``), fixed-base
  or with a free-flyer root (a floating base: ``from_urdf(..., free_flyer=True)``);
* ``end_frames`` — frame names, one per chain, in the order the cooperative layer uses;
* ``q0``, ``q_lower``, ``q_upper``, ``joint_names`` — a nominal configuration and limits;
* ``tree`` — the :class:`~coop_ga.kinematics.chains.KinematicTree` (motor FK, Jacobians);
* ``visuals`` — where each robot's visual geometry comes from (:class:`VisualSource`: a URDF
  and its package folders, or a ``pinocchio.GeometryModel``, plus the frame-name prefix the
  robot got in the combined model); :meth:`System.visual_model` builds the visual
  ``pinocchio.GeometryModel`` that matches ``model`` (for :mod:`coop_ga.viz`).

Systems are registered by name in :mod:`coop_ga.systems.registry`; ``load(name)`` builds
(and caches) one.  Any URDF that Pinocchio loads becomes a system with :func:`from_urdf`.

Free flyers (nq ≠ nv)
---------------------
A free-flyer root has 7 coordinates in q (position [m], unit quaternion x y z w) and 6 velocities
(Pinocchio's LOCAL ``[v; ω]``), so ``nq = nv + 1``.  Everything that moves q does it through
:meth:`System.integrate` (``pinocchio.integrate``; ``q + v`` when nq = nv) and compares two
configurations through :meth:`System.difference`; velocities, Jacobian columns and the arrays of
:attr:`System.limits` have nv entries, in q̇ order.  The free flyer has no position limits; the
bounded coordinates of q, in q̇ order, are :meth:`System.limit_coordinates`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..diagnostics import warn
from ..errors import InvalidInputError, JointLimitWarning, UnknownNameError
from ..kinematics.chains import KinematicTree, require_nq_equals_nv
from .groups import locked_joints as _group_locked
from .joints import continuous_as_revolute
from .limits import JointLimits
from .points import EndPoint, add_end_points, end_frame_names

__all__ = [
    "ROBOTS_DIR",
    "System",
    "VisualSource",
    "append_robots",
    "from_model",
    "from_urdf",
    "prefixed",
    "unique_frames",
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
        import pinocchio as pin

        if (self.urdf is None) == (self.geometry is None):
            raise InvalidInputError("a VisualSource needs exactly one of urdf= or geometry= (with model=)")
        if self.geometry is not None:
            if not isinstance(self.geometry, pin.GeometryModel):
                raise InvalidInputError(
                    f"VisualSource geometry must be a pinocchio.GeometryModel, got {type(self.geometry).__name__}"
                )
            if not isinstance(self.model, pin.Model):
                raise InvalidInputError(
                    "VisualSource(geometry=...) also needs model=, the pinocchio.Model it was built for"
                )
        if self.urdf is not None:
            object.__setattr__(self, "urdf", _path(self.urdf, "VisualSource urdf"))
        object.__setattr__(self, "package_dirs", _dirs(self.package_dirs, "VisualSource package_dirs"))
        if not isinstance(self.prefix, str):
            raise InvalidInputError(f"VisualSource prefix must be a string, got {self.prefix!r}")


def _path(x: Any, what: str) -> Path:
    if not isinstance(x, (str, Path)):
        raise InvalidInputError(f"{what} must be a path (str or pathlib.Path), got {type(x).__name__} {x!r}")
    return Path(x)


def _dirs(x: Any, what: str) -> tuple[str, ...]:
    if isinstance(x, (str, Path)) or not isinstance(x, Sequence):
        raise InvalidInputError(f"{what} must be a list of folders (str or Path), got {x!r}")
    return tuple(str(_path(d, f"{what}[{i}]")) for i, d in enumerate(x))


def _names(x: Any, what: str) -> tuple[str, ...]:
    """A sequence of names (str) — not a single string, whose letters would be taken for names."""
    if isinstance(x, str) or not isinstance(x, Sequence) or not all(isinstance(v, str) for v in x):
        raise InvalidInputError(f"{what} must be a list of names (str), got {x!r}")
    return tuple(x)


def _pin_model(x: Any, what: str = "model") -> Any:
    import pinocchio as pin

    if not isinstance(x, pin.Model):
        raise InvalidInputError(f"{what} must be a pinocchio.Model, got {type(x).__name__}")
    return x


def read_urdf(path: Any, what: str = "urdf_path", *, free_flyer: bool = False) -> Any:
    """``pinocchio.buildModelFromUrdf(path)`` (fixed base; with ``free_flyer``, a ``JointModelFreeFlyer`` root),
    with a :class:`InvalidInputError` naming ``what`` for a missing file, a folder, or a file Pinocchio cannot
    parse as URDF."""
    import pinocchio as pin

    p = _path(path, what)
    if not isinstance(free_flyer, (bool, np.bool_)):
        raise InvalidInputError(f"free_flyer must be True or False, got {free_flyer!r}")
    if not p.is_file():
        raise InvalidInputError(f"{what}: URDF file not found: {p}" + (" (a folder)" if p.is_dir() else ""))
    try:
        if free_flyer:
            return pin.buildModelFromUrdf(str(p), pin.JointModelFreeFlyer())
        return pin.buildModelFromUrdf(str(p))
    except (ValueError, RuntimeError) as e:
        raise InvalidInputError(f"{what}: {p} is not a URDF Pinocchio can read ({e})") from None


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
        model = read_urdf(src.urdf, "visuals: the visual geometry's URDF")
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
        if not isinstance(self.name, str) or not self.name:
            raise InvalidInputError(f"a system's name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.description, str):
            raise InvalidInputError(f"description of system '{self.name}' must be a string, got {self.description!r}")
        _pin_model(self.model, f"model of system '{self.name}'")
        self.end_frames = validation.frames(self.end_frames, [f.name for f in self.model.frames], "end_frames")
        self.tree = KinematicTree(self.model, self.end_frames)
        if self.limits is None:
            self.limits = JointLimits.from_model(self.model, self.joint_names)
        elif not isinstance(self.limits, JointLimits) or self.limits.joint_names != tuple(self.joint_names):
            raise InvalidInputError(f"limits of system '{self.name}' must be JointLimits for joints {self.joint_names}")
        self.q0 = validation.configuration(
            self.q0, self.model.nq, "q0", owner=f"system '{self.name}'", joint_names=self.joint_names
        )
        self.check_quaternions(self.q0, "q0")
        outside = self.limits.describe(self.limit_coordinates(self.q0), tol=0.0)
        if outside:
            raise InvalidInputError(
                f"q0 of system '{self.name}' is outside the joint limits: {outside}; pass a q0 inside them "
                "(or widen the limits with System.with_limits)"
            )
        self.q0.setflags(write=False)
        if not self.labels:
            self.labels = self.end_frames
        self.labels = tuple(self.labels) if isinstance(self.labels, (list, tuple)) else self.labels
        if (
            not isinstance(self.labels, tuple)
            or len(self.labels) != len(self.end_frames)
            or not all(isinstance(x, str) for x in self.labels)
        ):
            raise InvalidInputError(
                f"labels of system '{self.name}' must be {len(self.end_frames)} strings (one per end frame), "
                f"got {self.labels!r}"
            )
        if isinstance(self.visuals, (str, VisualSource)) or not isinstance(self.visuals, Sequence):
            raise InvalidInputError(
                f"visuals of system '{self.name}' must be a list of VisualSource, got {self.visuals!r}"
            )
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
    def nv(self) -> int:
        """Number of velocities (= DOF): nq, or nq − 1 with a free flyer (module docstring)."""
        return int(self.model.nv)

    def integrate(self, q: Any, v: Any) -> np.ndarray:
        """The configuration reached from q (nq,) by the velocity v (nv,) applied for 1 s: ``q + v`` when
        nq = nv, else ``pinocchio.integrate`` (a free flyer's v is its LOCAL [v; ω]; the quaternion stays unit)."""
        if self.model.nq == self.model.nv:
            return np.asarray(q, dtype=float) + v
        import pinocchio as pin

        return np.asarray(pin.integrate(self.model, np.asarray(q, dtype=float), np.asarray(v, dtype=float)))

    def difference(self, q0: Any, q1: Any) -> np.ndarray:
        """The velocity (nv,) that moves q0 to q1 in 1 s (:meth:`integrate`'s inverse): ``q1 − q0`` when
        nq = nv, else ``pinocchio.difference``."""
        if self.model.nq == self.model.nv:
            return np.asarray(q1, dtype=float) - np.asarray(q0, dtype=float)
        import pinocchio as pin

        return np.asarray(pin.difference(self.model, np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)))

    def neutral(self) -> np.ndarray:
        """Pinocchio's neutral configuration (nq,): joints at 0, a free flyer at the origin, unrotated."""
        import pinocchio as pin

        return np.array(pin.neutral(self.model), dtype=float)

    def limit_coordinates(self, q: Any) -> np.ndarray:
        """The coordinates of q (nq,) or (T, nq) that :attr:`limits` bound, in q̇ order: (nv,) or (T, nv).

        q itself when nq = nv; otherwise each 1-DOF joint's coordinate at its velocity index and 0 for a
        free flyer's six entries (they have no position bound)."""
        a = np.asarray(q, dtype=float)
        if self.model.nq == self.model.nv:
            return a
        idx = self.limit_index
        out = np.zeros(a.shape[:-1] + (self.nv,))
        out[..., idx >= 0] = a[..., idx[idx >= 0]]
        return out

    def distance(self, q0: Any, q1: Any) -> float:
        """The length ‖difference(q0, q1)‖ of the tangent step from q0 to q1 (nq,) [a mixed norm: rad and m of
        the joints, and a free flyer's LOCAL translation [m] and rotation angle [rad]]: ``‖q1 − q0‖`` when
        nq = nv.  Unlike ``‖q1 − q0‖`` it does not add metres to quaternion units, and it is the same for q and
        the equivalent quaternion −q."""
        return float(np.linalg.norm(self.difference(q0, q1)))

    def require_nq_equals_nv(self, what: str, instead: str) -> None:
        """Raise :class:`UnsupportedJointError` when this system has nq ≠ nv (a free flyer) naming ``what`` (a
        controller or function that assumes one coordinate per velocity) and ``instead`` (what works)."""
        require_nq_equals_nv(self.model, what, instead, f"system '{self.name}'")

    def clip(self, q: Any, out: np.ndarray | None = None) -> np.ndarray:
        """q (nq,) with its bounded coordinates clipped into the position limits (``out``: write there, may be q).

        ``numpy.clip(q, lower, upper)`` when nq = nv; a free flyer's coordinates are left as they are."""
        assert self.limits is not None
        if self.model.nq == self.model.nv:
            return np.clip(q, self.limits.lower, self.limits.upper, out=out)
        a = np.array(q, dtype=float) if out is None else out
        if out is not None and out is not q:
            a[...] = q
        idx = self.limit_index
        on = idx >= 0
        a[idx[on]] = np.clip(a[idx[on]], self.limits.lower[on], self.limits.upper[on])
        return a

    def tangent_trajectory(self, traj: Any) -> np.ndarray:
        """A trajectory (T, nq) in q̇ coordinates (T, nv), for limits on speeds and accelerations by finite
        differences: the trajectory itself when nq = nv; otherwise each 1-DOF joint's coordinate and, for a free
        flyer, the sum of :meth:`difference` along the trajectory from 0 (so that a row difference is the step's
        displacement; its position has no bound)."""
        a = np.asarray(traj, dtype=float)
        if self.model.nq == self.model.nv:
            return a
        out = self.limit_coordinates(a)
        free = self.limit_index < 0
        if len(a) > 1:
            steps = np.array([self.difference(a[k], a[k + 1]) for k in range(len(a) - 1)])
            out[1:, free] = np.cumsum(steps[:, free], axis=0)
        return out

    @property
    def limit_index(self) -> np.ndarray:
        """(nv,) int: for each velocity (q̇ order), the index in q of its 1-DOF joint's coordinate, or −1 for a free
        flyer's six velocities (they have no position bound; :meth:`limit_coordinates`)."""
        m = self.model
        idx = np.full(m.nv, -1)
        for j in range(1, m.njoints):
            if m.nqs[j] == 1 and m.nvs[j] == 1:
                idx[m.idx_vs[j]] = m.idx_qs[j]
        return idx

    def check_quaternions(self, q: np.ndarray, what: str) -> None:
        """Raise :class:`InvalidInputError` naming ``what`` (e.g. ``"q_init"``) if a free flyer's quaternion
        (x y z w) in the configuration q (nq,) is not unit within
        :data:`~coop_ga.kinematics.chains.QUATERNION_TOLERANCE`; nothing to check without a free flyer."""
        from ..kinematics.chains import QUATERNION_TOLERANCE

        m = self.model
        for j in range(1, m.njoints):
            if m.joints[j].shortname() == "JointModelFreeFlyer":
                n = float(np.linalg.norm(q[m.idx_qs[j] + 3 : m.idx_qs[j] + 7]))
                if not abs(n - 1.0) <= QUATERNION_TOLERANCE:
                    raise InvalidInputError(
                        f"{what} of system '{self.name}': the quaternion (x y z w) of free flyer '{m.names[j]}' "
                        f"(q[{m.idx_qs[j] + 3}:{m.idx_qs[j] + 7}]) has norm {n:.9g}, not 1; normalise it "
                        "(pinocchio.normalize(model, q)) or move q with System.integrate"
                    )

    @property
    def n_chains(self) -> int:
        return len(self.end_frames)

    @property
    def joint_names(self) -> list[str]:
        """Joint names in q order (Pinocchio's order); when nq ≠ nv one name per velocity, in q̇ order, a free
        flyer ``root`` giving ``root:vx``, ``root:vy``, ``root:vz``, ``root:wx``, ``root:wy``, ``root:wz``."""
        m = self.model
        order = sorted(range(1, m.njoints), key=lambda j: m.idx_qs[j])
        if m.nq == m.nv:
            return [m.names[j] for j in order if m.nqs[j] > 0]
        out: list[str] = []
        for j in order:
            if m.nvs[j] == 1:
                out.append(m.names[j])
            elif m.nvs[j] > 1:
                out += [f"{m.names[j]}:{c}" for c in ("vx", "vy", "vz", "wx", "wy", "wz")[: m.nvs[j]]]
        return out

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
        if name is not None and (not isinstance(name, str) or not name):
            raise InvalidInputError(f"name must be a non-empty string (or None: this system's), got {name!r}")
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
        if not isinstance(warn_limits, (bool, np.bool_)):
            raise InvalidInputError(f"warn_limits must be True or False, got {warn_limits!r}")
        if self.model.nq != self.model.nv:
            self.check_quaternions(a, "q")
        if warn_limits and self.limits is not None:
            desc = self.limits.describe(self.limit_coordinates(a), tol=1e-12)
            if desc:
                warn(f"system '{self.name}': joint limits exceeded: {desc}", JointLimitWarning, key=self.name)
        return a

    def random_q(self, rng: np.random.Generator, scale: float = 1.0) -> np.ndarray:
        """Uniform random q inside the limits (``scale < 1`` shrinks the box around its middle).

        Joints without finite limits (models built in code get ±1.8e308) are sampled in
        [−π, π] (revolute) or [−1, 1] m (prismatic); a free flyer's position in [−1, 1] m and its
        rotation as a rotation vector in [−π, π]³ (applied to the neutral pose by :meth:`integrate`).  ``rng``: a ``numpy.random.Generator``; ``scale`` ∈ [0, 1].
        """
        if not isinstance(rng, np.random.Generator):
            raise InvalidInputError(
                f"rng must be a numpy.random.Generator (numpy.random.default_rng(seed)), got {rng!r}"
            )
        scale = validation.scalar(scale, "scale", low=0.0, high=1.0)
        lo, hi = self.q_lower.copy(), self.q_upper.copy()
        unbounded = (hi - lo > 1e6) | ~np.isfinite(hi - lo)
        if np.any(unbounded):
            span = np.array(
                [
                    s
                    for j in self._joint_ids_in_q()
                    for s in (
                        (1.0, 1.0, 1.0, np.pi, np.pi, np.pi)
                        if self.model.joints[j].shortname() == "JointModelFreeFlyer"
                        else (1.0 if self.model.joints[j].shortname().startswith("JointModelP") else np.pi,)
                    )
                ]
            )
            lo[unbounded], hi[unbounded] = -span[unbounded], span[unbounded]
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo) * scale
        sample = rng.uniform(mid - half, mid + half)
        # with a free flyer the sample is a velocity from the neutral configuration (joints: their coordinate)
        return sample if self.nq == self.nv else self.integrate(self.neutral(), sample)

    # ------------------------------------------------------------------ kinematics
    def end_points(self, q: Any) -> np.ndarray:
        """End points [m] in the world frame, shape (k, 3), computed with motors."""
        return self.tree.end_points_array(self.check_q(q))

    def frame_motors(self, q: Any) -> list:
        """World motors of the end frames (equal to Pinocchio's ``oMf``)."""
        return self.tree.frame_motors(self.check_q(q))

    def with_end_frames(self, end_frames: Sequence[str | EndPoint], *, name: str | None = None) -> System:
        """A copy of this system with other end frames: frame names of :attr:`model` and :class:`EndPoint`
        entries (points anywhere on a link, added to a copy of the model as operational frames; paper §5.4).

        Same joints, q0, limits and visuals; labels are the new frame names.  Example (Fig. 9's chest point)::

            load("g1_arms").with_end_frames([EndPoint("torso_link", (0.15, 0, 0.2), name="chest_point"),
                                             "right_rubber_hand", "left_rubber_hand"])
        """
        if name is not None and (not isinstance(name, str) or not name):
            raise InvalidInputError(f"name must be a non-empty string (or None: this system's), got {name!r}")
        names = end_frame_names(end_frames)
        model = add_end_points(self.model, [e for e in end_frames if isinstance(e, EndPoint)])
        return dataclasses.replace(self, name=name or self.name, model=model, end_frames=names, labels=())

    def __repr__(self) -> str:
        return f"System({self.name!r}, nq={self.nq}, end_frames={list(self.end_frames)})"


# ====================================================================== model tools
def prefixed(model: Any, prefix: str) -> Any:
    """A copy of ``model`` whose joint and frame names start with ``prefix``.

    ``pinocchio.appendModel`` refuses duplicate frame names, so copies of the same robot
    are renamed before appending.
    """
    import pinocchio as pin

    _pin_model(model)
    if not isinstance(prefix, str):
        raise InvalidInputError(f"prefix must be a string (e.g. 'arm0_'), got {prefix!r}")
    m = pin.Model(model)
    for i in range(1, m.njoints):
        m.names[i] = prefix + m.names[i]
    for i in range(len(m.frames)):
        f = m.frames[i]
        if f.name != "universe":
            f.name = prefix + f.name
            m.frames[i] = f
    return m


def _repeated_frames(model: Any) -> dict[str, list[str]]:
    """``{name: [frame types]}`` of the frame names a model repeats (a URDF joint named like a link gives a
    FIXED_JOINT and a BODY frame of one name)."""
    types: dict[str, list[str]] = {}
    for f in model.frames:
        types.setdefault(f.name, []).append(str(f.type).rsplit(".", 1)[-1])
    return {n: t for n, t in types.items() if len(t) > 1}


def unique_frames(model: Any) -> Any:
    """A copy of ``model`` in which no two frames share a name: of frames sharing a name, the BODY frame (or
    else the first) keeps it, the others get their type appended (``"gripperStator"`` FIXED_JOINT →
    ``"gripperStator_fixed_joint"``).  ``pinocchio.appendModel`` (:func:`append_robots`) needs unique names."""
    import pinocchio as pin

    m = pin.Model(_pin_model(model))
    repeated = _repeated_frames(m)
    taken = {f.name for f in m.frames}
    for name in repeated:
        ids = [i for i in range(len(m.frames)) if m.frames[i].name == name]
        keep = next((i for i in ids if m.frames[i].type == pin.FrameType.BODY), ids[0])
        for i in ids:
            if i == keep:
                continue
            f = m.frames[i]
            new = f"{name}_{str(f.type).rsplit('.', 1)[-1].lower()}"
            k = 2
            while new in taken:
                new, k = f"{name}_{str(f.type).rsplit('.', 1)[-1].lower()}{k}", k + 1
            taken.add(new)
            f.name = new
            m.frames[i] = f
    return m


def append_robots(parts: Sequence[tuple[Any, Any]]) -> Any:
    """Combine ``(model, world_placement_SE3)`` pairs into one model with ``pinocchio.appendModel``.

    Each model is attached to the universe frame at its placement.  Joint and frame names must be
    unique across the parts (rename copies of the same robot first with :func:`prefixed`) and within each
    part (:func:`unique_frames` renames a model's repeated frame names, e.g. the Unitree Z1's).

    Raises :class:`~coop_ga.errors.InvalidInputError` for a malformed part and for a joint or frame name
    that two parts share or one part repeats (the message names it, the parts and the fix).
    """
    import pinocchio as pin

    if isinstance(parts, (str, tuple)) or not isinstance(parts, Sequence):
        raise InvalidInputError(f"parts must be a list of (pinocchio.Model, pinocchio.SE3) pairs, got {parts!r}")
    seen: dict[tuple[str, str], int] = {}  # ("joint" | "frame", name) → the part that has it
    combined = pin.Model()
    for k, part in enumerate(parts):
        if not isinstance(part, (tuple, list)) or len(part) != 2:
            raise InvalidInputError(f"parts[{k}] must be a (pinocchio.Model, pinocchio.SE3) pair, got {part!r}")
        m, placement = part
        _pin_model(m, f"parts[{k}]: the model")
        if not isinstance(placement, pin.SE3):
            raise InvalidInputError(
                f"parts[{k}]: the placement must be a pinocchio.SE3 (world ← robot base), got {type(placement).__name__}"
            )
        repeated = _repeated_frames(m)
        if repeated:
            name, types = next(iter(repeated.items()))
            raise InvalidInputError(
                f"parts[{k}]: the model has {len(types)} frames named '{name}' ({', '.join(types)})"
                + (f" and {len(repeated) - 1} more repeated name(s)" if len(repeated) > 1 else "")
                + "; pinocchio.appendModel cannot tell them apart: rename them first with "
                "coop_ga.systems.unique_frames(model)"
            )
        names = [("joint", n) for n in list(m.names)[1:]] + [
            ("frame", f.name) for f in m.frames if f.name != "universe"
        ]
        for kind, n in dict.fromkeys(names):
            if (kind, n) in seen:
                raise InvalidInputError(
                    f"parts[{seen[kind, n]}] and parts[{k}] both have a {kind} named '{n}': names must be unique in "
                    f"the combined model; rename the copies with prefixed(model, 'robot{k}_') before appending"
                )
            seen[kind, n] = k
        combined = pin.appendModel(combined, m, 0, placement)
    return combined


#: :func:`from_model`'s default q0 keeps a joint whose neutral value lies on a bound this fraction of its range inside
DEFAULT_Q0_MARGIN = 0.01


def _default_q0(model: Any, start: Any = None) -> np.ndarray:
    """The neutral configuration (or ``start``, (nq,)), strictly inside the limits: moved to mid-range for joints
    whose limits exclude it, and :data:`DEFAULT_Q0_MARGIN` of the range inside for joints whose value lies on a
    bound (a joint whose two bounds coincide stays on them)."""
    import pinocchio as pin

    q = np.array(pin.neutral(model) if start is None else start, dtype=float)
    lo, hi = np.array(model.lowerPositionLimit), np.array(model.upperPositionLimit)
    for j in range(1, model.njoints):  # a free flyer's coordinates have no bounds (Pinocchio stores ±1)
        if model.nqs[j] != 1 or model.nvs[j] != 1:
            lo[model.idx_qs[j] : model.idx_qs[j] + model.nqs[j]] = -np.inf
            hi[model.idx_qs[j] : model.idx_qs[j] + model.nqs[j]] = np.inf
    bad = (q < lo) | (q > hi)
    q[bad] = 0.5 * (lo[bad] + hi[bad])
    with np.errstate(over="ignore"):  # models built in code have limits ±1.8e308: no finite range
        span = hi - lo
    finite = np.isfinite(span) & (span > 0)
    low, high = finite & (q == lo), finite & (q == hi)
    q[low] = lo[low] + DEFAULT_Q0_MARGIN * span[low]
    q[high] = hi[high] - DEFAULT_Q0_MARGIN * span[high]
    return q


def resolve_locked(
    model: Any,
    locked_joints: Sequence[str] = (),
    groups: Mapping[str, Any] | None = None,
    active: Sequence[str] | None = None,
) -> tuple[str, ...]:
    """The joints to lock: ``locked_joints``, or the joints outside the ``active`` named ``groups``
    (:func:`coop_ga.systems.groups.locked_joints`); the two ways are exclusive."""
    locked = _names(locked_joints, "locked_joints")
    if groups is None and active is None:
        return locked
    if groups is None or active is None:
        raise InvalidInputError("named control groups need both groups= and active= (the groups that move)")
    if locked:
        raise InvalidInputError(
            "give either locked_joints= or groups=/active=, not both (put the joints to lock outside the active groups)"
        )
    return tuple(_group_locked(list(_pin_model(model).names)[1:], groups, active))


def _locked_model(model: Any, locked: Sequence[str], q_lock: Any) -> Any:
    """``model`` with the joints ``locked`` removed at ``q_lock`` (default: neutral) by ``pinocchio.buildReducedModel``."""
    import pinocchio as pin

    if not locked:
        return model
    known = set(model.names)
    missing = [j for j in locked if j not in known]
    if missing:
        raise UnknownNameError(
            f"unknown locked_joints {missing}. Joints of the model: {', '.join(list(model.names)[1:])}"
        )
    ql = pin.neutral(model) if q_lock is None else validation.configuration(q_lock, model.nq, "q_lock")
    try:
        return pin.buildReducedModel(model, [model.getJointId(j) for j in locked], ql)
    except (ValueError, RuntimeError) as e:
        raise InvalidInputError(
            f"locked_joints {list(locked)}: pinocchio.buildReducedModel refused them ({str(e).splitlines()[0]})"
        ) from None


def from_model(
    model: Any,
    end_frames: Sequence[str | EndPoint],
    *,
    name: str = "custom",
    q0: Any = None,
    locked_joints: Sequence[str] = (),
    q_lock: Any = None,
    description: str = "",
    visual_model: Any = None,
    visuals: Sequence[VisualSource] = (),
    groups: Mapping[str, Any] | None = None,
    active: Sequence[str] | None = None,
) -> System:
    """Build a :class:`System` from a ``pinocchio.Model``.

    ``locked_joints`` (names) are removed with ``pinocchio.buildReducedModel`` at
    ``q_lock`` (nq,) (default: the neutral configuration).  ``q0`` defaults to the neutral
    configuration moved strictly inside the limits (to mid-range where the limits exclude it,
    :data:`DEFAULT_Q0_MARGIN` of the range inside a bound it lies on); a given ``q0`` must be finite
    and inside the limits.

    ``end_frames``: frame names, or :class:`~coop_ga.systems.points.EndPoint` entries — points anywhere on a
    link (paper §5.4), added to a copy of the model as operational frames before locking.

    Continuous (unbounded revolute) joints get the angle as their one coordinate, unbounded
    (:func:`~coop_ga.systems.joints.continuous_as_revolute`); ``q_lock`` and ``q0`` are in those coordinates.

    Instead of ``locked_joints``, named control groups: ``groups`` ``{name: joint names or regular
    expressions}`` and ``active`` (the group names whose joints move); every other joint is locked
    (:mod:`coop_ga.systems.groups`).

    ``visual_model``: a visual ``pinocchio.GeometryModel`` built for ``model`` (before
    locking), so that :mod:`coop_ga.viz` draws the robot's meshes; or ``visuals``, the
    :class:`VisualSource` list of a combined model (one per robot, with its prefix).
    Without either the robot is drawn as a skeleton.

    Raises :class:`~coop_ga.errors.InvalidInputError` (:class:`~coop_ga.errors.UnknownNameError` for an
    unknown joint or frame) naming the argument.
    """
    import pinocchio as pin

    _pin_model(model)
    if isinstance(visuals, (str, VisualSource)) or not isinstance(visuals, Sequence):
        raise InvalidInputError(f"visuals must be a list of VisualSource, got {visuals!r}")
    sources = tuple(visuals)
    if visual_model is not None:
        if not isinstance(visual_model, pin.GeometryModel):
            raise InvalidInputError(
                f"visual_model must be a pinocchio.GeometryModel, got {type(visual_model).__name__}"
            )
        sources += (VisualSource(geometry=visual_model, model=pin.Model(model)),)
    model = continuous_as_revolute(model)  # q = θ for continuous joints, not (cos θ, sin θ)
    frames = end_frame_names(end_frames)
    points = [e for e in end_frames if isinstance(e, EndPoint)]
    if points:
        model = add_end_points(model, points)
    model = _locked_model(model, resolve_locked(model, locked_joints, groups, active), q_lock)
    if q0 is None:
        q0 = _default_q0(model)
    return System(
        name=name,
        model=model,
        end_frames=_names(frames, "end_frames"),
        q0=q0,
        description=description,
        visuals=sources,
    )


def _default_package_dirs(urdf: Path) -> tuple[str, ...]:
    """Folders that resolve ``package://NAME/...`` for a URDF inside its package: its parents."""
    p = urdf.resolve().parent
    return tuple(str(d) for d in [p, *list(p.parents)[:3]])


def from_urdf(
    urdf_path: str | Path,
    end_frames: Sequence[str | EndPoint],
    locked_joints: Sequence[str] = (),
    *,
    name: str | None = None,
    q0: Any = None,
    q_lock: Any = None,
    package_dirs: Sequence[str | Path] | None = None,
    groups: Mapping[str, Any] | None = None,
    active: Sequence[str] | None = None,
    free_flyer: bool = False,
) -> System:
    """Build a system from any URDF Pinocchio loads (fixed base; with ``free_flyer=True`` the root link is a
    floating base, a ``JointModelFreeFlyer`` named ``root_joint``: q starts with its position [m] and unit
    quaternion x y z w, q̇ with its LOCAL [v; ω] — module docstring).

    ``package_dirs``: folders that resolve the ``package://`` mesh URIs of its ``<visual>``
    elements (default: the URDF's folder and three of its parents); the visual geometry is
    read only when the system is drawn (:meth:`System.visual_model`).  ``groups``/``active``: named control
    groups instead of ``locked_joints`` (:func:`from_model`).

    Example::

        sys = coop_ga.systems.from_urdf("my_robot.urdf", ["left_tip", "right_tip", "thumb_tip"],
                                        locked_joints=["gripper_joint"])
        task = coop_ga.cooperative_task(sys, "circle")
    """
    p = _path(urdf_path, "urdf_path")
    if name is not None and (not isinstance(name, str) or not name):
        raise InvalidInputError(f"name must be a non-empty string (or None: the file's stem), got {name!r}")
    dirs = _default_package_dirs(p) if package_dirs is None else _dirs(package_dirs, "package_dirs")
    model = read_urdf(p, "urdf_path", free_flyer=free_flyer)
    return from_model(
        model,
        end_frames,
        name=name or p.stem,
        q0=q0,
        locked_joints=locked_joints,
        q_lock=q_lock,
        description=f"from URDF {p}",
        groups=groups,
        active=active,
        visuals=(VisualSource(urdf=p.resolve(), package_dirs=dirs),),
    )
