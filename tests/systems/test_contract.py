"""The error contract of coop_ga.systems, append_robots' name clashes, and the default q0 strictly inside the limits.

Regression tests: ``from_urdf(q0=NaN)`` built a system with a NaN q0; ``append_robots`` of two robots sharing a
joint or frame name passed Pinocchio's bare ``ValueError`` ("conflicting frame names", or "Several frames match
the filter" when a system is built on it) without saying which name or what to do; ``from_model``'s default q0
kept joints whose neutral value lies on a bound there (Talos: four arm joints, two knees and two grippers);
a URDF that Pinocchio cannot parse, or a folder, gave a ValueError/RuntimeError; the limits' checks returned NaN
for a NaN input and a numpy broadcasting error for a wrong size.
"""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin
import pytest

from coop_ga import systems
from coop_ga.errors import InvalidInputError, NonFiniteError, UnknownNameError
from coop_ga.systems import (
    ROBOTS_DIR,
    System,
    append_robots,
    cartesian_points,
    from_model,
    from_urdf,
    prefixed,
    unique_frames,
)
from coop_ga.systems.system import DEFAULT_Q0_MARGIN

NAN = float("nan")
HEXAPOD = ROBOTS_DIR / "hexapod" / "hexapod.urdf"
FEET = ["lf_foot", "lm_foot", "lr_foot"]


def _erd_urdf(loader: str) -> str:
    import example_robot_data as erd

    L = getattr(erd.robots_loader, loader)
    rel = os.path.join(L.path, L.urdf_subpath, L.urdf_filename)
    return os.path.join(erd.getModelPath(rel), rel)


@pytest.mark.parametrize("q0, cls", [([NAN] * 18, NonFiniteError), ([np.inf] * 18, NonFiniteError),
                                     ("q0", InvalidInputError), ([0.0] * 17, InvalidInputError)])  # fmt: skip
def test_from_urdf_refuses_a_bad_q0(q0, cls):
    with pytest.raises(cls, match="q0"):
        from_urdf(HEXAPOD, FEET, q0=q0)


def test_q0_outside_the_limits_is_refused_naming_the_joints():
    with pytest.raises(InvalidInputError, match=r"q0 of system 'hexapod' is outside the joint limits: lf_coxa_joint"):
        from_urdf(HEXAPOD, FEET, q0=[10.0] * 18)
    s = cartesian_points(2)
    with pytest.raises(InvalidInputError, match=r"c0_px=6\.0000 not in"):
        System("s", s.model, ("tip0",), [6.0] + [0.0] * 5)


def test_append_robots_names_the_clash_and_the_fix():
    z1 = pin.buildModelFromUrdf(_erd_urdf("Z1Loader"))  # Unitree Z1, twice: the example
    # its URDF names a fixed joint like a link: Pinocchio's appendModel failed with "Several frames match the filter"
    with pytest.raises(InvalidInputError, match=r"parts\[0\]: .* 2 frames named 'gripperStator' .*unique_frames"):
        append_robots([(z1, pin.SE3.Identity()), (z1, pin.SE3.Identity())])
    z1u = unique_frames(z1)
    assert [f.name for f in z1u.frames].count("gripperStator") == 1
    assert z1u.frames[z1u.getFrameId("gripperStator")].type == pin.FrameType.BODY
    assert "gripperStator_fixed_joint" in [f.name for f in z1u.frames]
    with pytest.raises(
        InvalidInputError, match=r"parts\[0\] and parts\[1\] both have a joint named 'joint1'.*prefixed"
    ):
        append_robots([(z1u, pin.SE3.Identity()), (z1u, pin.SE3.Identity())])
    z1 = z1u
    # distinct joint names, one frame name in common
    s = cartesian_points(2)
    m2 = pin.Model(s.model)
    for i in range(1, m2.njoints):
        m2.names[i] = "b_" + m2.names[i]
    with pytest.raises(InvalidInputError, match="both have a frame named 'tip0'"):
        append_robots([(s.model, pin.SE3.Identity()), (m2, pin.SE3.Identity())])
    both = append_robots([(prefixed(z1, "a_"), pin.SE3.Identity()), (prefixed(z1, "b_"), pin.SE3.Identity())])
    assert both.nq == 2 * z1.nq
    with pytest.raises(InvalidInputError, match=r"placement must be a pinocchio\.SE3"):
        append_robots([(z1, "origin")])
    with pytest.raises(InvalidInputError, match="prefix"):
        prefixed(z1, 3)


def test_default_q0_is_strictly_inside_the_limits():
    """Talos' neutral configuration has joints on a bound; the default q0 moves them 1 % of the range inside."""
    talos = pin.buildModelFromUrdf(_erd_urdf("TalosLoader"))
    q = pin.neutral(talos)
    on = [i for i in range(talos.nq) if q[i] in (talos.lowerPositionLimit[i], talos.upperPositionLimit[i])]
    assert len(on) == 8  # 4 arm joints, 2 knees, 2 grippers
    s = from_model(talos, ["gripper_left_base_link", "gripper_right_base_link"], name="talos")
    lo, hi = s.q_lower, s.q_upper
    assert np.all(lo < s.q0) and np.all(s.q0 < hi)
    span = hi - lo
    np.testing.assert_allclose(np.minimum(s.q0 - lo, hi - s.q0)[on], DEFAULT_Q0_MARGIN * span[on], rtol=1e-12)
    others = [i for i in range(talos.nq) if i not in on]
    np.testing.assert_array_equal(s.q0[others], q[others])  # inside already: neutral kept


def test_registered_systems_q0_are_strictly_inside():
    for name in systems.names():
        s = systems.load(name)
        assert np.all(s.q_lower < s.q0) and np.all(s.q0 < s.q_upper), name


@pytest.mark.parametrize(
    "path, match",
    [(None, "urdf_path must be a path"), ("/nonexistent/robot.urdf", "not found"), (ROBOTS_DIR, "a folder")],
)
def test_from_urdf_paths_are_checked(path, match):
    with pytest.raises(InvalidInputError, match=match):
        from_urdf(path, FEET)


def test_unreadable_urdf_is_a_coop_ga_error(tmp_path):
    bad = tmp_path / "x.urdf"
    bad.write_text("<robot><oops")
    with pytest.raises(InvalidInputError, match=r"urdf_path: .* is not a URDF Pinocchio can read"):
        from_urdf(bad, FEET)


def test_name_lists_are_not_strings():
    with pytest.raises(InvalidInputError, match="locked_joints must be a list of names"):
        from_urdf(HEXAPOD, FEET, "lf_coxa_joint")  # its letters were taken for 13 joint names
    with pytest.raises(UnknownNameError, match="unknown locked_joints"):
        from_urdf(HEXAPOD, FEET, ["nope"])
    with pytest.raises(NonFiniteError, match="q_lock"):
        from_urdf(HEXAPOD, FEET, ["rf_coxa_joint"], q_lock=[NAN] * 18)


def test_limits_checks_refuse_nan_and_wrong_sizes():
    lim = cartesian_points(3).limits
    for f, arg in ((lim.position_violation, "q"), (lim.velocity_violation, "qd"), (lim.clip, "q"),
                   (lim.acceleration_violation, "qdd"), (lim.effort_violation, "tau")):  # fmt: skip
        with pytest.raises(NonFiniteError, match=rf"\b{arg}\b"):
            f([NAN] * 9)
        with pytest.raises(InvalidInputError, match=rf"\b{arg}\b must have shape"):
            f([0.0] * 4)
    with pytest.raises(InvalidInputError, match="dt"):
        lim.trajectory_velocity_violation(np.zeros((2, 9)), 0.0)
    assert lim.position_violation(np.full((4, 9), 6.0)) == pytest.approx(1.0)


def test_system_arguments_are_checked():
    s = cartesian_points(3)
    with pytest.raises(InvalidInputError, match="labels of system 's' must be 3 strings"):
        System("s", s.model, ("tip0", "tip1", "tip2"), [0.0] * 9, labels=("a", "b"))
    with pytest.raises(InvalidInputError, match=r"model of system 's' must be a pinocchio\.Model"):
        System("s", None, ("tip0",), [0.0] * 9)
    with pytest.raises(InvalidInputError, match="scale"):
        s.random_q(np.random.default_rng(0), 2.0)
    with pytest.raises(InvalidInputError, match="rng"):
        s.random_q(3)
    with pytest.raises(InvalidInputError, match="n_points"):
        cartesian_points(2.5)
    with pytest.raises(NonFiniteError, match="bases"):
        cartesian_points(2, [[NAN, 0, 0]] * 2)
    with pytest.raises(InvalidInputError, match="name must be a non-empty string"):
        systems.register(3)
