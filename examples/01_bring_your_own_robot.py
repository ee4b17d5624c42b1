"""Bring your own robot: a URDF → a multi-chain System → a cooperative circle → an IK solve → a picture.

Shows ``coop_ga.systems.from_urdf`` on a URDF that is not shipped with coop_ga (a small three-finger
gripper, written by this script into ``--out``; replace it with yours), naming one end frame per chain,
then the cooperative task through the three fingertips (a circle, Eq 14), its similarity V_Sc (Eq 28), and
a Gauss–Newton IK solve (Eq 43–47) that shrinks the circle by 15 % and moves it 5 mm down (the fingers curl in), inside the joint
limits.  Writes ``my_gripper.urdf``, ``start.png`` and ``solved.png`` (drawn from the URDF's visual
cylinders and spheres) and ``summary.json``.

Run::

    python examples/01_bring_your_own_robot.py --out /tmp/ex01
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

import coop_ga as cg

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("my_gripper.urdf", "start.png", "solved.png", "summary.json")


def _finger(k: int, yaw_deg: float) -> str:
    """Two revolute links of one finger on a 6 cm palm ring, curling towards the centre."""
    yaw = np.deg2rad(yaw_deg)
    x, y = 0.06 * np.cos(yaw), 0.06 * np.sin(yaw)
    link = (
        '<link name="{n}"><visual><origin xyz="0 0 0.02"/><geometry><cylinder radius="0.008" length="0.04"/>'
        '</geometry></visual><inertial><mass value="0.05"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-6" ixy="0" ixz="0"'
        ' iyz="0"/></inertial></link>'
    )
    joint = (
        '<joint name="{n}" type="revolute"><parent link="{p}"/><child link="{c}"/><origin xyz="{o}" rpy="0 0 {yaw}"/>'
        '<axis xyz="0 1 0"/><limit lower="-0.6" upper="1.4" effort="2" velocity="3"/></joint>'
    )
    return "\n".join(
        [
            link.format(n=f"f{k}_proximal"),
            link.format(n=f"f{k}_distal"),
            f'<link name="f{k}_tip"><visual><geometry><sphere radius="0.01"/></geometry></visual></link>',
            joint.format(
                n=f"f{k}_j0", p="palm", c=f"f{k}_proximal", o=f"{x:.6f} {y:.6f} 0.02", yaw=f"{yaw + np.pi:.6f}"
            ),
            joint.format(n=f"f{k}_j1", p=f"f{k}_proximal", c=f"f{k}_distal", o="0 0 0.04", yaw="0"),
            f'<joint name="f{k}_tip_joint" type="fixed"><parent link="f{k}_distal"/><child link="f{k}_tip"/>'
            '<origin xyz="0 0 0.04"/></joint>',
        ]
    )


def gripper_urdf() -> str:
    """A palm (a flat cylinder) with three 2-joint fingers 120° apart: 6 DOF, fingertip frames f0_tip … f2_tip."""
    palm = (
        '<link name="palm"><visual><geometry><cylinder radius="0.08" length="0.02"/></geometry></visual>'
        '<inertial><mass value="0.5"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial>'
        "</link>"
    )
    fingers = "\n".join(_finger(k, 90.0 + 120.0 * k) for k in range(3))
    return f'<?xml version="1.0"?>\n<robot name="my_gripper">\n{palm}\n{fingers}\n</robot>\n'


def main(argv: list[str] | None = None) -> int:
    """Build the gripper, solve one IK problem, draw it; returns 0."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "01")
    ap.add_argument("--fast", action="store_true", help="draw stick figures instead of the visual geometry")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    urdf = args.out / "my_gripper.urdf"
    urdf.write_text(gripper_urdf())
    # q0: the fingers half-curled (the neutral pose has the three tips on a circle too, but wide open)
    system = cg.systems.from_urdf(urdf, ["f0_tip", "f1_tip", "f2_tip"], name="my_gripper", q0=np.tile([0.3, 0.4], 3))
    print(system, system.joint_names)

    task = cg.cooperative_task(system, "circle")  # the circle through the three fingertips
    X0 = task.primitive(system.q0)
    V0 = task.similarity(system.q0)
    r0, c0 = float(cg.radius(X0)), np.asarray(cg.center(X0), float)
    print(f"start: circle radius {r0 * 1e3:.1f} mm, centre {np.round(c0, 4)} m, V_Sc scale {V0.scale:.4f}")

    target = cg.control.displaced_target(task, system.q0, translation=(0.0, 0.0, -0.005), scale=0.85)
    ik = cg.control.gauss_newton_ik(task, system.q0, target)
    X1 = task.primitive(ik.q)
    r1, c1 = float(cg.radius(X1)), np.asarray(cg.center(X1), float)
    why = "" if ik.converged else f" ({ik.message})"
    print(
        f"IK: converged={ik.converged}{why} in {ik.iterations} iterations, error {ik.error:.2e}; "
        f"radius {r1 * 1e3:.1f} mm (target {0.85 * r0 * 1e3:.1f}), centre height change {(c1 - c0)[2] * 1e3:+.2f} mm"
    )
    lim = system.limits
    assert lim is not None  # from_urdf reads them from the URDF
    inside = bool(np.all((ik.q >= lim.lower) & (ik.q <= lim.upper)))

    backend = "skeleton" if args.fast else "auto"
    cg.viz.render(system, system.q0, [X0], args.out / "start.png", backend=backend, size=(4, 4), dpi=80)
    cg.viz.render(
        system, ik.q, [X1, target.apply(task.unit)], args.out / "solved.png", backend=backend, size=(4, 4), dpi=80
    )
    summary = {
        "converged": bool(ik.converged),
        "iterations": int(ik.iterations),
        "error": float(ik.error),
        "radius_start_m": r0,
        "radius_solved_m": r1,
        "inside_limits": inside,
    }
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(f"inside the joint limits: {inside}; wrote {', '.join(OUTPUTS)} to {args.out}")
    return 0 if ik.converged and inside else 1


if __name__ == "__main__":
    sys.exit(main())
