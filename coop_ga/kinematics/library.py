"""The registered systems of the paper (§4, Figs. 8–13, 20–21): builders for :func:`systems.load`."""

from __future__ import annotations

import numpy as np

from .systems import System, append_robots, prefixed, register

__all__: list[str] = []


def _panda_arm():
    """example-robot-data ``panda`` with the two finger joints locked (7 DOF), and its q0."""
    import example_robot_data as erd
    import pinocchio as pin

    r = erd.load("panda")
    m = r.model
    locked = [m.getJointId(n) for n in ("panda_finger_joint1", "panda_finger_joint2")]
    arm = pin.buildReducedModel(m, locked, np.asarray(r.q0))
    return arm, np.asarray(r.q0)[:7].copy()


def _ring_placements(n: int, radius: float, start_deg: float = -90.0):
    """Bases on a circle, ``360/n`` degrees apart counter-clockwise, x axes facing the centre."""
    import pinocchio as pin

    out = []
    for i in range(n):
        phi = np.deg2rad(start_deg + i * 360.0 / n)
        pos = radius * np.array([np.cos(phi), np.sin(phi), 0.0])
        out.append(pin.SE3(pin.utils.rotate("z", phi + np.pi), pos))
    return out


@register("three_franka", "three Franka Panda arms 120° apart on a 0.8 m circle, facing the centre (Fig. 8)")
def _three_franka() -> System:
    arm, q0 = _panda_arm()
    parts = [(prefixed(arm, f"arm{i}_"), pl) for i, pl in enumerate(_ring_placements(3, 0.8))]
    model = append_robots(parts)
    return System(
        name="three_franka",
        model=model,
        end_frames=tuple(f"arm{i}_panda_hand_tcp" for i in range(3)),
        q0=np.tile(q0, 3),
        description="three Franka Panda arms (fingers locked) 120° apart on a 0.8 m circle, facing the centre",
        labels=("arm0 tcp", "arm1 tcp", "arm2 tcp"),
    )
