"""Named control groups: choose a system's joints by group (``"left_arm"``, ``"waist"``) instead of listing the
joints to lock.

A group is a list of joint names or regular expressions (a pattern matches whole names, ``re.fullmatch``), or a
single pattern::

    groups = {"waist": "waist_.*", "left_arm": ["left_shoulder_.*", "left_elbow_joint", "left_wrist_.*"],
              "right_arm": r"right_(shoulder|elbow|wrist)_.*", "legs": ".*_(hip|knee|ankle)_.*"}
    sys = coop_ga.systems.from_urdf(g1_urdf, ["left_rubber_hand", "right_rubber_hand"], groups=groups,
                                    active=("waist", "left_arm", "right_arm"))

The joints of the ``active`` groups move; every other joint is locked (:func:`locked_joints` gives the list
``from_model``/``from_urdf``/``from_mjcf`` hand to ``pinocchio.buildReducedModel``).  An entry that names no
joint of the model, an unknown active group and an empty selection are refused, naming them.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import InvalidInputError, UnknownNameError

__all__ = ["group_joints", "locked_joints"]


def _entries(group: str, members: Any) -> tuple[str, ...]:
    if isinstance(members, str):
        members = (members,)
    if not isinstance(members, Sequence) or not members or not all(isinstance(m, str) and m for m in members):
        raise InvalidInputError(
            f"group '{group}' must be a joint name or pattern, or a non-empty list of them (str), got {members!r}"
        )
    return tuple(members)


def _matches(entry: str, joints: Sequence[str]) -> list[str]:
    if entry in joints:
        return [entry]
    try:
        pattern = re.compile(entry)
    except re.error as e:
        raise InvalidInputError(f"'{entry}' is neither a joint name nor a valid regular expression ({e})") from None
    return [j for j in joints if pattern.fullmatch(j)]


def group_joints(joint_names: Sequence[str], groups: Mapping[str, Any]) -> dict[str, tuple[str, ...]]:
    """The joints of each group, in ``joint_names`` order.

    Args:
        joint_names: the model's joint names (``list(model.names)[1:]``).
        groups: ``{group: joint names / regular expressions, or one expression}``.

    Raises :class:`~coop_ga.errors.UnknownNameError` for an entry that matches no joint (naming the group, the
    entry and the joints), :class:`InvalidInputError` for a malformed group or pattern.
    """
    if not isinstance(groups, Mapping) or not groups:
        raise InvalidInputError(f"groups must be a non-empty mapping {{name: joints}}, got {groups!r}")
    joints = list(joint_names)
    out: dict[str, tuple[str, ...]] = {}
    for name, members in groups.items():
        if not isinstance(name, str) or not name:
            raise InvalidInputError(f"group names must be non-empty strings, got {name!r}")
        chosen: set[str] = set()
        for entry in _entries(name, members):
            hit = _matches(entry, joints)
            if not hit:
                raise UnknownNameError(
                    f"group '{name}': '{entry}' matches no joint of the model. Joints: {', '.join(joints)}"
                )
            chosen.update(hit)
        out[name] = tuple(j for j in joints if j in chosen)
    return out


def locked_joints(joint_names: Sequence[str], groups: Mapping[str, Any], active: Sequence[str]) -> list[str]:
    """The joints outside every ``active`` group (to lock), in ``joint_names`` order.

    Args:
        joint_names: the model's joint names.
        groups: as in :func:`group_joints`.
        active: the names of the groups whose joints move.

    Raises :class:`~coop_ga.errors.UnknownNameError` for an active group that ``groups`` does not define,
    :class:`InvalidInputError` for an empty ``active``, and the errors of :func:`group_joints`.
    """
    if isinstance(active, str) or not isinstance(active, Sequence) or not active:
        raise InvalidInputError(f"active must be a non-empty list of group names, got {active!r}")
    members = group_joints(joint_names, groups)
    unknown = [g for g in active if g not in members]
    if unknown:
        raise UnknownNameError(f"unknown active group(s) {unknown}. Groups: {', '.join(members)}")
    moving = {j for g in active for j in members[g]}
    return [j for j in joint_names if j not in moving]
