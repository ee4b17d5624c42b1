"""MJCF text of a scene that reloads into the same model: full-precision ``MjSpec.to_xml`` and its check.

``MjSpec.to_xml`` prints numbers with 6 significant digits (MuJoCo's XML writer default), so a
model written that way and loaded back differs from the compiled one by ~1e-7 relative (body
positions, inertias): the replay of a log would drift and the written model would not be "the
model of the run".  MuJoCo's writer has a precision setting for its own round-trip tests
(``_mjPRIVATE__set_xml_precision`` in ``libmujoco``, thread-local, default 6; 17 digits print every
double exactly); :func:`to_xml` sets it to 17 around the call with :mod:`ctypes` and restores it.
The symbol is private, so :func:`to_xml` falls back to the default precision if it is missing, and
:func:`check_reload` — run by :meth:`coop_ga.sim.Scene.write_model` on every model it writes — says
whether the text reproduces the model: every array that enters the dynamics, kinematics and
contacts is compared bit for bit.

Meshes (the visual meshes of :func:`~coop_ga.sim.build_scene`) are given to the spec as vertex and
face arrays, so ``to_xml`` writes them inline (``<mesh vertex="…" face="…"/>``) and the text needs
no other file.
"""

from __future__ import annotations

import contextlib
import ctypes
import glob
import os
import threading
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..errors import CoopGAError
from ._mujoco import mj

__all__ = ["RELOAD_FIELDS", "VISUAL_TOL", "check_reload", "full_precision", "to_xml"]

#: MjModel arrays compared by :func:`check_reload` (dynamics, kinematics, contacts, actuation).
RELOAD_FIELDS = (
    "opt.timestep",
    "opt.gravity",
    "opt.integrator",
    "opt.cone",
    "opt.solver",
    "opt.iterations",
    "opt.tolerance",
    "opt.disableflags",
    "opt.enableflags",
    "body_parentid",
    "body_pos",
    "body_quat",
    "body_ipos",
    "body_iquat",
    "body_mass",
    "body_inertia",
    "jnt_type",
    "jnt_bodyid",
    "jnt_qposadr",
    "jnt_pos",
    "jnt_axis",
    "jnt_range",
    "jnt_limited",
    "dof_armature",
    "dof_damping",
    "dof_frictionloss",
    "geom_type",
    "geom_bodyid",
    "geom_contype",
    "geom_conaffinity",
    "geom_condim",
    "geom_size",
    "geom_pos",
    "geom_quat",
    "geom_friction",
    "geom_solref",
    "geom_solimp",
    "geom_margin",
    "site_bodyid",
    "site_pos",
    "site_quat",
    "actuator_trnid",
    "actuator_gear",
    "actuator_ctrlrange",
    "actuator_ctrllimited",
    "actuator_forcerange",
    "actuator_gainprm",
    "actuator_biasprm",
    "exclude_signature",
    "qpos0",
    "nmesh",
    "mesh_vertnum",
    "mesh_facenum",
    "mesh_vert",
    "mesh_face",
)

#: tolerance [m, or quaternion units] on the pose of a visual-only geom after a reload (:func:`check_reload`)
VISUAL_TOL = 1e-12

_LOCK = threading.Lock()
_LIB: Any = None


def _library() -> Any:
    """libmujoco loaded with ctypes (the one the ``mujoco`` module uses), or False if not found."""
    global _LIB
    if _LIB is None:
        folder = os.path.dirname(mj().__file__)
        paths = sorted(glob.glob(os.path.join(folder, "libmujoco.so*")))
        paths += sorted(glob.glob(os.path.join(folder, "libmujoco*.dylib")))
        _LIB = False
        for p in paths:
            try:
                lib = ctypes.CDLL(p)
                lib._mjPRIVATE__set_xml_precision.argtypes = [ctypes.c_int]
                lib._mjPRIVATE__get_xml_precision.restype = ctypes.c_int
            except (OSError, AttributeError):
                continue
            _LIB = lib
            break
    return _LIB


@contextlib.contextmanager
def full_precision() -> Iterator[bool]:
    """Context in which MuJoCo's XML writer prints 17 significant digits; yields whether it could be set."""
    lib = _library()
    if not lib:
        yield False
        return
    with _LOCK:
        old = int(lib._mjPRIVATE__get_xml_precision())
        lib._mjPRIVATE__set_xml_precision(17)
        try:
            yield True
        finally:
            lib._mjPRIVATE__set_xml_precision(old)


def to_xml(spec: Any) -> str:
    """``spec.to_xml()`` with every number printed exactly (module docstring).  The spec must be compiled."""
    with full_precision():
        return str(spec.to_xml())


def _field(model: Any, name: str) -> np.ndarray:
    obj = model
    for part in name.split("."):
        obj = getattr(obj, part)
    return np.asarray(obj)


def check_reload(model: Any, xml: str) -> list[str]:
    """Names of the :data:`RELOAD_FIELDS` that differ (bit for bit) between ``model`` and the model
    ``mujoco.MjModel.from_xml_string(xml)``; empty when the text reproduces the model (the poses of
    visual-only geoms within :data:`VISUAL_TOL`, everything else bit for bit).

    Raises :class:`~coop_ga.errors.CoopGAError` if MuJoCo cannot load the text at all.
    """
    try:
        other = mj().MjModel.from_xml_string(xml)
    except ValueError as e:
        raise CoopGAError(f"the written MJCF does not load back in MuJoCo: {e}") from e
    bad = []
    for name in RELOAD_FIELDS:
        a, b = _field(model, name), _field(other, name)
        if a.shape != b.shape:
            bad.append(name)
        elif name in ("geom_pos", "geom_quat"):
            # a visual mesh is re-centred on its centroid when compiled: its pose differs by round-off
            # (~1e-16) after a reload; it never touches anything, so only colliding geoms must be exact
            collide = (np.asarray(model.geom_contype) != 0) | (np.asarray(model.geom_conaffinity) != 0)
            if not np.array_equal(a[collide], b[collide]) or not np.allclose(a, b, rtol=0.0, atol=VISUAL_TOL):
                bad.append(name)
        elif not np.array_equal(a, b):
            bad.append(name)
    return bad
