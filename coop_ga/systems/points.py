"""End points anywhere on the body (paper §5.4): a point given by a link and a position in that link's frame.

The paper's end points are the chains' end effectors; §5.4 proposes contact points anywhere on a robot's
surface (a forearm pushing a box, the chest of Fig. 9).  An :class:`EndPoint` names a link (any frame of
the model) and a local position [m] in it; :func:`add_end_points` adds it to a copy of the Pinocchio
model as an operational frame (``OP_FRAME``) rigidly attached to that link, so everything above the
model — motor FK, the cooperative task graph, Jacobians, controllers, the MuJoCo scene's sites — treats it
like any end frame.  ``from_model``, ``from_urdf``, ``from_mjcf`` and :meth:`System.with_end_frames
<coop_ga.systems.System.with_end_frames>` take ``EndPoint`` entries in ``end_frames`` next to frame names::

    chest = EndPoint("torso_link", (0.15, 0.0, 0.20), name="chest_point")
    sys = coop_ga.systems.load("g1_arms").with_end_frames([chest, "right_rubber_hand", "left_rubber_hand"])

The point's world position is ``oMf[link] · offset``; its frame has the link's orientation (or
``rotation`` relative to it), which matters only to tasks that read end-frame orientations.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError, UnknownNameError

__all__ = ["EndPoint", "add_end_points", "end_frame_names"]


@dataclass(frozen=True)
class EndPoint:
    """A point on link ``link`` at ``offset`` [m] in the link's frame, added as the frame ``name``.

    Attributes:
        link: name of a frame of the model (usually a link's BODY frame, e.g. ``"torso_link"``).
        offset: (3,) position in that frame [m].
        name: name of the new frame (default ``"<link>_point"``); it must not exist in the model.
        rotation: (3, 3) orientation of the new frame relative to the link's (default: the identity).
    """

    link: str
    offset: Any = (0.0, 0.0, 0.0)
    name: str = ""
    rotation: Any = None

    def __post_init__(self) -> None:
        if not isinstance(self.link, str) or not self.link:
            raise InvalidInputError(f"EndPoint link must be a frame name (str), got {self.link!r}")
        offset = validation.array(self.offset, "EndPoint offset")
        if offset.shape != (3,):
            raise InvalidInputError(
                f"EndPoint offset must be 3 numbers [m] in the link frame, got shape {offset.shape}"
            )
        object.__setattr__(self, "offset", tuple(float(v) for v in offset))
        if not isinstance(self.name, str):
            raise InvalidInputError(f"EndPoint name must be a string, got {self.name!r}")
        if not self.name:
            object.__setattr__(self, "name", f"{self.link}_point")
        if self.rotation is not None:
            R = validation.array(self.rotation, "EndPoint rotation")
            if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
                raise InvalidInputError(f"EndPoint rotation must be a 3×3 rotation matrix, got {R.tolist()}")
            object.__setattr__(self, "rotation", tuple(tuple(float(v) for v in row) for row in R))


def end_frame_names(end_frames: Sequence[Any]) -> tuple[str, ...]:
    """The frame names of ``end_frames`` (names and :class:`EndPoint` entries, in order)."""
    if isinstance(end_frames, (str, EndPoint)) or not isinstance(end_frames, Sequence):
        raise InvalidInputError(f"end_frames must be a list of frame names or EndPoint, got {end_frames!r}")
    return tuple(e.name if isinstance(e, EndPoint) else e for e in end_frames)


def add_end_points(model: Any, points: Sequence[EndPoint]) -> Any:
    """A copy of ``model`` with one ``OP_FRAME`` per :class:`EndPoint`, attached to the point's link.

    The frame's parent joint and parent frame are the link frame's; its placement in the joint frame is
    ``link placement · SE3(rotation, offset)``.  Raises :class:`~coop_ga.errors.UnknownNameError` for a
    link the model does not have (listing its frames) and :class:`InvalidInputError` for a name that
    already exists (in the model or twice in ``points``).
    """
    import pinocchio as pin

    if not isinstance(model, pin.Model):
        raise InvalidInputError(f"model must be a pinocchio.Model, got {type(model).__name__}")
    if isinstance(points, EndPoint) or not isinstance(points, Sequence):
        raise InvalidInputError(f"points must be a list of EndPoint, got {points!r}")
    m = pin.Model(model)
    names = [f.name for f in m.frames]
    for p in points:
        if not isinstance(p, EndPoint):
            raise InvalidInputError(f"points must contain EndPoint objects, got {p!r}")
        if p.link not in names:
            raise UnknownNameError(f"EndPoint link '{p.link}' is not a frame of the model. Frames: {', '.join(names)}")
        if p.name in names:
            raise InvalidInputError(
                f"EndPoint name '{p.name}' already names a frame of the model; give the point another name="
            )
        # a URDF joint named like its child link gives a FIXED_JOINT and a BODY frame of one name: the link's
        pf = (
            m.getFrameId(p.link, pin.FrameType.BODY)
            if m.existFrame(p.link, pin.FrameType.BODY)
            else m.getFrameId(p.link)
        )
        link = m.frames[pf]
        R = np.eye(3) if p.rotation is None else np.array(p.rotation)
        placement = link.placement * pin.SE3(R, np.array(p.offset))
        m.addFrame(pin.Frame(p.name, link.parentJoint, pf, placement, pin.FrameType.OP_FRAME))
        names.append(p.name)
    return m
