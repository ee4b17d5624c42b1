"""A MuJoCo scene built in code (``mujoco.MjSpec``) from the Pinocchio model a :class:`~coop_ga.systems.System` uses.

:func:`build_scene` walks ``system.model`` — the same model the kinematics, Jacobians and dynamics of
coop_ga use, whether it was read from a URDF, reduced with locked joints
(``pinocchio.buildReducedModel``: locked links ride on their parent joint, their inertia lumped into
it) or combined from several robots (``pinocchio.appendModel``, prefixed names) — and builds:

* **bodies and joints** — one MuJoCo body per Pinocchio joint, placed at ``model.jointPlacements``
  relative to its parent's body, carrying the joint (``hinge`` for a revolute, ``slide`` for a
  prismatic joint, same axis) and the joint's inertia ``model.inertias[j]`` (mass, centre of mass,
  full rotational inertia, given to MuJoCo as its principal axes and moments).  MuJoCo refuses a
  moving body without mass, so a massless joint body with exactly one child joint (e.g. a chain of
  virtual joints built in code) is merged with that child into one MuJoCo body that carries both
  joints in order (MuJoCo applies a body's joints one after the other, each in the frame moved by
  the previous ones; the child joint sits at its placement in that frame), which is the same
  kinematics.  Joint names are Pinocchio's;
* **limits and joint dynamics** — ``range`` from ``system.limits`` (position limits, what every
  controller of coop_ga reads), ``armature`` from ``model.armature`` (Pinocchio's ``crba`` and
  ``aba`` include it, so both simulators see the same joint-space inertia), ``damping`` from
  ``model.damping`` and ``frictionloss`` from ``model.friction`` (the URDF's ``<dynamics damping
  friction>``; Pinocchio's ``aba`` ignores both — override them with ``damping=`` / ``frictionloss=``
  to compare against it);
* **end points** — every end frame of the system is a MuJoCo *site* of the same name at the frame's
  placement (``data.site_xpos``/``site_xmat`` equal Pinocchio's ``oMf``);
* **actuators** — one ``motor`` per joint (gear 1, so ctrl = joint torque [N m] or force [N]),
  ``ctrlrange`` and ``forcerange`` = ±``system.limits.effort`` (the URDF effort); a joint with an
  unbounded effort gets an unlimited motor;
* **collision geometry** — the bounding capsules :func:`coop_ga.collision.fit_capsules` fits to each
  link's collision meshes (or ``capsules=`` given), as MuJoCo capsules (a sphere where a capsule
  degenerates to a ball).  A capsule of a link fixed to the world (an arm's base) goes on a static
  body of that link's name.  Self-collision follows :class:`coop_ga.collision.CollisionModel`: two
  capsules collide iff their pair is one of the model's self-distance rows (pairs on one rigid
  body, adjacent links, SRDF-disabled pairs and pairs overlapping at ``system.q0`` do not).  MuJoCo
  filters by body, so a body pair with any excluded capsule pair gets an ``<exclude>``
  (:attr:`Scene.excluded`) and its allowed capsule pairs explicit ``<pair>`` elements (a Panda's
  link 5 still touches the fingers locked on link 7's body, though link 5–link 7 is disabled);
* **visual geometry** — the meshes and shapes of :meth:`System.visual_model` as visual-only geoms
  (``contype = conaffinity = 0``, no mass, group :data:`GROUP_VISUAL`), meshes inline (vertex and
  face arrays, decimated to ``visual_cell``; one asset per distinct mesh);
* **a floor** (a plane at z = ``floor``), **scene objects** (:class:`~coop_ga.sim.objects.Box`,
  :class:`~coop_ga.sim.objects.Ball`, :class:`~coop_ga.sim.objects.Cylinder`: free bodies, or static
  ones), gravity from ``model.gravity``, Δt = ``timestep`` (1 ms), MuJoCo's ``implicitfast``
  integrator by default.

With ``floating_base=True`` everything fixed to the world in the system (the hexapod's body, an
arm's base) is instead one free body (a MuJoCo ``freejoint``) named :attr:`Scene.base_body`, carrying
``model.inertias[0]`` (the links fixed to Pinocchio's universe) — a robot that can fall, walk or be
pushed.

Geom groups (MuJoCo's ``mjvOption.geomgroup`` shows 0–2 by default): :data:`GROUP_SCENE` (0) floor
and objects, :data:`GROUP_VISUAL` (2) robot visuals, :data:`GROUP_COLLISION` (3, hidden) robot
capsules, sites in :data:`GROUP_SITES` (4, hidden).

Index maps (:class:`Scene`): ``qpos_index[i]`` is the MuJoCo ``qpos`` address of Pinocchio coordinate
``q[i]``, ``qvel_index[i]`` the ``qvel`` address of ``q̇[i]``, ``actuator_index[i]`` the actuator of
joint i; ``site_ids`` / ``end_bodies`` per end frame; ``object_ids`` (object name → body id) and the
free objects' ``qpos``/``qvel`` addresses.

Checked in ``tests/sim/test_gate.py``: at 100 random in-limit configurations of every registered
system and a ``from_urdf`` system, the sites equal Pinocchio's ``oMf`` (position and rotation) to
1e-9 and MuJoCo's joint-space inertia (``mj_fullM``) equals Pinocchio's ``crba`` to 1e-8 relative.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..errors import CoopGAError, InvalidInputError, UnknownNameError
from ..kinematics.chains import _SUPPORTED, _joint_axis
from ._mujoco import mj as _mj
from .mjcf import check_reload, to_xml
from .objects import SceneObject, friction

__all__ = [
    "GROUP_COLLISION",
    "GROUP_SCENE",
    "GROUP_SITES",
    "GROUP_VISUAL",
    "INTEGRATORS",
    "Scene",
    "add_objects",
    "build_scene",
    "set_inertial",
]

GROUP_SCENE, GROUP_VISUAL, GROUP_COLLISION, GROUP_SITES = 0, 2, 3, 4
#: ``integrator=`` names and MuJoCo's enum members.
INTEGRATORS = {
    "euler": "mjINT_EULER",
    "implicitfast": "mjINT_IMPLICITFAST",
    "implicit": "mjINT_IMPLICIT",
    "rk4": "mjINT_RK4",
}
#: robot geoms' default friction (sliding, torsional, rolling): MuJoCo's defaults
ROBOT_FRICTION = (1.0, 0.005, 0.0001)
_MASSLESS = 1e-12  # [kg]: a Pinocchio body lighter than this counts as massless


def _pos_quat(M: Any) -> tuple[np.ndarray, np.ndarray]:
    """(position (3,), unit quaternion (w, x, y, z)) of a ``pinocchio.SE3``."""
    q = np.empty(4)
    _mj().mju_mat2Quat(q, np.ascontiguousarray(M.rotation, dtype=float).reshape(9))
    return np.array(M.translation, dtype=float), q


def _principal(I_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(principal moments (3,), quaternion of the principal axes in the body frame) of a (3, 3) inertia."""
    w, V = np.linalg.eigh(0.5 * (I_c + I_c.T))
    if np.linalg.det(V) < 0:
        V[:, 2] = -V[:, 2]
    q = np.empty(4)
    _mj().mju_mat2Quat(q, np.ascontiguousarray(V).reshape(9))
    return w, q


@dataclass
class _Attach:
    """Where a Pinocchio joint's frame lives in MuJoCo: its body and the frame's pose in that body."""

    body: Any
    offset: Any  # pinocchio.SE3
    group: list[int] = field(default_factory=list)  # Pinocchio joints of the body, in order (shared list)


# ====================================================================== the robot
def _children(model: Any) -> dict[int, list[int]]:
    out: dict[int, list[int]] = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        out[int(model.parents[j])].append(j)
    return out


def _add_joint_bodies(root: Any, system: Any, dyn: dict[str, np.ndarray]) -> dict[int, _Attach]:
    """One MuJoCo body per Pinocchio joint (massless single-child bodies merged, module docstring)."""
    import pinocchio as pin

    mj = _mj()
    model = system.model
    lim = system.limits
    children = _children(model)
    att: dict[int, _Attach] = {0: _Attach(root, pin.SE3.Identity(), [0])}
    mass: dict[int, float] = {}  # id(body group) → mass so far
    for j in range(1, model.njoints):
        short = model.joints[j].shortname()
        if short not in _SUPPORTED:
            raise InvalidInputError(
                f"joint '{model.names[j]}' has type {short}; build_scene supports {sorted(_SUPPORTED)}"
            )
        kind, fixed_axis = _SUPPORTED[short]
        axis = np.asarray(_joint_axis(model, j, kind) if fixed_axis is None else fixed_axis, float)
        p = int(model.parents[j])
        pa = att[p]
        if p > 0 and mass[id(pa.group)] < _MASSLESS and len(children[p]) == 1:
            a = _Attach(pa.body, pa.offset * model.jointPlacements[j], pa.group)  # merged (module docstring)
        else:
            pos, quat = _pos_quat(pa.offset * model.jointPlacements[j])
            a = _Attach(pa.body.add_body(pos=pos, quat=quat), pin.SE3.Identity(), [])
            mass[id(a.group)] = 0.0
        a.group.append(j)
        mass[id(a.group)] += float(model.inertias[j].mass)
        att[j] = a
        v = int(model.idx_vs[j])
        jt = a.body.add_joint(
            name=model.names[j],
            type=mj.mjtJoint.mjJNT_HINGE if kind == "revolute" else mj.mjtJoint.mjJNT_SLIDE,
            pos=np.array(a.offset.translation, float),
            axis=np.asarray(a.offset.rotation, float) @ axis,
            armature=float(dyn["armature"][v]),
            frictionloss=float(dyn["frictionloss"][v]),
        )
        if np.ndim(jt.damping):  # MuJoCo 4: a polynomial in q̇ whose first coefficient is the linear damping
            jt.damping[0] = float(dyn["damping"][v])
        else:  # MuJoCo 3: one number
            jt.damping = float(dyn["damping"][v])
        lo, hi = float(lim.lower[model.idx_qs[j]]), float(lim.upper[model.idx_qs[j]])
        if np.isfinite(lo) and np.isfinite(hi):
            jt.limited = mj.mjtLimited.mjLIMITED_TRUE
            jt.range = [lo, hi]
        else:
            jt.limited = mj.mjtLimited.mjLIMITED_FALSE
    _set_inertias(att, model)
    _name_bodies(att, model)
    return att


def _groups(att: dict[int, _Attach], model: Any) -> list[_Attach]:
    """One :class:`_Attach` per MuJoCo body of the robot's joints (its first joint's), in joint order."""
    seen: set[int] = set()
    out = []
    for j in range(1, model.njoints):
        if id(att[j].group) not in seen:
            seen.add(id(att[j].group))
            out.append(att[j])
    return out


def set_inertial(body: Any, mass: float, com: Any, I_c: Any, what: str) -> None:
    """Give ``body`` (an ``mujoco.MjsBody`` of a scene's spec) an explicit inertial: ``mass`` [kg], centre of
    mass ``com`` (3,) [m] and inertia ``I_c`` (3, 3) about it [kg m²] in the body frame, as MuJoCo's principal
    moments and axes.  Used for the robot's bodies, the scene's free objects and bodies added to a scene
    elsewhere (e.g. the moving obstacle of :mod:`coop_ga.sim.mpc_track`).

    Raises:
        InvalidInputError: a non-physical inertia (a principal moment ≤ 0 or the triangle inequality broken),
            naming ``what`` (e.g. "object 'box'").
    """
    w, q = _principal(np.asarray(I_c, float))
    if w[0] <= 0.0 or w[0] + w[1] < w[2] * (1.0 - 1e-9):
        raise InvalidInputError(
            f"{what} has a non-physical rotational inertia (principal moments {w.tolist()} kg m² must be > 0 "
            "and satisfy A + B ≥ C); fix its <inertia> in the URDF"
        )
    body.explicitinertial = True
    body.mass = float(mass)
    body.ipos = np.array(com, float)
    body.iquat = q
    body.inertia = w


def _set_inertias(att: dict[int, _Attach], model: Any) -> None:
    """Each body's inertia: the sum of its joints' Pinocchio inertias, moved into the body frame."""
    import pinocchio as pin

    for a in _groups(att, model):
        total = pin.Inertia.Zero()
        for k in a.group:
            total = total + att[k].offset.act(model.inertias[k])
        names = ", ".join(model.names[k] for k in a.group)
        if total.mass < _MASSLESS:
            raise InvalidInputError(
                f"joint(s) {names} move a body without mass: MuJoCo cannot simulate it (its mass matrix would "
                "be singular); give the link an <inertial> in the URDF, or lock the joint "
                "(from_urdf(..., locked_joints=[...]))"
            )
        set_inertial(a.body, total.mass, total.lever, total.inertia, f"the body moved by joint(s) {names}")


def _name_bodies(att: dict[int, _Attach], model: Any) -> None:
    """Body names: the link (BODY frame) of the body's last joint, else of any of its joints, else
    ``<first joint>_link``; made unique."""
    import pinocchio as pin

    links: dict[int, str] = {}
    for f in model.frames:
        if f.type == pin.FrameType.BODY and int(f.parentJoint) not in links:
            links[int(f.parentJoint)] = f.name
    used: set[str] = {f.name for f in model.frames if int(f.parentJoint) == 0}  # static link bodies
    for a in _groups(att, model):
        cands = [links[k] for k in reversed(a.group) if k in links]
        name = cands[0] if cands else f"{model.names[a.group[0]]}_link"
        base, i = name, 1
        while name in used:
            name, i = f"{base}_{i}", i + 1
        used.add(name)
        a.body.name = name


def _frame_in_body(model: Any, att: dict[int, _Attach], fid: int) -> tuple[Any, Any]:
    """(MuJoCo body, pose of Pinocchio frame ``fid`` in that body's frame)."""
    f = model.frames[fid]
    a = att[int(f.parentJoint)]
    return a.body, a.offset * f.placement


def _add_actuators(spec: Any, system: Any) -> None:
    mj = _mj()
    eff = system.limits.effort
    for i, name in enumerate(system.joint_names):
        act = spec.add_actuator(name=f"{name}_motor", target=name, trntype=mj.mjtTrn.mjTRN_JOINT)
        act.set_to_motor()
        if np.isfinite(eff[i]):
            act.ctrllimited = mj.mjtLimited.mjLIMITED_TRUE
            act.ctrlrange = [-float(eff[i]), float(eff[i])]
            act.forcelimited = mj.mjtLimited.mjLIMITED_TRUE
            act.forcerange = [-float(eff[i]), float(eff[i])]
        else:
            act.ctrllimited = mj.mjtLimited.mjLIMITED_FALSE


def _add_sites(model: Any, att: dict[int, _Attach], end_frames: Sequence[str]) -> None:
    mj = _mj()
    for name in end_frames:
        body, M = _frame_in_body(model, att, model.getFrameId(name))
        pos, quat = _pos_quat(M)
        body.add_site(
            name=name, pos=pos, quat=quat, size=[0.01, 0, 0], group=GROUP_SITES, type=mj.mjtGeom.mjGEOM_SPHERE
        )


# ====================================================================== collision
def _capsules(system: Any, capsules: Any) -> tuple[Any, ...]:
    from ..collision import Capsule, fit_capsules

    if capsules is not None:
        caps = tuple(capsules)
        if not all(isinstance(c, Capsule) for c in caps):
            raise InvalidInputError("capsules must be coop_ga.collision.Capsule objects")
        return caps
    try:
        return tuple(fit_capsules(system))
    except CoopGAError as e:
        raise InvalidInputError(
            f"the collision geometry of system '{system.name}' cannot be built ({e}); pass capsules=[Capsule(frame, "
            "a, b, radius), ...] (coop_ga.collision.Capsule, one per link) or collision=False (no robot contacts)"
        ) from e


def capsule_geom_name(capsule: Any, i: int) -> str:
    """MuJoCo geom name of capsule ``i`` of a scene: ``<link>_capsule<i>``."""
    return f"{capsule.link}_capsule{i}"


def _add_capsules(
    spec: Any, root: Any, system: Any, att: dict[int, _Attach], caps: Sequence[Any], friction: np.ndarray
) -> list[Any]:
    """The capsules as MuJoCo geoms; returns the MuJoCo body of each capsule (static link bodies for
    capsules of world-fixed links)."""
    import pinocchio as pin

    mj = _mj()
    model = system.model
    static: dict[str, Any] = {}
    bodies = []
    for i, c in enumerate(caps):
        if not model.existFrame(c.frame):
            raise UnknownNameError(f"capsule frame '{c.frame}' is not a frame of system '{system.name}'")
        fid = model.getFrameId(c.frame)
        if int(model.frames[fid].parentJoint) == 0:
            if c.frame not in static:
                pos, quat = _pos_quat(model.frames[fid].placement)
                static[c.frame] = root.add_body(name=c.frame, pos=pos, quat=quat)
            body, M = static[c.frame], pin.SE3.Identity()
        else:
            body, M = _frame_in_body(model, att, fid)
        a = np.asarray(M.act(np.asarray(c.a, float)), float)
        b = np.asarray(M.act(np.asarray(c.b, float)), float)
        kw = dict(
            name=capsule_geom_name(c, i),
            contype=1,
            conaffinity=1,
            group=GROUP_COLLISION,
            friction=friction,
            rgba=[0.3, 0.6, 0.9, 0.4],
        )
        if np.linalg.norm(b - a) < 1e-9:
            body.add_geom(type=mj.mjtGeom.mjGEOM_SPHERE, size=[c.radius, 0, 0], pos=0.5 * (a + b), **kw)
        else:
            body.add_geom(type=mj.mjtGeom.mjGEOM_CAPSULE, size=[c.radius, 0, 0], fromto=np.concatenate([a, b]), **kw)
        bodies.append(body)
    return bodies


def _add_excludes(
    spec: Any, system: Any, caps: Sequence[Any], bodies: list[Any], self_collision: bool, friction: np.ndarray
) -> list[tuple[str, str, str]]:
    """``<exclude>`` every pair of robot bodies with a capsule pair that must not collide (module
    docstring), and an explicit ``<pair>`` for each capsule pair of such bodies that must; returns
    (body, body, reason) of each excluded body pair."""
    allowed: set[tuple[int, int]] = set()
    if self_collision and len(caps) > 1:
        from ..collision import CollisionModel

        cm = CollisionModel(system, capsules=caps)
        allowed = {(int(i), int(j)) for (i, j), k in zip(cm.pairs, cm.kinds) if k == "self"}
    excluded: dict[tuple[str, str], str] = {}
    kept: dict[tuple[str, str], list[tuple[int, int]]] = {}
    for i in range(len(caps)):
        for j in range(i + 1, len(caps)):
            bi, bj = bodies[i], bodies[j]
            if bi is bj:
                continue
            key = (bi.name, bj.name) if bi.name < bj.name else (bj.name, bi.name)
            if (i, j) in allowed:
                kept.setdefault(key, []).append((i, j))
            else:
                why = f"{caps[i].link} – {caps[j].link}" if self_collision else "self_collision=False"
                excluded.setdefault(key, why)
    for a, b in sorted(excluded):
        spec.add_exclude(bodyname1=a, bodyname2=b)
        for i, j in kept.get((a, b), ()):  # explicit pairs are not affected by <exclude>
            spec.add_pair(
                geomname1=capsule_geom_name(caps[i], i),
                geomname2=capsule_geom_name(caps[j], j),
                condim=3,
                friction=[friction[0], friction[0], friction[1], friction[2], friction[2]],
            )
    return [(a, b, why) for (a, b), why in sorted(excluded.items())]


# ====================================================================== visuals
_PRIMITIVES = {
    "Box": ("mjGEOM_BOX", lambda g: np.asarray(g.halfSide, float)),
    "Sphere": ("mjGEOM_SPHERE", lambda g: np.array([g.radius, 0.0, 0.0])),
    "Cylinder": ("mjGEOM_CYLINDER", lambda g: np.array([g.radius, g.halfLength, 0.0])),
    "Capsule": ("mjGEOM_CAPSULE", lambda g: np.array([g.radius, g.halfLength, 0.0])),
    "Ellipsoid": ("mjGEOM_ELLIPSOID", lambda g: np.asarray(g.radii, float)),
}


def _visual_mesh(spec: Any, obj: Any, cell: float, assets: dict[Any, str | None]) -> str | None:
    """Name of the inline mesh asset of a visual object (created once per mesh and cell), or None if empty."""
    from ..systems.meshes import object_key, object_mesh
    from ..viz.mesh import decimate

    key = (object_key(obj), cell)
    if key not in assets:
        mesh = object_mesh(obj)
        if mesh is not None and cell > 0:
            mesh = decimate(mesh, cell)
        if mesh is None or len(mesh.faces) < 4:
            assets[key] = None
        else:
            name = f"mesh{len(assets)}"
            m = spec.add_mesh(
                name=name,
                uservert=np.asarray(mesh.vertices, float).reshape(-1).tolist(),
                userface=np.asarray(mesh.faces, np.int64).reshape(-1).tolist(),
            )
            m.inertia = _mj().mjtMeshInertia.mjMESH_INERTIA_SHELL  # visual only: no volume needed
            assets[key] = name
    return assets[key]


def _add_visuals(spec: Any, root: Any, system: Any, att: dict[int, _Attach], cell: float) -> int:
    """The system's visual geometry as visual-only geoms; returns the number of objects skipped (empty)."""
    mj = _mj()
    geom = system.visual_model()
    if geom is None:
        return 0
    assets: dict[Any, str | None] = {}
    skipped = 0
    for k, obj in enumerate(geom.geometryObjects):
        j = int(obj.parentJoint)
        body, offset = (root, None) if j == 0 else (att[j].body, att[j].offset)
        M = obj.placement if offset is None else offset * obj.placement
        pos, quat = _pos_quat(M)
        kw = dict(name=f"{obj.name}_visual{k}", pos=pos, quat=quat, contype=0, conaffinity=0, group=GROUP_VISUAL)
        rgba = np.clip(np.asarray(obj.meshColor, float), 0.0, 1.0)
        kind = type(obj.geometry).__name__
        if kind in _PRIMITIVES:
            gtype, size = _PRIMITIVES[kind]
            body.add_geom(type=getattr(mj.mjtGeom, gtype), size=size(obj.geometry), rgba=rgba, **kw)
            continue
        mesh = _visual_mesh(spec, obj, cell, assets)
        if mesh is None:
            skipped += 1
            continue
        body.add_geom(type=mj.mjtGeom.mjGEOM_MESH, meshname=mesh, rgba=rgba, **kw)
    return skipped


# ====================================================================== world
def _add_world(spec: Any, floor: float | None) -> None:
    """Floor (checker plane at z = floor), lights, a sky and the offscreen buffer size for :mod:`coop_ga.sim.render`."""
    mj = _mj()
    spec.visual.global_.offwidth = 1280
    spec.visual.global_.offheight = 960
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    spec.worldbody.add_light(name="sun", pos=[0, 0, 4], dir=[0.3, 0.2, -1.0], diffuse=[0.6, 0.6, 0.6])
    spec.add_texture(
        name="sky",
        type=mj.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mj.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.93, 0.95, 0.97],
        rgb2=[0.55, 0.62, 0.7],
        width=256,
        height=256,
    )
    if floor is None:
        return
    spec.add_texture(
        name="floor_checker",
        type=mj.mjtTexture.mjTEXTURE_2D,
        builtin=mj.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.82, 0.84, 0.86],
        rgb2=[0.72, 0.74, 0.77],
        width=256,
        height=256,
    )
    mat = spec.add_material(name="floor_material", texrepeat=[8, 8], reflectance=0.0)
    mat.textures[mj.mjtTextureRole.mjTEXROLE_RGB] = "floor_checker"
    spec.worldbody.add_geom(
        name="floor",
        type=mj.mjtGeom.mjGEOM_PLANE,
        size=[0, 0, 0.05],
        pos=[0, 0, floor],
        material="floor_material",
        contype=1,
        conaffinity=1,
        group=GROUP_SCENE,
    )


def add_objects(spec: Any, objects: Sequence[SceneObject], taken: set[str]) -> None:
    """Add each :class:`~coop_ga.sim.objects.SceneObject` to ``spec``'s world body: a body at its pose (with a
    free joint and its inertial unless ``static``) and its geom (scene group, colliding with everything).
    ``taken``: the body names already in the spec; each object's name is added to it.  Used by
    :func:`build_scene` and to add objects to an existing scene (:mod:`coop_ga.sim.plan_execute`).

    Raises:
        InvalidInputError: an object's name is already taken (a link or another object).
    """
    mj = _mj()
    for ob in objects:
        if ob.name in taken:
            raise InvalidInputError(
                f"object name '{ob.name}' is already used in the scene (a link or another object); rename the object"
            )
        taken.add(ob.name)
        body = spec.worldbody.add_body(name=ob.name, pos=ob.pos, quat=ob.quat, mocap=ob.mocap)
        if ob.free:
            body.add_freejoint(name=ob.name)
            set_inertial(body, ob.mass, np.zeros(3), ob.inertia, f"object '{ob.name}'")
        body.add_geom(
            name=f"{ob.name}_geom",
            type=getattr(mj.mjtGeom, f"mjGEOM_{ob.geom_type}"),
            size=ob.geom_size(),
            friction=ob.friction,
            condim=int(ob.condim),
            rgba=ob.rgba,
            contype=1,
            conaffinity=1,
            group=GROUP_SCENE,
        )


def _joint_dynamics(model: Any, armature: Any, damping: Any, frictionloss: Any) -> dict[str, np.ndarray]:
    """(nv,) armature, damping and frictionloss: the model's (URDF) values, or the overrides."""
    out = {}
    for name, given, default in (
        ("armature", armature, model.armature),
        ("damping", damping, model.damping),
        ("frictionloss", frictionloss, model.friction),
    ):
        a = np.array(default, dtype=float) if given is None else validation.array(given, name)
        if a.ndim == 0:
            a = np.full(model.nv, float(a))
        if a.shape != (model.nv,) or np.any(a < 0.0):
            raise InvalidInputError(f"{name} must be one number or {model.nv} numbers ≥ 0, got shape {a.shape}")
        out[name] = a
    return out


# ====================================================================== the scene
@dataclass
class Scene:
    """A MuJoCo scene of a system (module docstring): the spec, the compiled model and the index maps.

    Attributes:
        system: the :class:`~coop_ga.systems.System`.
        spec: the ``mujoco.MjSpec`` (edit it, then :meth:`recompile`).
        model: the compiled ``mujoco.MjModel``.
        objects: the scene objects.
        floating_base: whether the system's world-fixed part is a free body (:attr:`base_body`).
        base_body: name of that free body (``None`` for a fixed base).
        qpos_index, qvel_index, actuator_index: (nq,) int arrays, Pinocchio q / q̇ / joint index → MuJoCo
            ``qpos`` / ``qvel`` address and actuator id.
        site_ids: (k,) int — the site of each end frame, in ``system.end_frames`` order.
        end_bodies: (k,) int — the MuJoCo body carrying each end frame (whose geoms' contacts are the
            end point's contact force, :meth:`coop_ga.sim.Simulation.end_forces`).
        object_ids: object name → body id; free objects also in ``object_qpos`` / ``object_qvel``
            (name → address of the freejoint's 7 qpos / 6 qvel); mocap objects in ``mocap_index`` (name →
            row of ``data.mocap_pos`` / ``data.mocap_quat``).
        robot_bodies: ids of every MuJoCo body of the robot (static link bodies and the base included).
        excluded: (body, body, reason) of every excluded robot body pair.
        visual_skipped: visual objects left out (their mesh vanished at ``visual_cell``).
        capsules: the robot's :class:`~coop_ga.collision.Capsule` list (empty with ``collision=False``);
        capsule_geoms: (len(capsules),) int — the MuJoCo geom of each capsule (geom ``<link>_capsule<i>``).
    """

    system: Any
    spec: Any
    model: Any
    objects: tuple[SceneObject, ...]
    floating_base: bool
    base_body: str | None
    excluded: list[tuple[str, str, str]]
    visual_skipped: int = 0
    capsules: tuple[Any, ...] = ()
    capsule_geoms: np.ndarray = field(init=False)
    qpos_index: np.ndarray = field(init=False)
    qvel_index: np.ndarray = field(init=False)
    actuator_index: np.ndarray = field(init=False)
    site_ids: np.ndarray = field(init=False)
    end_bodies: np.ndarray = field(init=False)
    object_ids: dict[str, int] = field(init=False)
    object_qpos: dict[str, int] = field(init=False)
    object_qvel: dict[str, int] = field(init=False)
    mocap_index: dict[str, int] = field(init=False)
    robot_bodies: frozenset[int] = field(init=False)

    def __post_init__(self) -> None:
        self._index()

    def __repr__(self) -> str:
        m = self.model
        return (
            f"Scene({self.system.name!r}, nq={self.nq}, bodies={m.nbody}, geoms={m.ngeom}, "
            f"objects={[o.name for o in self.objects]}, floating_base={self.floating_base})"
        )

    # ------------------------------------------------------------------ maps
    def id_of(self, kind: str, name: str) -> int:
        """MuJoCo id of the ``kind`` (``"body"``, ``"joint"``, ``"geom"``, ``"site"``, ``"actuator"``,
        ``"sensor"``, …) called ``name`` — e.g. an end frame's site: ``id_of("site", frame)``; raises
        :class:`UnknownNameError` naming the model if there is none."""
        mj = _mj()
        obj = getattr(mj.mjtObj, f"mjOBJ_{kind.upper()}", None)
        if obj is None:
            raise InvalidInputError(
                f"unknown MuJoCo object kind {kind!r} (body, joint, geom, site, actuator, sensor, …)"
            )
        i = int(mj.mj_name2id(self.model, obj, name))
        if i < 0:
            raise UnknownNameError(f"no {kind} named '{name}' in the MuJoCo model of '{self.system.name}'")
        return i

    def _index(self) -> None:
        m, s = self.model, self.system
        jids = [self.id_of("joint", n) for n in s.joint_names]
        self.qpos_index = np.array([m.jnt_qposadr[j] for j in jids], dtype=np.int64)
        self.qvel_index = np.array([m.jnt_dofadr[j] for j in jids], dtype=np.int64)
        self.actuator_index = np.array([self.id_of("actuator", f"{n}_motor") for n in s.joint_names], dtype=np.int64)
        self.site_ids = np.array([self.id_of("site", f) for f in s.end_frames], dtype=np.int64)
        self.end_bodies = np.array([m.site_bodyid[i] for i in self.site_ids], dtype=np.int64)
        self.object_ids = {o.name: self.id_of("body", o.name) for o in self.objects}
        self.capsule_geoms = np.array(
            [self.id_of("geom", capsule_geom_name(c, i)) for i, c in enumerate(self.capsules)], dtype=np.int64
        )
        self.object_qpos, self.object_qvel = {}, {}
        self.mocap_index = {o.name: int(m.body_mocapid[self.object_ids[o.name]]) for o in self.objects if o.mocap}
        for o in self.objects:
            if o.free:
                j = self.id_of("joint", o.name)
                self.object_qpos[o.name] = int(m.jnt_qposadr[j])
                self.object_qvel[o.name] = int(m.jnt_dofadr[j])
        scene_bodies = set(self.object_ids.values()) | {0}
        self.robot_bodies = frozenset(b for b in range(m.nbody) if b not in scene_bodies)

    @property
    def nq(self) -> int:
        """Number of robot coordinates (= ``system.nq``)."""
        return int(self.system.nq)

    @property
    def base_qpos(self) -> int | None:
        """qpos address of the floating base's freejoint (7 entries), or None for a fixed base."""
        if self.base_body is None:
            return None
        return int(self.model.jnt_qposadr[self.id_of("joint", self.base_body)])

    @property
    def base_qvel(self) -> int | None:
        """qvel address of the floating base's freejoint (6 entries), or None for a fixed base."""
        if self.base_body is None:
            return None
        return int(self.model.jnt_dofadr[self.id_of("joint", self.base_body)])

    def object(self, name: str) -> SceneObject:
        """The scene object called ``name``."""
        for o in self.objects:
            if o.name == name:
                return o
        raise UnknownNameError(f"unknown object '{name}'; objects of the scene: {[o.name for o in self.objects]}")

    # ------------------------------------------------------------------ state
    def set_q(self, data: Any, q: Any, qd: Any = None) -> None:
        """Write the robot configuration q (nq,) [rad or m] (and velocity q̇, default unchanged) into ``data``."""
        qv = validation.configuration(q, self.nq, "q", owner=f"scene of '{self.system.name}'")
        data.qpos[self.qpos_index] = qv
        if qd is not None:
            data.qvel[self.qvel_index] = validation.configuration(qd, self.nq, "qd")

    def q(self, data: Any) -> np.ndarray:
        """Robot configuration (nq,) in Pinocchio's order, read from ``data``."""
        return np.array(data.qpos[self.qpos_index])

    def qd(self, data: Any) -> np.ndarray:
        """Robot velocity (nq,) in Pinocchio's order, read from ``data``."""
        return np.array(data.qvel[self.qvel_index])

    def set_base_pose(self, data: Any, pos: Any, quat: Any = (1.0, 0.0, 0.0, 0.0)) -> None:
        """Place the free base (``floating_base=True``) at ``pos`` (3,) [m] with unit quaternion ``quat``
        (w, x, y, z) in ``data`` (its velocity is left unchanged)."""
        a = self.base_qpos
        if a is None:
            raise InvalidInputError("set_base_pose needs a scene built with floating_base=True")
        q = validation.vector(quat, 4, "quat")
        n = float(np.linalg.norm(q))
        if abs(n - 1.0) > 1e-6:
            raise InvalidInputError(f"quat must be a unit quaternion (w, x, y, z), got norm {n:.6g}")
        data.qpos[a : a + 3] = validation.vector(pos, 3, "pos")
        data.qpos[a + 3 : a + 7] = q / n

    def base_pose(self, data: Any) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,) [m], quaternion (w, x, y, z)) of the free base in ``data``."""
        a = self.base_qpos
        if a is None:
            raise InvalidInputError("base_pose needs a scene built with floating_base=True")
        return np.array(data.qpos[a : a + 3]), np.array(data.qpos[a + 3 : a + 7])

    def make_data(self, q: Any = None, qd: Any = None, base_pose: Any = None) -> Any:
        """A new ``mujoco.MjData`` with the robot at q (default ``system.q0``; a
        :class:`~coop_ga.errors.JointLimitWarning` names joints outside their limits, where MuJoCo's limit
        constraints will push at once), q̇ (default 0), the free base at ``base_pose`` = (pos, quat) (default
        the world origin; ``floating_base=True`` only), the objects at their poses, and ``mj_forward`` done."""
        mj = _mj()
        d = mj.MjData(self.model)
        q0 = self.system.q0 if q is None else self.system.check_q(q)  # warns outside the joint limits
        self.set_q(d, q0, np.zeros(self.nq) if qd is None else qd)
        if base_pose is not None:
            self.set_base_pose(d, *base_pose)
        mj.mj_forward(self.model, d)
        return d

    def contact_name(self, geom: int) -> str:
        """What a contact touches: the name of the geom's body, or of the geom for a world geom (``floor``)."""
        mj = _mj()
        m = self.model
        b = int(m.geom_bodyid[geom])
        if b == 0:
            return str(mj.mj_id2name(m, mj.mjtObj.mjOBJ_GEOM, geom) or "world")
        return str(mj.mj_id2name(m, mj.mjtObj.mjOBJ_BODY, b))

    def penetrations(self, data: Any, tol: float = 1e-3) -> list[tuple[str, str, float]]:
        """(A, B, depth [m]) of every contact in ``data`` (after ``mj_forward``) deeper than ``tol``; A and B
        name bodies (:meth:`contact_name`)."""
        return [
            (self.contact_name(c.geom1), self.contact_name(c.geom2), float(-c.dist))
            for c in data.contact[: data.ncon]
            if -c.dist > tol
        ]

    def check_state(self, data: Any, tol: float = 1e-3) -> None:
        """Raise :class:`InvalidInputError` if anything overlaps by more than ``tol`` [m] in ``data`` (an
        object inside a robot or below the floor, a link in the floor): the simulation would start with
        an explosive contact.  Call after ``mj_forward`` (``make_data`` does it)."""
        bad = self.penetrations(data, tol)
        if bad:
            listing = "; ".join(f"{a} – {b}: {1e3 * d:.1f} mm" for a, b, d in bad[:8])
            raise InvalidInputError(
                f"the initial state of the scene of '{self.system.name}' has {len(bad)} overlapping contact(s) "
                f"deeper than {1e3 * tol:g} mm ({listing}); move the object (its pos=/quat=), start the robot at "
                "another q, or move the floor (floor=height, or floor=None)"
            )

    # ------------------------------------------------------------------ model
    def recompile(self) -> Scene:
        """A new :class:`Scene` compiled from :attr:`spec` after you edited it (e.g. added sensors)."""
        return Scene(
            self.system,
            self.spec,
            _compile(self.spec),
            self.objects,
            self.floating_base,
            self.base_body,
            self.excluded,
            self.visual_skipped,
            self.capsules,
        )

    def to_xml(self) -> str:
        """The MJCF text of :attr:`model` (full precision, meshes inline; :mod:`coop_ga.sim.mjcf`)."""
        return to_xml(self.spec)

    def write_model(self, path: Any) -> str:
        """Write :meth:`to_xml` to ``path`` and check that it loads back into :attr:`model` bit for bit
        (:func:`coop_ga.sim.mjcf.check_reload`); raises :class:`CoopGAError` if not.  Returns the text."""
        from pathlib import Path

        xml = self.to_xml()
        bad = check_reload(self.model, xml)
        if bad:
            raise CoopGAError(
                f"the MJCF of the scene does not reproduce the compiled model (fields {bad}): MuJoCo's XML writer "
                "lost precision; the log would not replay — report this with your mujoco version"
            )
        Path(path).write_text(xml)
        return xml


def _compile(spec: Any) -> Any:
    try:
        return spec.compile()
    except ValueError as e:
        raise InvalidInputError(f"MuJoCo could not compile the scene: {e}") from e


def build_scene(
    system: Any,
    *,
    objects: Sequence[SceneObject] = (),
    floor: float | None = 0.0,
    collision: bool = True,
    capsules: Sequence[Any] | None = None,
    self_collision: bool = True,
    robot_friction: Any = ROBOT_FRICTION,
    visuals: bool = True,
    visual_cell: float = 0.003,
    armature: Any = None,
    damping: Any = None,
    frictionloss: Any = None,
    floating_base: bool = False,
    timestep: float = 1e-3,
    integrator: str = "implicitfast",
    name: str | None = None,
) -> Scene:
    """Build the MuJoCo scene of ``system`` (module docstring).

    Args:
        system: a :class:`~coop_ga.systems.System` (registered, ``from_urdf`` or ``from_model``).
        objects: :class:`~coop_ga.sim.objects.Box` / ``Ball`` / ``Cylinder`` instances (unique names).
        floor: height [m] of the floor plane, or None for no floor.
        collision: give the robot collision capsules (False: the robot touches nothing).
        capsules: the robot's :class:`~coop_ga.collision.Capsule` list (default: ``fit_capsules(system)``).
        self_collision: let robot links collide with each other (pairs as in ``CollisionModel``).
        robot_friction: friction of the robot's geoms (one number or (sliding, torsional, rolling)).
        visuals: add the visual geometry of ``system.visual_model()``.
        visual_cell: decimation cell [m] of visual meshes (``coop_ga.viz.mesh.decimate``; 0 = full meshes).
        armature: per-joint armature (one number or (nq,)); None = ``model.armature``.
        damping: per-joint damping (one number or (nq,)); None = the URDF's ``damping``.
        frictionloss: per-joint friction loss (one number or (nq,)); None = the URDF's ``friction``.
        floating_base: the world-fixed part of the system becomes a free body (module docstring).
        timestep: physics step Δt [s] (1 ms).
        integrator: ``"implicitfast"`` (default), ``"euler"`` (semi-implicit Euler; the scheme of
            :func:`coop_ga.control.simulate_impedance`), ``"implicit"`` or ``"rk4"``.
        name: model name (default: the system's).

    Returns:
        :class:`Scene`.

    Raises:
        InvalidInputError: a joint type MuJoCo cannot take, a massless moving body, collision geometry
            that cannot be built, duplicate object names, a bad option.
    """
    validation.nonnegative(visual_cell, "visual_cell")
    fr = friction(robot_friction, "robot_friction")
    if floor is not None:
        floor = validation.scalar(floor, "floor")
    objects = tuple(objects)
    if not all(isinstance(o, SceneObject) for o in objects):
        raise InvalidInputError("objects must be coop_ga.sim Box, Ball or Cylinder instances")
    spec = _new_spec(name or system.name, timestep, integrator, system.model.gravity.linear)
    root, base_name = spec.worldbody, None
    if floating_base:
        root, base_name = _floating_root(spec, system)
    att = _add_joint_bodies(root, system, _joint_dynamics(system.model, armature, damping, frictionloss))
    _add_sites(system.model, att, system.end_frames)
    _add_actuators(spec, system)
    excluded: list[tuple[str, str, str]] = []
    caps: tuple[Any, ...] = ()
    if collision:
        caps = _capsules(system, capsules)
        bodies = _add_capsules(spec, root, system, att, caps, fr)
        excluded = _add_excludes(spec, system, caps, bodies, self_collision, fr)
    skipped = _add_visuals(spec, root, system, att, float(visual_cell)) if visuals else 0
    _add_world(spec, floor)
    add_objects(spec, objects, {b.name for b in spec.bodies})
    return Scene(system, spec, _compile(spec), objects, bool(floating_base), base_name, excluded, skipped, caps)


def _new_spec(name: str, timestep: float, integrator: str, gravity: Any) -> Any:
    """An empty ``MjSpec``: SI units and radians, inertias only where given, the step and the integrator."""
    mj = _mj()
    spec = mj.MjSpec()
    spec.modelname = name
    spec.compiler.inertiafromgeom = mj.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.autolimits = False
    spec.compiler.degree = False  # joint ranges in radians (MjSpec's compiler defaults to degrees)
    spec.option.timestep = validation.positive(timestep, "timestep")
    spec.option.integrator = getattr(
        mj.mjtIntegrator, INTEGRATORS[validation.choice(integrator, tuple(INTEGRATORS), "integrator")]
    )
    spec.option.gravity = np.asarray(gravity, float)
    return spec


def _floating_root(spec: Any, system: Any) -> tuple[Any, str]:
    """The free base body: carries ``model.inertias[0]`` (links fixed to the universe), named after the
    first BODY frame fixed to the world (e.g. ``base_link``)."""
    import pinocchio as pin

    model = system.model
    I0 = model.inertias[0]
    fixed = [f.name for f in model.frames if int(f.parentJoint) == 0 and f.type == pin.FrameType.BODY]
    if I0.mass < _MASSLESS:
        raise InvalidInputError(
            f"floating_base=True: the part of system '{system.name}' fixed to the world has no mass; a free body "
            "needs one (give the base link an <inertial> in the URDF)"
        )
    name = f"{fixed[0]}_free" if fixed else "base_free"
    body = spec.worldbody.add_body(name=name)
    body.add_freejoint(name=name)
    set_inertial(body, I0.mass, I0.lever, I0.inertia, f"the world-fixed part of system '{system.name}'")
    return body, name
