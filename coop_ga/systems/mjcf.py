"""MJCF input: a MuJoCo model description (``.xml``) as a Pinocchio model and a :class:`~coop_ga.systems.System`.

MuJoCo compiles the file (``mujoco.MjModel.from_xml_path``: defaults classes, ``<compiler angle>``, ``euler``
sequences, ``fromto``, includes, inertias from geoms are all resolved by MuJoCo itself), and
:func:`model_from_mjcf` walks the compiled bodies into a ``pinocchio.Model``:

* every **hinge** joint becomes a revolute joint (``RX``/``RY``/``RZ`` for a coordinate axis, else
  ``RevoluteUnaligned``), every **slide** joint a prismatic one, added in MuJoCo's joint order, so
  Pinocchio's ``q`` is MuJoCo's ``qpos`` entry for entry.  A joint's anchor ``jnt_pos`` and its
  reference value ``ref`` (the ``qpos`` of the pose written in the file) go into the joint placement:
  a body carrying joints ``k = 1…n`` sits at ``X · Π_k T(p_k) R_k(q_k − ref_k) T(−p_k)`` in its parent
  (``X``: ``body_pos``, ``body_quat``), as MuJoCo's ``mj_kinematics`` composes it;
* a body without joints is welded to its parent's joint (a BODY frame, its inertia lumped in);
* frames: one BODY frame per body, a JOINT frame per joint, an OP_FRAME per ``<site>`` (named like
  the MuJoCo element; unnamed elements get ``body<i>``/``joint<i>``/``site<i>``);
* inertias (``body_mass``, ``body_ipos``, ``body_iquat``, ``body_inertia``), position limits
  (``range`` of a limited joint, else unbounded), ``armature``, ``damping``, ``frictionloss``,
  efforts (``actfrcrange``, else the ``forcerange`` × gear of a force-limited actuator on the joint)
  and gravity are copied;
* the visual geometry (:func:`from_mjcf`): MuJoCo's geoms as coal shapes and meshes at their pose in the body.

MuJoCo has no velocity limits (they get :data:`~coop_ga.systems.limits.DEFAULT_VELOCITY_LIMIT`).  Tendons,
equality constraints and actuators' dynamics are not part of a kinematic model and are not read.
A **free joint** (``<freejoint/>``, on a body of the world) becomes a free flyer (``JointModelFreeFlyer``: 7
coordinates, 6 velocities, nq ≠ nv; see :mod:`coop_ga.systems.system`): its placement is the identity, as
MuJoCo puts the body at the pose in ``qpos``.  Its quaternion is ``w x y z`` in MuJoCo's ``qpos`` and ``x y z w``
in Pinocchio's q: :func:`q_from_qpos` and :func:`qpos_from_q` convert (every other entry is the same), and
:func:`v_from_qvel` the velocities (MuJoCo's free-joint ``qvel`` is the world-frame linear velocity and the local
angular velocity, Pinocchio's v both in the local frame).  **Ball joints are refused**
(:class:`~coop_ga.errors.UnsupportedJointError`): replace one by three hinges.

Why not ``pinocchio.buildModelFromMJCF``: Pinocchio 4.1's parser reads only the first body tree under
``<worldbody>`` (the three Frankas of a ``coop_ga.sim`` scene give a 7-joint model), drops that body's
pose, converts a slide joint's ``range`` as an angle under ``<compiler angle="degree">`` and shifts a
hinge's range by its ``ref`` — FK and limits that disagree with MuJoCo on the same file.  MuJoCo is the
reference reader of its own format; ``tests/systems/test_mjcf.py`` checks the model built here
against MuJoCo's ``xpos``/``xmat``, ``site_xpos``, ``jnt_range`` and ``mj_fullM``.

MuJoCo is an optional dependency (the ``sim`` extra): ``pip install 'coop_ga[sim]'``.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CoopGAError, InvalidInputError, UnknownNameError, UnsupportedJointError
from .points import EndPoint
from .system import System, VisualSource, _default_q0, _path, from_model, resolve_locked

__all__ = ["from_mjcf", "model_from_mjcf", "q_from_qpos", "qpos_from_q", "v_from_qvel"]

_AXES = {(1.0, 0.0, 0.0): "RX", (0.0, 1.0, 0.0): "RY", (0.0, 0.0, 1.0): "RZ"}


def _mujoco() -> Any:
    try:
        return importlib.import_module("mujoco")
    except ImportError as e:
        raise CoopGAError(f"reading MJCF needs MuJoCo ({e}); install it with: pip install 'coop_ga[sim]'") from e


def _compile(path: Any) -> Any:
    """``mujoco.MjModel`` of an MJCF file, with an :class:`InvalidInputError` for a missing or unreadable file."""
    mj = _mujoco()
    p = _path(path, "mjcf_path")
    if not p.is_file():
        raise InvalidInputError(f"mjcf_path: MJCF file not found: {p}" + (" (a folder)" if p.is_dir() else ""))
    try:
        return mj.MjModel.from_xml_path(str(p))
    except ValueError as e:
        raise InvalidInputError(f"mjcf_path: {p} is not an MJCF file MuJoCo can compile ({e})") from None


def _name(mm: Any, kind: str, i: int) -> str:
    n = str(getattr(mm, kind)(i).name)
    return n or f"{kind}{i}"


def _se3(pos: Any, quat: Any) -> Any:
    """``pinocchio.SE3`` from a MuJoCo position and (w, x, y, z) quaternion."""
    import pinocchio as pin

    w, x, y, z = (float(v) for v in quat)
    return pin.SE3(pin.Quaternion(w, x, y, z).normalized().matrix(), np.asarray(pos, dtype=float))


def _joint_model(mm: Any, j: int) -> Any:
    """Pinocchio joint model of MuJoCo joint ``j`` (hinge, slide or free); refuses ball joints."""
    import pinocchio as pin

    mj = _mujoco()
    t = int(mm.jnt_type[j])
    if t == int(mj.mjtJoint.mjJNT_FREE):
        if int(mm.body_parentid[mm.jnt_bodyid[j]]) != 0:
            raise UnsupportedJointError(
                f"MJCF joint '{_name(mm, 'joint', j)}' is a free joint on a body that is not a child of the world; "
                "coop_ga reads a free joint as a floating base only"
            )
        return pin.JointModelFreeFlyer()
    if t == int(mj.mjtJoint.mjJNT_BALL):
        raise UnsupportedJointError(
            f"MJCF joint '{_name(mm, 'joint', j)}' is a ball joint; coop_ga reads hinge, slide and free joints: "
            "replace a ball joint by three hinges"
        )
    axis = np.asarray(mm.jnt_axis[j], dtype=float)
    key = tuple(float(a) for a in axis)
    revolute = t == int(mj.mjtJoint.mjJNT_HINGE)
    if key in _AXES:
        return getattr(pin, f"JointModel{_AXES[key] if revolute else 'P' + _AXES[key][1]}")()
    return pin.JointModelRevoluteUnaligned(axis) if revolute else pin.JointModelPrismaticUnaligned(axis)


def _ref_motion(mm: Any, j: int) -> Any:
    """The joint's motion at q = 0 relative to the file's pose: R(axis, −ref) or T(−ref · axis)."""
    import pinocchio as pin

    ref = float(mm.qpos0[mm.jnt_qposadr[j]])
    axis = np.asarray(mm.jnt_axis[j], dtype=float)
    if int(mm.jnt_type[j]) == int(_mujoco().mjtJoint.mjJNT_HINGE):
        return pin.SE3(pin.AngleAxis(-ref, axis).matrix(), np.zeros(3))
    return pin.SE3(np.eye(3), -ref * axis)


def _efforts(mm: Any) -> np.ndarray:
    """Per-joint effort bound [N m or N]: ``actfrcrange``, else ``forcerange`` × |gear| of force-limited
    actuators driving the joint, else inf."""
    mj = _mujoco()
    eff = np.full(mm.njnt, np.inf)
    for a in range(mm.nu):
        if int(mm.actuator_trntype[a]) == int(mj.mjtTrn.mjTRN_JOINT) and mm.actuator_forcelimited[a]:
            j = int(mm.actuator_trnid[a, 0])
            bound = float(np.max(np.abs(mm.actuator_forcerange[a]))) * abs(float(mm.actuator_gear[a, 0]))
            eff[j] = bound if not np.isfinite(eff[j]) else max(eff[j], bound)
    lim = np.asarray(mm.jnt_actfrclimited, dtype=bool)
    eff[lim] = np.max(np.abs(mm.jnt_actfrcrange[lim]), axis=1)
    return eff


def _add_joints(model: Any, mm: Any, b: int, parent: int, placement: Any, eff: np.ndarray) -> tuple[int, Any]:
    """Add body ``b``'s joints to ``model`` after joint ``parent`` (``placement``: body frame ``X`` in that
    joint's frame); returns the last joint and the body frame's placement in it."""
    import pinocchio as pin

    big = np.finfo(float).max
    pre = placement
    if int(mm.body_jntnum[b]) == 1 and int(mm.jnt_type[mm.body_jntadr[b]]) == int(_mujoco().mjtJoint.mjJNT_FREE):
        return _add_free_joint(model, mm, int(mm.body_jntadr[b]), parent, eff), pin.SE3.Identity()
    for j in range(int(mm.body_jntadr[b]), int(mm.body_jntadr[b]) + int(mm.body_jntnum[b])):
        anchor = pin.SE3(np.eye(3), np.asarray(mm.jnt_pos[j], dtype=float))
        lo, hi = (float(mm.jnt_range[j, 0]), float(mm.jnt_range[j, 1])) if mm.jnt_limited[j] else (-big, big)
        parent = model.addJoint(
            parent,
            _joint_model(mm, j),
            pre * anchor * _ref_motion(mm, j),
            _name(mm, "joint", j),
            np.array([eff[j]]),
            np.array([big]),
            np.array([lo]),
            np.array([hi]),
        )
        d = int(mm.jnt_dofadr[j])
        model.armature[model.idx_vs[parent]] = mm.dof_armature[d]
        model.damping[model.idx_vs[parent]] = mm.dof_damping[d]
        model.friction[model.idx_vs[parent]] = mm.dof_frictionloss[d]
        model.addJointFrame(parent)
        pre = anchor.inverse()
    return parent, pre


def _add_free_joint(model: Any, mm: Any, j: int, parent: int, eff: np.ndarray) -> int:
    """Add MuJoCo free joint ``j`` as a free flyer at the identity (MuJoCo puts its body at the qpos pose)."""
    import pinocchio as pin

    big = np.finfo(float).max
    jid = model.addJoint(
        parent, _joint_model(mm, j), pin.SE3.Identity(), _name(mm, "joint", j),
        np.full(6, eff[j]), np.full(6, big), np.full(7, -big), np.full(7, big),
    )  # fmt: skip
    d = int(mm.jnt_dofadr[j])
    for name, src in (("armature", mm.dof_armature), ("damping", mm.dof_damping), ("friction", mm.dof_frictionloss)):
        getattr(model, name)[model.idx_vs[jid] : model.idx_vs[jid] + 6] = src[d : d + 6]
    model.addJointFrame(jid)
    return jid


def _free_flyers(model: Any) -> list[int]:
    """q indices of the free flyers of a Pinocchio model."""
    return [
        int(model.idx_qs[j]) for j in range(1, model.njoints) if model.joints[j].shortname() == "JointModelFreeFlyer"
    ]


def q_from_qpos(model: Any, qpos: Any) -> np.ndarray:
    """Pinocchio's q (nq,) of :func:`model_from_mjcf`'s model from MuJoCo's ``qpos``: the same entries, a free
    joint's quaternion reordered from w x y z to x y z w."""
    q = np.array(qpos, dtype=float)
    for i in _free_flyers(model):
        q[i + 3 : i + 7] = np.roll(q[i + 3 : i + 7], -1)
    return q


def qpos_from_q(model: Any, q: Any) -> np.ndarray:
    """MuJoCo's ``qpos`` from Pinocchio's q (:func:`q_from_qpos`'s inverse)."""
    qpos = np.array(q, dtype=float)
    for i in _free_flyers(model):
        qpos[i + 3 : i + 7] = np.roll(qpos[i + 3 : i + 7], 1)
    return qpos


def v_from_qvel(model: Any, q: Any, qvel: Any) -> np.ndarray:
    """Pinocchio's v (nv,) from MuJoCo's ``qvel`` at Pinocchio's q: a free joint's linear velocity is rotated from
    the world frame into the body frame (``Rᵀ v``; its angular velocity is local in both), the rest is the same."""
    import pinocchio as pin

    v = np.array(qvel, dtype=float)
    qa = np.asarray(q, dtype=float)
    for j in range(1, model.njoints):
        if model.joints[j].shortname() == "JointModelFreeFlyer":
            iq, iv = int(model.idx_qs[j]), int(model.idx_vs[j])
            R = pin.Quaternion(qa[iq + 6], qa[iq + 3], qa[iq + 4], qa[iq + 5]).normalized().matrix()
            v[iv : iv + 3] = R.T @ v[iv : iv + 3]
    return v


def _body_inertia(mm: Any, b: int) -> Any:
    """``pinocchio.Inertia`` of MuJoCo body ``b`` in its body frame."""
    import pinocchio as pin

    R = _se3(np.zeros(3), mm.body_iquat[b]).rotation
    return pin.Inertia(
        float(mm.body_mass[b]), np.asarray(mm.body_ipos[b], dtype=float), R @ np.diag(mm.body_inertia[b]) @ R.T
    )


def model_from_mjcf(mjcf_path: str | Path) -> Any:
    """A ``pinocchio.Model`` of an MJCF file, compiled by MuJoCo (module docstring).

    ``q`` of the model is MuJoCo's ``qpos`` (same order and meaning, ``ref`` included), except a free joint's
    quaternion order (:func:`q_from_qpos`).  Raises
    :class:`~coop_ga.errors.UnsupportedJointError` for a ball joint, :class:`InvalidInputError`
    for a missing or invalid file, :class:`~coop_ga.errors.CoopGAError` without MuJoCo.
    """
    model = _build(_compile(mjcf_path))
    model.name = Path(str(mjcf_path)).stem
    return model


def _build(mm: Any) -> Any:
    """:func:`model_from_mjcf` of a compiled ``mujoco.MjModel``."""
    import pinocchio as pin

    model = pin.Model()
    model.gravity = pin.Motion(np.asarray(mm.opt.gravity, dtype=float), np.zeros(3))
    eff = _efforts(mm)
    # where body b's frame is: (its joint, its placement in that joint, its BODY frame id)
    where: dict[int, tuple[int, Any, int]] = {0: (0, pin.SE3.Identity(), 0)}
    for b in range(1, mm.nbody):  # MuJoCo orders bodies depth-first: a parent before its children
        pj, pM, pf = where[int(mm.body_parentid[b])]
        X = pM * _se3(mm.body_pos[b], mm.body_quat[b])
        jid, M = _add_joints(model, mm, b, pj, X, eff) if mm.body_jntnum[b] else (pj, X)
        model.appendBodyToJoint(jid, _body_inertia(mm, b), M)
        parent_frame = model.nframes - 1 if mm.body_jntnum[b] else pf
        fid = model.addFrame(pin.Frame(_name(mm, "body", b), jid, parent_frame, M, pin.FrameType.BODY))
        where[b] = (jid, M, fid)
    for s in range(mm.nsite):
        jid, M, fid = where[int(mm.site_bodyid[s])]
        placement = M * _se3(mm.site_pos[s], mm.site_quat[s])
        model.addFrame(pin.Frame(_name(mm, "site", s), jid, fid, placement, pin.FrameType.OP_FRAME))
    return model


def _keyframe_q(mm: Any, keyframe: Any) -> np.ndarray:
    """``qpos`` of the keyframe named ``keyframe``, or ``qpos0`` for None."""
    if keyframe is None:
        return np.array(mm.qpos0, dtype=float)
    if not isinstance(keyframe, str):
        raise InvalidInputError(f"keyframe must be the name of a <key> of the MJCF file, got {keyframe!r}")
    keys = [str(mm.key(k).name) for k in range(mm.nkey)]
    if keyframe not in keys:
        raise UnknownNameError(f"unknown keyframe {keyframe!r}; the file's keyframes: {keys or 'none'}")
    return np.array(mm.key_qpos[keys.index(keyframe)], dtype=float)


def _shape(mm: Any, g: int) -> Any:
    """A coal shape for MuJoCo geom ``g`` (sizes are MuJoCo's half-lengths), or None (plane, height field, SDF)."""
    coal = importlib.import_module("coal")  # ships with the pin wheels; untyped

    mj = _mujoco()
    t, size = int(mm.geom_type[g]), np.asarray(mm.geom_size[g], dtype=float)
    T = mj.mjtGeom
    if t == int(T.mjGEOM_SPHERE):
        return coal.Sphere(size[0])
    if t == int(T.mjGEOM_BOX):
        return coal.Box(*(2.0 * size))
    if t == int(T.mjGEOM_ELLIPSOID):
        return coal.Ellipsoid(*size)
    if t in (int(T.mjGEOM_CAPSULE), int(T.mjGEOM_CYLINDER)):
        return (coal.Capsule if t == int(T.mjGEOM_CAPSULE) else coal.Cylinder)(size[0], 2.0 * size[1])
    if t != int(T.mjGEOM_MESH):
        return None
    m = int(mm.geom_dataid[g])
    va, vn, fa, fn = (int(x[m]) for x in (mm.mesh_vertadr, mm.mesh_vertnum, mm.mesh_faceadr, mm.mesh_facenum))
    bvh = coal.BVHModelOBBRSS()
    bvh.beginModel(fn, vn)
    bvh.addVertices(np.asarray(mm.mesh_vert[va : va + vn], dtype=float))
    bvh.addTriangles(np.asarray(mm.mesh_face[fa : fa + fn], dtype=np.int64))
    bvh.endModel()
    return bvh


def _geometry(mm: Any, model: Any) -> Any:
    """The visual ``pinocchio.GeometryModel`` of a compiled MJCF on :func:`model_from_mjcf`'s model: the geoms that
    collide with nothing (``contype = conaffinity = 0``, MuJoCo's visual-only convention), or every geom when the
    file has none of those; planes, height fields and SDFs are left out."""
    import pinocchio as pin

    visual = (np.asarray(mm.geom_contype) == 0) & (np.asarray(mm.geom_conaffinity) == 0)
    chosen = np.flatnonzero(visual) if visual.any() else np.arange(mm.ngeom)
    out = pin.GeometryModel()
    for g in chosen:
        shape = _shape(mm, int(g))
        if shape is None:
            continue
        b = int(mm.geom_bodyid[g])
        fid = model.getFrameId(_name(mm, "body", b), pin.FrameType.BODY) if b else 0
        f = model.frames[fid]
        obj = pin.GeometryObject(
            _name(mm, "geom", int(g)), f.parentJoint, fid, f.placement * _se3(mm.geom_pos[g], mm.geom_quat[g]), shape
        )
        mat = int(mm.geom_matid[g])
        obj.meshColor = np.asarray(mm.mat_rgba[mat] if mat >= 0 else mm.geom_rgba[g], dtype=float)
        out.addGeometryObject(obj)
    return out


def from_mjcf(
    mjcf_path: str | Path,
    end_frames: Sequence[str | EndPoint],
    locked_joints: Sequence[str] = (),
    *,
    name: str | None = None,
    q0: Any = None,
    keyframe: str | None = None,
    q_lock: Any = None,
    groups: Mapping[str, Any] | None = None,
    active: Sequence[str] | None = None,
    visuals: bool = True,
) -> System:
    """Build a system from an MJCF file (hinge and slide joints, a free joint as a floating base), read through
    MuJoCo.  With a free joint, ``q0``/``q_lock`` are Pinocchio's q (quaternion x y z w, :func:`q_from_qpos`).

    The counterpart of :func:`~coop_ga.systems.from_urdf`.  ``end_frames``: body or ``<site>`` names
    (one per chain), or :class:`~coop_ga.systems.points.EndPoint` entries on a body.  ``locked_joints`` are removed at ``q_lock`` (full ``qpos``, default: the file's
    ``qpos0``, i.e. every joint at its ``ref``).  ``q0``: the system's nominal q (after locking);
    ``keyframe``: the name of a ``<key>`` whose ``qpos`` gives ``q_lock`` and (for the kept joints)
    ``q0`` instead; by default q0 is ``qpos0`` moved strictly inside the limits.  ``groups``/``active``:
    named control groups instead of ``locked_joints`` (:func:`~coop_ga.systems.from_model`).  ``visuals``: the
    file's visual-only geoms (``contype = conaffinity = 0``; every geom if it has none) as the system's visual
    geometry (boxes, spheres, capsules, cylinders, ellipsoids and meshes, as MuJoCo compiled them).

    Example::

        sys = coop_ga.systems.from_mjcf("panda.xml", ["left_tip", "right_tip"], locked_joints=["finger_joint1"])

    Raises the errors of :func:`model_from_mjcf` and :func:`~coop_ga.systems.from_model`.
    """
    p = _path(mjcf_path, "mjcf_path")
    if name is not None and (not isinstance(name, str) or not name):
        raise InvalidInputError(f"name must be a non-empty string (or None: the file's stem), got {name!r}")
    if keyframe is not None and (q0 is not None or q_lock is not None):
        raise InvalidInputError("give either keyframe= or q0=/q_lock=, not both")
    mm = _compile(p)
    full = _build(mm)
    qpos0 = q_from_qpos(full, _keyframe_q(mm, keyframe))
    locked = resolve_locked(full, locked_joints, groups, active)
    if q0 is None:
        start = qpos0 if keyframe is not None else _default_q0(full, qpos0)
        q0 = np.concatenate(
            [[]]
            + [
                start[full.idx_qs[j] : full.idx_qs[j] + full.nqs[j]]
                for j in range(1, full.njoints)
                if full.names[j] not in locked
            ]
        )
    return from_model(
        full,
        end_frames,
        name=name or p.stem,
        q0=q0,
        locked_joints=locked,
        q_lock=qpos0 if q_lock is None else q_lock,
        description=f"from MJCF {p}",
        visuals=(VisualSource(geometry=_geometry(mm, full), model=full),) if visuals else (),
    )
