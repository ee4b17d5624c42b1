"""Multi-chain robot systems: Pinocchio models plus the frames whose points span a primitive.

A :class:`System` bundles

* ``model`` — a fixed-base ``pinocchio.Model`` with revolute/prismatic joints only
  (robots combined with ``pinocchio.appendModel``, locked joints removed with
  ``pinocchio.buildReducedModel``);
* ``end_frames`` — frame names, one per chain, in the order the cooperative layer uses;
* ``q0``, ``q_lower``, ``q_upper``, ``joint_names`` — a nominal configuration and limits;
* ``tree`` — the :class:`~coop_ga.kinematics.chains.KinematicTree` (motor FK, Jacobians).

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
    "append_robots",
    "from_model",
    "from_urdf",
    "prefixed",
]

#: Directory of the URDFs coop_ga ships (iiwa14, hexapod): package data of ``coop_ga.systems``,
#: located with :mod:`importlib.resources`, so it exists in a wheel install as in a checkout.
ROBOTS_DIR = Path(str(resources.files("coop_ga.systems") / "robots"))


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
        self._data = None

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
        return dataclasses.replace(self, name=name or self.name, limits=new)

    @property
    def data(self) -> Any:
        """A ``pinocchio.Data`` for this model (created once)."""
        if self._data is None:
            self._data = self.model.createData()
        return self._data

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
) -> System:
    """Build a :class:`System` from a ``pinocchio.Model``.

    ``locked_joints`` (names) are removed with ``pinocchio.buildReducedModel`` at
    ``q_lock`` (default: the neutral configuration).  ``q0`` defaults to the neutral
    configuration, moved to mid-range where the limits exclude it.
    """
    import pinocchio as pin

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
        name=name, model=model, end_frames=tuple(end_frames), q0=np.asarray(q0, dtype=float), description=description
    )


def from_urdf(
    urdf_path: str | Path,
    end_frames: Sequence[str],
    locked_joints: Sequence[str] = (),
    *,
    name: str | None = None,
    q0: Any = None,
    q_lock: Any = None,
) -> System:
    """Build a system from any URDF Pinocchio loads (fixed base).

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
    return from_model(
        model,
        end_frames,
        name=name or p.stem,
        q0=q0,
        locked_joints=locked_joints,
        q_lock=q_lock,
        description=f"from URDF {p}",
    )
