"""The tool at the end points: a stick with a rubber sphere pad (:func:`with_tool`, :func:`add_pads`).

The robots' own links make poor, shifting contacts with an object (a flange's rim, a gripper's
fingers), so a holding experiment gives every end frame a tool: a stick of ``length`` along the end
frame's z axis ending in a sphere pad, whose centre becomes the end point (:func:`with_tool` adds the
frames ``<end frame>_tool`` to a copy of the system's model, :func:`add_pads` the geometry to its
MuJoCo scene).  The pads carry their own contact settings — friction, ``condim``, a contact margin
and ``solref`` — and the scene gets MuJoCo's elliptic friction cones with ``impratio`` > 1 and,
optionally, no-slip iterations (MuJoCo's advice against grasp slip).  Pads and sticks are massless
(a scene never takes inertias from geoms), so the gate (sites = ``oMf``, ``mj_fullM`` = ``crba``) holds.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from ._mujoco import mj
from .scene import GROUP_SCENE, Scene

__all__ = ["add_pads", "with_tool"]


def with_tool(system: Any, length: float, *, name: str | None = None) -> Any:
    """A copy of ``system`` whose end frames are ``length`` [m] beyond the old ones along their z axes.

    The new frames ``<end frame>_tool`` (same orientation) are the tips of a tool (a stick ending in a
    pad, :func:`add_pads` with ``shaft_length=length``); the model is copied, the old one is untouched.
    """
    import dataclasses

    import pinocchio as pin

    L = validation.positive(length, "length")
    model = pin.Model(system.model)
    frames = []
    for f in system.end_frames:
        fid = model.getFrameId(f)
        fr = model.frames[fid]
        placement = fr.placement * pin.SE3(np.eye(3), np.array([0.0, 0.0, L]))
        frames.append(f"{f}_tool")
        model.addFrame(pin.Frame(frames[-1], fr.parentJoint, fid, placement, pin.FrameType.OP_FRAME))
    labels = tuple(f"{lab} tool" for lab in system.labels)
    return dataclasses.replace(
        system, model=model, end_frames=tuple(frames), labels=labels, name=name or f"{system.name}_tool"
    )


def add_pads(
    scene: Scene,
    radius: float = 0.03,
    *,
    shaft_length: float = 0.0,
    shaft_radius: float = 0.012,
    friction: Any = (1.0, 0.01, 0.0001),
    condim: int = 4,
    impratio: float = 10.0,
    cone: str = "elliptic",
    noslip_iterations: int = 0,
    margin: float = 0.0,
    solref: Any = None,
    rgba: Any = (0.15, 0.15, 0.15, 1.0),
) -> Scene:
    """A new :class:`Scene` with a rubber sphere pad of ``radius`` [m] centred on every end frame.

    Args:
        scene: the scene (its spec is copied, not modified).
        radius: pad radius [m] (the contact is ``radius`` beyond the end point).
        shaft_length: [m] a capsule of ``shaft_radius`` from the pad back along the end frame's −z (the
            stick of a :func:`with_tool` system; 0: no shaft).
        friction: the pads' (sliding, torsional, rolling) friction, or one number (MuJoCo combines two
            geoms' friction by the element-wise maximum: give the object the same, or lower, friction).
        condim: 3 (sliding), 4 (+ torsional) or 6 (+ rolling).
        impratio: MuJoCo's frictional-to-normal impedance ratio (> 1 stiffens friction: less creep).
        cone: ``"elliptic"`` (default) or ``"pyramidal"`` friction cones.
        noslip_iterations: MuJoCo's post-solver no-slip iterations (0: off).
        margin: [m] MuJoCo's contact margin of the pads: the contact acts from ``margin`` before touching
            (a skin; without it a pad pressing while sliding sits within microns of separation and its
            contact flickers off for single steps).
        solref: MuJoCo's (timeconst [s], dampratio) of the pad contacts (None: MuJoCo's (0.02, 1)); a
            smaller time constant makes the contact, and its friction, stiffer (≥ 2 Δt).
        rgba: pad colour.

    Returns:
        The new :class:`Scene` (geoms ``<end frame>_pad`` and ``<end frame>_shaft`` on the end bodies, in
        :data:`GROUP_SCENE`; massless: inertias never come from geoms).
    """
    from .objects import friction as _friction

    r = validation.positive(radius, "radius")
    L = validation.nonnegative(shaft_length, "shaft_length")
    fr = _friction(friction, "friction")
    if condim not in (3, 4, 6):
        raise InvalidInputError(f"condim must be 3, 4 or 6, got {condim!r}")
    validation.choice(cone, ("elliptic", "pyramidal"), "cone")
    m = mj()
    spec = scene.spec.copy()
    model = scene.model
    kw: dict[str, Any] = dict(
        friction=fr,
        condim=int(condim),
        contype=1,
        conaffinity=1,
        group=GROUP_SCENE,
        rgba=validation.vector(rgba, 4, "rgba"),
        margin=validation.nonnegative(margin, "margin"),
    )
    if solref is not None:
        kw["solref"] = validation.vector(solref, 2, "solref")
    rs = validation.positive(shaft_radius, "shaft_radius")
    for frame, sid in zip(scene.system.end_frames, scene.site_ids):
        body = spec.body(m.mj_id2name(model, m.mjtObj.mjOBJ_BODY, int(model.site_bodyid[sid])))
        _add_pad(body, frame, np.array(model.site_pos[sid]), np.array(model.site_quat[sid]), r, L, rs, kw)
    spec.option.cone = m.mjtCone.mjCONE_ELLIPTIC if cone == "elliptic" else m.mjtCone.mjCONE_PYRAMIDAL
    spec.option.impratio = validation.positive(impratio, "impratio")
    spec.option.noslip_iterations = validation.integer(noslip_iterations, "noslip_iterations", minimum=0)
    return replace(scene, spec=spec).recompile()


def _add_pad(body: Any, frame: str, pos: np.ndarray, quat: np.ndarray, r: float, L: float, rs: float, kw: dict) -> None:
    """The pad sphere of radius r at ``pos`` in ``body`` and, for L > 0, the stick (radius rs) behind it
    along the frame's −z."""
    m = mj()
    body.add_geom(name=f"{frame}_pad", type=m.mjtGeom.mjGEOM_SPHERE, size=[r, 0.0, 0.0], pos=pos, **kw)
    if L > 0:
        R = np.empty(9)
        m.mju_quat2Mat(R, quat)
        z = R.reshape(3, 3)[:, 2]
        body.add_geom(
            name=f"{frame}_shaft",
            type=m.mjtGeom.mjGEOM_CAPSULE,
            size=[rs, 0.0, 0.0],
            fromto=np.concatenate([pos - L * z, pos - 0.5 * r * z]),
            **kw,
        )
