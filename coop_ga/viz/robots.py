"""Robot skeletons from Pinocchio forward kinematics of a :class:`coop_ga.systems.System`.

The skeleton of a model at q (world frame, metres) is

* one segment per actuated joint, from its parent joint's origin (``data.oMi``) to its own
  — a root joint starts at the body it hangs from (the parent frame of its JOINT frame,
  e.g. a Panda's ``link0`` or a G1's pelvis), so bases and pedestals show;
* one segment per end frame, from its joint's origin to the frame (``data.oMf``), dashed;
* the fixed structure (bodies attached to the world through fixed or locked joints) as
  points, with a segment to their parent body where the model records one.

Any system (a ``model`` with revolute/prismatic joints and ``end_frames``) can be drawn;
:func:`skeleton` returns the geometry, :func:`draw_robot` draws it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .axes import Drawn
from .style import LINEWIDTH, PALETTE

__all__ = ["RobotDrawn", "Skeleton", "draw_robot", "skeleton"]


@dataclass
class Skeleton:
    """Geometry of a robot at one configuration, world frame [m].

    segments: (S, 2, 3) segment end points; kinds: one of 'joint', 'end', 'fixed' per segment;
    joints: (J, 3) actuated joint origins; end_points: (k, 3) end frames in ``system.end_frames``
    order; fixed_points: (F, 3) bodies fixed to the world; chains: one (m_i, 3) polyline per
    end frame, from the body its root joint hangs from through its joints to the end frame.
    """

    segments: np.ndarray
    kinds: tuple[str, ...]
    joints: np.ndarray
    end_points: np.ndarray
    fixed_points: np.ndarray
    chains: list[np.ndarray] = field(default_factory=list)

    def points(self) -> np.ndarray:
        """Every point of the skeleton (N, 3) [m], for axis limits."""
        return np.vstack([self.segments.reshape(-1, 3), self.joints, self.end_points, self.fixed_points])


def skeleton(system: Any, q: Any) -> Skeleton:
    """The :class:`Skeleton` of ``system`` (a :class:`coop_ga.systems.System`, or anything with a
    Pinocchio ``model`` and ``end_frames``) at configuration ``q`` (nq,) [rad | m]."""
    import pinocchio as pin

    m = system.model
    q = np.asarray(q, dtype=float).reshape(-1)
    if q.shape != (m.nq,):
        raise ValueError(f"q must have {m.nq} entries for system {getattr(system, 'name', '?')!r}, got {q.shape}")
    d = m.createData()
    pin.forwardKinematics(m, d, q)
    pin.updateFramePlacements(m, d)

    def root_of(j: int) -> np.ndarray:
        """Where root joint j hangs from: the parent frame of its JOINT frame (else the joint itself)."""
        fid = m.getFrameId(m.names[j], pin.FrameType.JOINT)
        if fid < len(m.frames):
            return np.array(d.oMf[m.frames[fid].parentFrame].translation)
        return np.array(d.oMi[j].translation)

    segs: list[tuple[np.ndarray, np.ndarray]] = []
    kinds: list[str] = []
    for j in range(1, m.njoints):
        b = np.array(d.oMi[j].translation)
        p = int(m.parents[j])
        if p == 0 and m.joints[j].shortname() == "JointModelFreeFlyer":
            start = b  # a free flyer hangs from nothing: no segment from the world origin to the floating base
        else:
            start = np.array(d.oMi[p].translation) if p > 0 else root_of(j)
        segs.append((start, b))
        kinds.append("joint")
    ends, chains = [], []
    for f in system.end_frames:
        fid = m.getFrameId(f)
        j = int(m.frames[fid].parentJoint)
        e = np.array(d.oMf[fid].translation)
        segs.append((np.array(d.oMi[j].translation), e))
        kinds.append("end")
        ends.append(e)
        path = []
        while j > 0:
            path.append(j)
            j = int(m.parents[j])
        pts = [np.array(d.oMi[k].translation) for k in reversed(path)]
        chains.append(np.array(([root_of(path[-1])] if path else []) + pts + [e]))
    fixed, seen = [], set()
    for i, f in enumerate(m.frames):
        if i == 0 or f.parentJoint != 0 or f.type != pin.FrameType.BODY:
            continue
        fixed.append(np.array(d.oMf[i].translation))
        pf = m.frames[f.parentFrame]  # FIXED_JOINT frame → its parent body (reduced models may self-reference)
        if pf.parentFrame not in (f.parentFrame, 0) and (i, pf.parentFrame) not in seen:
            seen.add((i, pf.parentFrame))
            segs.append((np.array(d.oMf[pf.parentFrame].translation), np.array(d.oMf[i].translation)))
            kinds.append("fixed")
    J = np.array([b for (_, b), k in zip(segs, kinds) if k == "joint"]).reshape(-1, 3)
    return Skeleton(
        segments=np.array([[a, b] for a, b in segs]).reshape(-1, 2, 3),
        kinds=tuple(kinds),
        joints=J,
        end_points=np.array(ends).reshape(-1, 3),
        fixed_points=np.array(fixed).reshape(-1, 3),
        chains=chains,
    )


@dataclass
class RobotDrawn(Drawn):
    """:class:`~coop_ga.viz.axes.Drawn` plus the :class:`Skeleton` that was drawn."""

    skeleton: Skeleton | None = None


def draw_robot(
    ax: Any,
    system: Any,
    q: Any,
    *,
    color: Any = None,
    lw: float | None = None,
    alpha: float = 1.0,
    label: str | None = None,
    joints: bool = True,
    ends: bool = True,
    fixed: bool = True,
    end_color: Any = None,
    end_size: float = 40.0,
    end_labels: bool = False,
    zorder: float | None = None,
) -> RobotDrawn:
    """Draw the skeleton of ``system`` at configuration ``q`` (nq,) on a matplotlib ``Axes3D``.

    ``color``/``lw``/``alpha``: links and joint dots (default ``PALETTE.robot``, 2.2 pt);
    ``label``: legend entry of the links; ``joints``: dots at the joint origins; ``ends``:
    markers at the end points (``end_color``, default ``PALETTE.end_point``; ``end_size`` in pt²);
    ``end_labels``: write ``system.labels`` next to them; ``fixed``: the fixed structure (grey).

    Returns a :class:`RobotDrawn` (artists, all points drawn (N, 3) [m], the skeleton).
    """
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    sk = skeleton(system, q)
    col = PALETTE.robot if color is None else color
    lw = LINEWIDTH["robot"] if lw is None else float(lw)
    out = RobotDrawn(skeleton=sk)
    extra = {} if zorder is None else {"zorder": zorder}
    styles = {
        "joint": {"colors": [col], "linewidths": lw, "linestyles": "-"},
        "end": {"colors": [col], "linewidths": 0.55 * lw, "linestyles": "--"},
        "fixed": {"colors": [PALETTE.fixed], "linewidths": 0.45 * lw, "linestyles": "-"},
    }
    kinds = np.array(sk.kinds)
    for kind, st in styles.items():
        segs = sk.segments[kinds == kind] if len(kinds) else np.zeros((0, 2, 3))
        if len(segs) == 0 or (kind == "fixed" and not fixed):
            continue
        lc = Line3DCollection(list(segs), alpha=alpha, label=label if kind == "joint" else None, **st, **extra)
        ax.add_collection3d(lc)
        out.artists.append(lc)
    if joints and len(sk.joints):
        out.artists.append(ax.scatter(*sk.joints.T, s=3.0 * lw**2, color=col, alpha=alpha, depthshade=False, **extra))
    if fixed and len(sk.fixed_points):
        out.artists.append(ax.scatter(*sk.fixed_points.T, s=6, color=PALETTE.fixed, alpha=alpha, depthshade=False))
    if ends and len(sk.end_points):
        ec = PALETTE.end_point if end_color is None else end_color
        out.artists.append(
            ax.scatter(
                *sk.end_points.T,
                s=end_size,
                color=ec,
                alpha=alpha,
                depthshade=False,
                zorder=5 if zorder is None else zorder + 1,
            )
        )
        if end_labels:
            for p, lab in zip(sk.end_points, getattr(system, "labels", system.end_frames)):
                out.artists.append(ax.text(p[0], p[1], p[2], f"  {lab}", fontsize=7, color=ec))
    out.points = sk.points()
    return out
