"""Named control groups (``groups=``/``active=``) instead of ``locked_joints``: the G1's waist and arms chosen by
group give the registered ``g1_arms`` model (same joints, same FK), and bad groups are refused by name."""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin
import pytest

from coop_ga import systems
from coop_ga.errors import InvalidInputError, UnknownNameError
from coop_ga.systems import ROBOTS_DIR, from_model, from_urdf, group_joints, locked_joints

HEXAPOD = ROBOTS_DIR / "hexapod" / "hexapod.urdf"
G1_GROUPS = {
    "waist": "waist_.*",
    "left_arm": ["left_shoulder_.*", "left_elbow_joint", "left_wrist_.*"],
    "right_arm": r"right_(shoulder|elbow|wrist)_.*",
    "legs": [".*_hip_.*", ".*_knee_joint", ".*_ankle_.*"],
}


def _g1_urdf() -> str:
    import example_robot_data as erd

    L = erd.robots_loader.G1Loader
    rel = os.path.join(L.path, L.urdf_subpath, L.urdf_filename)
    return os.path.join(erd.getModelPath(rel), rel)


def test_g1_waist_and_arms_by_group_equal_g1_arms() -> None:
    ref = systems.load("g1_arms")
    s = from_urdf(_g1_urdf(), ref.end_frames, groups=G1_GROUPS, active=("waist", "left_arm", "right_arm"), q0=ref.q0)
    assert s.joint_names == ref.joint_names and s.nq == 17
    rng = np.random.default_rng(0)
    for _ in range(10):
        q = ref.random_q(rng)
        np.testing.assert_allclose(s.end_points(q), ref.end_points(q), rtol=0, atol=1e-14)
    # only the left arm: the waist and the right arm are locked too
    left = from_urdf(_g1_urdf(), ["left_rubber_hand"], groups=G1_GROUPS, active=["left_arm"])
    assert left.joint_names == [f"left_{j}_joint" for j in
                                ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll",
                                 "wrist_pitch", "wrist_yaw")]  # fmt: skip


def test_group_joints_and_locked_joints_keep_model_order() -> None:
    names = list(pin.buildModelFromUrdf(str(HEXAPOD)).names)[1:]
    groups = {"left": "l._.*", "front": ["lf_.*", "rf_.*"], "tibias": ".*tibia.*"}
    members = group_joints(names, groups)
    assert members["front"] == tuple(n for n in names if n[:3] in ("lf_", "rf_"))
    assert len(members["left"]) == 9 and len(members["tibias"]) == 6
    locked = locked_joints(names, groups, ["front", "tibias"])
    assert locked == [n for n in names if n[:3] not in ("lf_", "rf_") and "tibia" not in n]
    assert len(locked) == 18 - 6 - 4  # two front legs (6) and the other four tibias


def test_bad_groups_are_refused_by_name() -> None:
    with pytest.raises(UnknownNameError, match=r"unknown active group\(s\) \['arms'\]\. Groups: left, front"):
        from_urdf(HEXAPOD, ["lf_foot"], groups={"left": "l._.*", "front": "lf_.*"}, active=["arms"])
    with pytest.raises(UnknownNameError, match=r"group 'front': 'xf_\.\*' matches no joint of the model\. Joints: lf_"):
        from_urdf(HEXAPOD, ["lf_foot"], groups={"front": ["lf_.*", "xf_.*"]}, active=["front"])
    with pytest.raises(InvalidInputError, match="neither a joint name nor a valid regular expression"):
        from_urdf(HEXAPOD, ["lf_foot"], groups={"front": "lf_(.*"}, active=["front"])
    with pytest.raises(InvalidInputError, match="either locked_joints= or groups=/active="):
        from_urdf(HEXAPOD, ["lf_foot"], ["rf_coxa_joint"], groups={"front": "lf_.*"}, active=["front"])
    with pytest.raises(InvalidInputError, match="need both groups= and active="):
        from_model(pin.buildModelFromUrdf(str(HEXAPOD)), ["lf_foot"], groups={"front": "lf_.*"})
    with pytest.raises(InvalidInputError, match="active must be a non-empty list"):
        from_urdf(HEXAPOD, ["lf_foot"], groups={"front": "lf_.*"}, active="front")
    with pytest.raises(InvalidInputError, match="group 'front' must be a joint name or pattern"):
        from_urdf(HEXAPOD, ["lf_foot"], groups={"front": []}, active=["front"])
    with pytest.raises(InvalidInputError, match="groups must be a non-empty mapping"):
        from_urdf(HEXAPOD, ["lf_foot"], groups=["lf_.*"], active=["front"])  # type: ignore[arg-type]
