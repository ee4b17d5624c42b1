"""Continuous (unbounded revolute) joints as angle coordinates: one coordinate per joint, nq = nv.

A URDF ``continuous`` joint is a revolute joint without limits.  Pinocchio models it as
``JointModelRUBX/Y/Z`` (or ``RevoluteUnboundedUnaligned``) with two coordinates (cos θ, sin θ) on the unit
circle and one velocity, so a model with one has nq ≠ nv, which coop_ga's kinematics, Jacobians (nq
columns) and controllers (q ← q + q̇ Δt) do not handle.  :func:`continuous_as_revolute` rebuilds the model
with each such joint replaced by the plain revolute joint about the same axis at the same placement, with
the angle θ as its coordinate and unbounded position limits: the same kinematics and dynamics (the joint's
motion subspace, inertias, frames, effort and velocity limits, armature, damping and friction are
unchanged), q = θ instead of (cos θ, sin θ).  ``from_model`` and ``from_urdf`` apply it, so a Kinova Gen2
(three continuous joints) loads without editing its URDF.  Only the coordinate's wrap-around is lost:
θ and θ + 2π are two values of q for one pose (the limits are unbounded, nothing in coop_ga wraps angles).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InvalidInputError

__all__ = ["UNBOUNDED_REVOLUTE", "angles_to_configuration", "continuous_as_revolute"]

#: Pinocchio's unbounded revolute joint classes (q = (cos θ, sin θ)) and the revolute class that replaces each.
UNBOUNDED_REVOLUTE = {
    "JointModelRUBX": "JointModelRX",
    "JointModelRUBY": "JointModelRY",
    "JointModelRUBZ": "JointModelRZ",
    "JointModelRevoluteUnboundedUnaligned": "JointModelRevoluteUnaligned",
}


def _revolute(jm: Any) -> Any:
    """The revolute joint model replacing unbounded ``jm`` (same axis)."""
    import pinocchio as pin

    short = jm.shortname()
    cls = getattr(pin, UNBOUNDED_REVOLUTE[short])
    if short == "JointModelRevoluteUnboundedUnaligned":
        return cls(np.asarray(jm.extract().axis, dtype=float))
    return cls()


def continuous_as_revolute(model: Any) -> Any:
    """A copy of ``model`` with every unbounded revolute joint replaced by a revolute joint (module docstring).

    Returns ``model`` itself when it has none.  Joint and frame order, names and ids are kept; the replaced
    joints' position limits are unbounded (Pinocchio's ±1.8e308 of a model built in code).
    """
    import pinocchio as pin

    if not isinstance(model, pin.Model):
        raise InvalidInputError(f"model must be a pinocchio.Model, got {type(model).__name__}")
    if not any(model.joints[j].shortname() in UNBOUNDED_REVOLUTE for j in range(1, model.njoints)):
        return model
    big = np.finfo(float).max
    new = pin.Model()
    new.name, new.gravity = model.name, model.gravity
    for j in range(1, model.njoints):
        jm = model.joints[j]
        iq, nq, iv, nv = jm.idx_q, jm.nq, jm.idx_v, jm.nv
        unbounded = jm.shortname() in UNBOUNDED_REVOLUTE
        lo = np.array([-big]) if unbounded else np.asarray(model.lowerPositionLimit[iq : iq + nq])
        hi = np.array([big]) if unbounded else np.asarray(model.upperPositionLimit[iq : iq + nq])
        jid = new.addJoint(
            int(model.parents[j]),
            _revolute(jm) if unbounded else jm,
            model.jointPlacements[j],
            model.names[j],
            np.asarray(model.effortLimit[iv : iv + nv]),
            np.asarray(model.velocityLimit[iv : iv + nv]),
            lo,
            hi,
        )
        for name in ("armature", "damping", "friction"):
            getattr(new, name)[new.idx_vs[jid] : new.idx_vs[jid] + nv] = getattr(model, name)[iv : iv + nv]
    for j in range(model.njoints):
        new.inertias[j] = model.inertias[j]
    for f in list(model.frames)[1:]:  # frame 0 is the universe, which the new model has
        new.addFrame(pin.Frame(f), False)  # the inertias were copied whole: append none again
    return new


def angles_to_configuration(model: Any, reduced: Any, q: Any) -> np.ndarray:
    """The configuration of ``model`` (with unbounded joints: (cos θ, sin θ)) for angles ``q`` of
    ``reduced = continuous_as_revolute(model)``; for cross-checks against the original model."""
    import pinocchio as pin

    qa = np.asarray(q, dtype=float)
    out = np.array(pin.neutral(model), dtype=float)
    for j in range(1, model.njoints):
        jm, jr = model.joints[j], reduced.joints[j]
        if jm.shortname() in UNBOUNDED_REVOLUTE:
            th = qa[jr.idx_q]
            out[jm.idx_q : jm.idx_q + 2] = (np.cos(th), np.sin(th))
        else:
            out[jm.idx_q : jm.idx_q + jm.nq] = qa[jr.idx_q : jr.idx_q + jr.nq]
    return out
