"""Trajectories to play back: what the experiments and the physics simulations write, read into one form.

:func:`load_recording` reads

* **an experiment's NPZ** (``trajectory.npz``, ``trajectories.npz``, ``session.npz``, ``paths.npz`` of
  ``experiments/*.py``): the system and primitive kind from ``metrics.json`` next to it (keys ``system``,
  ``kind``; or the ``system=`` / ``kind=`` arguments); the trajectories are the 2-D arrays with one column
  per joint whose name is ``q``, ends in ``_q`` / ``_trajectory`` or starts with ``q_`` / ``arm_q``
  (``key=`` picks one, default ``q``, else the first in alphabetical order; the others are listed in
  :attr:`Recording.alternatives`); the time from ``t`` or ``<prefix>_t`` of the same length, else
  ``metrics['dt_s']`` (else 0.01 s, Eq 61) per row; a target similarity from ``target_versor`` /
  ``target`` of 12 coefficients, a target point from a ``target`` of 3.  Special layouts: the hexapod's
  ``q`` (T, 18) with ``body`` (T, 7) (position, unit quaternion xyzw) is played on the floating hexapod
  ``load("hexapod", free_flyer=True)`` (q = ``[body, q_legs]`` (T, 25), the quaternion as it is);
  ``arm_q_*`` of ``potential_field`` on the ``arm5`` URDF;
* **a physics log** of :mod:`coop_ga.sim` (a folder, or its ``log.npz``, with ``model.xml`` and
  ``metrics.json``): q = ``qpos[:, qpos_index]`` on the system named in ``metrics.json``; a floating base
  (a free joint whose body is not an object) poses the robot's root (:attr:`Recording.base`) — for the
  ``hexapod`` it is the body of the floating hexapod instead: q = ``[position, quaternion xyzw, legs]`` (T, 25)
  on ``load("hexapod", free_flyer=True)``, no base; each free object
  (``object_bodies``) is read from ``model.xml`` as its geoms (box, sphere, cylinder, capsule sizes and
  colours) and posed per frame by MuJoCo's forward kinematics (needs ``mujoco``: the ``sim`` extra).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from ..geometry.groups import Similarity
from .drawing import BodyShape

__all__ = ["DEFAULT_DT", "BodyTrack", "Recording", "load_recording", "trajectory_keys"]

#: time step [s] assumed when a file has no time (Eq 61: Δt = 0.01 s)
DEFAULT_DT = 0.01


@dataclass
class BodyTrack:
    """A free body of a physics log: its shapes and its world pose per frame (positions (T, 3) [m],
    quaternions (T, 4) wxyz)."""

    name: str
    shapes: list[BodyShape]
    positions: np.ndarray
    wxyz: np.ndarray


@dataclass
class Recording:
    """A trajectory ready to play.

    system: the :class:`~coop_ga.systems.System`; q: (T, nq) [rad | m]; t: (T,) [s]; kind: the cooperative
    primitive kind (None: no primitive); target: a target :class:`~coop_ga.Similarity` (or None);
    target_point: a target point (3,) [m] (or None); base: (T, 4, 4) world poses of the system's root (None:
    fixed); bodies: free objects; source: where it came from; key: the trajectory's array name;
    alternatives: the other trajectories of the file.
    """

    system: Any
    q: np.ndarray
    t: np.ndarray
    kind: str | None = None
    target: Similarity | None = None
    target_point: np.ndarray | None = None
    base: np.ndarray | None = None
    bodies: list[BodyTrack] = field(default_factory=list)
    source: str = ""
    key: str = "q"
    alternatives: tuple[str, ...] = ()


def _system(system: Any) -> Any:
    from .. import systems

    if isinstance(system, str):
        return systems.load(system)
    if not hasattr(system, "model") or not hasattr(system, "nq"):
        raise InvalidInputError(f"system must be a registered name or a coop_ga System, got {type(system).__name__}")
    return system


def _metrics(folder: Path) -> dict[str, Any]:
    f = folder / "metrics.json"
    if not f.is_file():
        return {}
    try:
        out = json.loads(f.read_text())
    except (OSError, ValueError) as e:
        raise InvalidInputError(f"{f}: not readable JSON ({e})") from None
    return out if isinstance(out, dict) else {}


def load_recording(
    path: str | Path, *, key: str | None = None, system: Any = None, kind: str | None = None
) -> Recording:
    """Read an experiment's NPZ or a physics log (module docstring).

    Args:
        path: an ``.npz`` file, or a physics run folder (``log.npz`` + ``model.xml`` + ``metrics.json``).
        key: the trajectory array to play (default ``q``, else the first trajectory found).
        system: a registered system name or a System (default: from ``metrics.json``).
        kind: the cooperative primitive kind to draw (default: ``metrics.json``'s ``kind``; ``"none"``: none).

    Returns:
        A :class:`Recording`.

    Raises:
        InvalidInputError: a missing or unreadable file, no trajectory in it, no system known, a key that is not
            a trajectory of the file.
    """
    p = Path(path)
    if p.is_dir():
        if not (p / "log.npz").is_file():
            raise InvalidInputError(f"{p} is a folder without log.npz; give an .npz file or a physics run folder")
        p = p / "log.npz"
    if not p.is_file():
        raise InvalidInputError(f"{p}: no such file")
    try:
        data = dict(np.load(p, allow_pickle=False))
    except (OSError, ValueError) as e:
        raise InvalidInputError(f"{p}: not a readable .npz ({e})") from None
    metrics = _metrics(p.parent)
    if kind is None:
        kind = metrics.get("kind") if isinstance(metrics.get("kind"), str) else None
    elif kind == "none":
        kind = None
    if "qpos" in data and (p.parent / "model.xml").is_file():
        rec = _physics(p, data, metrics, system)
    else:
        rec = _experiment(p, data, metrics, key, system)
    rec.kind = kind
    return rec


# ====================================================================== experiments
def trajectory_keys(data: dict[str, np.ndarray], nq: int | None = None) -> list[str]:
    """Names of the trajectory arrays of an NPZ (2-D, ≥ 2 rows, ``nq`` columns if given; module docstring)."""

    def named(k: str) -> bool:
        return k == "q" or k.endswith(("_q", "_trajectory")) or k.startswith(("q_", "arm_q"))

    out = [k for k, a in data.items() if named(k) and a.ndim == 2 and a.shape[0] >= 2 and a.dtype.kind == "f"]
    if nq is not None:
        out = [k for k in out if data[k].shape[1] == nq]
    return sorted(out, key=lambda k: (k != "q", k))


def _pick(keys: list[str], key: str | None, p: Path) -> str:
    if not keys:
        raise InvalidInputError(f"{p}: no trajectory array (a (T, nq) array named q, *_q or *_trajectory)")
    if key is None:
        return keys[0]
    if key not in keys:
        raise InvalidInputError(f"{p}: {key!r} is not a trajectory of this file; trajectories: {keys}")
    return key


def _experiment(
    p: Path, data: dict[str, np.ndarray], metrics: dict[str, Any], key: str | None, system: Any
) -> Recording:
    if system is None and "body" in data and data.get("q", np.zeros((0, 0))).shape[1:] == (18,):
        return _hexapod(p, data, metrics)
    keys = trajectory_keys(data)
    if system is None:
        if isinstance(metrics.get("system"), str):
            system = metrics["system"]
        elif keys and all(k.startswith("arm_q") for k in keys):
            system = _arm5()
        else:
            raise InvalidInputError(f"{p}: no metrics.json naming the system next to it; pass system= (or --system)")
    sys_ = _system(system)
    keys = trajectory_keys(data, sys_.nq)
    k = _pick(keys, key, p)
    Q = validation.array(data[k], k)
    return Recording(
        sys_,
        Q,
        _time(data, k, len(Q), metrics),
        target=_target(data),
        target_point=_target_point(data),
        source=str(p),
        key=k,
        alternatives=tuple(x for x in keys if x != k),
    )


def _time(data: dict[str, np.ndarray], key: str, T: int, metrics: dict[str, Any]) -> np.ndarray:
    prefix = key.removesuffix("_trajectory").removesuffix("_q")
    for tk in (f"{prefix}_t", "t"):
        t = data.get(tk)
        if t is not None and t.shape == (T,) and np.all(np.isfinite(t)):
            return np.asarray(t, float)
    dt = metrics.get("dt_s")
    dt = float(dt) if isinstance(dt, (int, float)) and dt > 0 else DEFAULT_DT
    return dt * np.arange(T)


def _target(data: dict[str, np.ndarray]) -> Similarity | None:
    for k in ("target_versor", "target"):
        v = data.get(k)
        if v is not None and v.shape == (12,):
            return Similarity.from_coeffs(v)
    return None


def _target_point(data: dict[str, np.ndarray]) -> np.ndarray | None:
    v = data.get("target")
    return np.asarray(v, float) if v is not None and v.shape == (3,) else None


def _hexapod(p: Path, data: dict[str, np.ndarray], metrics: dict[str, Any]) -> Recording:
    """``q`` (T, 18) legs + ``body`` (T, 7) → the floating hexapod's q (T, 25) = ``[body, legs]``."""
    legs, body = validation.array(data["q"], "q"), validation.array(data["body"], "body")
    if body.shape != (len(legs), 7):
        raise InvalidInputError(f"{p}: body must be (T, 7) = position + quaternion xyzw, got {body.shape}")
    return _free_flyer_hexapod(p, body, legs, _time(data, "q", len(legs), metrics))


def _free_flyer_hexapod(p: Path | str, body: np.ndarray, legs: np.ndarray, t: np.ndarray, **kw: Any) -> Recording:
    """The recording of body poses (T, 7) (position, quaternion xyzw) and legs (T, 18) on the floating hexapod;
    a quaternion that is not unit raises :class:`InvalidInputError` naming the frame."""
    from .. import systems

    ff = systems.load("hexapod", free_flyer=True)
    Q = np.hstack([body, legs])
    for k, row in enumerate(Q):
        ff.check_quaternions(row, f"{p}: body pose of frame {k}")
    return Recording(ff, Q, t, source=str(p), **kw)


def _arm5() -> Any:
    from .. import systems
    from ..kinematics.arm5_ik import ARM5_END_FRAME

    return systems.from_urdf(systems.ROBOTS_DIR / "arm5" / "arm5.urdf", [ARM5_END_FRAME], name="arm5")


# ====================================================================== physics logs
def _physics(p: Path, data: dict[str, np.ndarray], metrics: dict[str, Any], system: Any) -> Recording:
    import importlib

    mj = importlib.import_module("mujoco")
    if system is None:
        if not isinstance(metrics.get("system"), str):
            raise InvalidInputError(f"{p.parent}/metrics.json names no system; pass system= (or --system)")
        system = metrics["system"]
    sys_ = _system(system)
    idx = np.asarray(metrics.get("qpos_index", []), dtype=int)
    if idx.shape != (sys_.nq,):
        raise InvalidInputError(f"{p.parent}/metrics.json: qpos_index must list {sys_.nq} addresses, got {idx.shape}")
    model = mj.MjModel.from_xml_string((p.parent / "model.xml").read_text())
    qpos = validation.array(data["qpos"], "qpos")
    if qpos.ndim != 2 or qpos.shape[1] != model.nq:
        raise InvalidInputError(f"{p}: qpos must be (T, {model.nq}), got {qpos.shape}")
    objects = [str(b) for b in metrics.get("object_bodies", []) or []]
    poses = _body_poses(mj, model, qpos)
    bodies = []
    for name in objects:
        b = mj.mj_name2id(model, mj.mjtObj.mjOBJ_BODY, name)
        if b >= 0:
            bodies.append(BodyTrack(name, _shapes(mj, model, b), poses[0][:, b], poses[1][:, b]))
    base = _base(mj, model, poses, objects)
    t = data.get("time")
    t = np.asarray(t, float) if t is not None and t.shape == (len(qpos),) else DEFAULT_DT * np.arange(len(qpos))
    if base is not None and sys_ is _system("hexapod"):  # the body on the floating hexapod's free flyer
        pos, wxyz = base
        return _free_flyer_hexapod(
            p.parent, np.hstack([pos, wxyz[:, [1, 2, 3, 0]]]), qpos[:, idx], t, bodies=bodies, key="qpos"
        )
    return Recording(
        sys_,
        qpos[:, idx],
        t,
        base=None if base is None else _matrices(*base),
        bodies=bodies,
        source=str(p.parent),
        key="qpos",
    )


def _body_poses(mj: Any, model: Any, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World positions (T, nbody, 3) and quaternions (T, nbody, 4) wxyz by ``mj_kinematics`` per frame."""
    d = mj.MjData(model)
    P = np.empty((len(qpos), model.nbody, 3))
    Qt = np.empty((len(qpos), model.nbody, 4))
    for k, row in enumerate(qpos):
        d.qpos[:] = row
        mj.mj_kinematics(model, d)
        P[k], Qt[k] = d.xpos, d.xquat
    return P, Qt


def _shapes(mj: Any, model: Any, body: int) -> list[BodyShape]:
    kinds = {
        int(mj.mjtGeom.mjGEOM_BOX): "box",
        int(mj.mjtGeom.mjGEOM_SPHERE): "sphere",
        int(mj.mjtGeom.mjGEOM_CYLINDER): "cylinder",
        int(mj.mjtGeom.mjGEOM_CAPSULE): "capsule",
    }
    out = []
    for g in np.flatnonzero(np.asarray(model.geom_bodyid) == body):
        kind = kinds.get(int(model.geom_type[g]))
        if kind is None:
            continue  # meshes, ellipsoids: not drawn
        size = tuple(float(x) for x in model.geom_size[g][: {"box": 3, "sphere": 1}.get(kind, 2)])
        rgba = tuple(float(x) for x in model.geom_rgba[g])
        out.append(BodyShape(kind, size, rgba, tuple(model.geom_pos[g]), tuple(model.geom_quat[g])))  # type: ignore[arg-type]
    return out


def _base(
    mj: Any, model: Any, poses: tuple[np.ndarray, np.ndarray], objects: list[str]
) -> tuple[np.ndarray, np.ndarray] | None:
    """World positions (T, 3) and quaternions (T, 4) wxyz of a floating robot base (a free joint on a body that is
    not an object), or None."""
    for j in range(model.njnt):
        if int(model.jnt_type[j]) != int(mj.mjtJoint.mjJNT_FREE):
            continue
        b = int(model.jnt_bodyid[j])
        if mj.mj_id2name(model, mj.mjtObj.mjOBJ_BODY, b) in objects:
            continue
        return poses[0][:, b], poses[1][:, b]
    return None


def _matrices(P: np.ndarray, wxyz: np.ndarray) -> np.ndarray:
    """Poses (T, 4, 4) of positions (T, 3) and quaternions (T, 4) wxyz."""
    from scipy.spatial.transform import Rotation

    M = np.tile(np.eye(4), (len(P), 1, 1))
    M[:, :3, :3] = Rotation.from_quat(wxyz[:, [1, 2, 3, 0]]).as_matrix()
    M[:, :3, 3] = P
    return M
