"""Combine two different robots into one System and keep their meshes (``VisualSource``).

A Franka Panda (example-robot-data) and a KUKA iiwa 14 (the URDF coop_ga ships) face each other 1.1 m
apart.  ``prefixed`` renames each robot's joints and frames, ``append_robots`` joins the two Pinocchio
models at their base placements (``pinocchio.appendModel``), ``from_model`` locks the Panda's fingers and
takes one ``VisualSource`` per robot (with the same prefix), so the combined system is drawn from both
robots' visual geometry instead of a stick figure.  The cooperative point pair spans the Panda's TCP and
the iiwa's flange; a Gauss–Newton IK solve lifts it 5 cm and turns it 10° about the vertical.

Writes ``meshes.png`` (both robots from their meshes; a skeleton with ``--fast``), ``skeleton.png`` (the
same system without visuals) and ``summary.json``.

Run::

    python examples/02_combine_robots_with_meshes.py --out /tmp/ex02
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import example_robot_data as erd
import numpy as np
import pinocchio as pin

import coop_ga as cg
from coop_ga.systems import ROBOTS_DIR, VisualSource, append_robots, from_model, prefixed

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("meshes.png", "skeleton.png", "summary.json")

#: The iiwa's q0 of the paper (§4.1) [rad]: it reaches along −x of its base.
IIWA_Q0 = np.array([0.0, -0.7854, 0.0, 1.3962, 0.0, 0.6109, 0.0])


def build(with_visuals: bool = True) -> cg.systems.System:
    """The Panda + iiwa system (14 DOF), end frames the Panda's TCP and the iiwa's flange."""
    panda = erd.load("panda")  # a RobotWrapper: model, visual_model, q0 (9 joints with the fingers)
    iiwa = pin.buildModelFromUrdf(str(ROBOTS_DIR / "iiwa14" / "iiwa14.urdf"))
    model = append_robots(
        [
            (prefixed(panda.model, "franka_"), pin.SE3(np.eye(3), np.array([-0.6, 0.0, 0.0]))),
            (prefixed(iiwa, "iiwa_"), pin.SE3(np.eye(3), np.array([1.1, 0.0, 0.0]))),
        ]
    )
    visuals = [
        VisualSource(geometry=panda.visual_model, model=panda.model, prefix="franka_"),  # a GeometryModel in memory
        VisualSource(urdf=ROBOTS_DIR / "iiwa14" / "iiwa14.urdf", prefix="iiwa_"),  # or a URDF file
    ]
    q_lock = np.concatenate([np.asarray(panda.q0), IIWA_Q0])  # the Panda's fingers are locked where q_lock says
    return from_model(
        model,
        ["franka_panda_hand_tcp", "iiwa_iiwa_flange"],
        name="panda_and_iiwa",
        locked_joints=["franka_panda_finger_joint1", "franka_panda_finger_joint2"],
        q_lock=q_lock,
        q0=np.concatenate([np.asarray(panda.q0)[:7], IIWA_Q0]),
        visuals=visuals if with_visuals else (),
    )


def main(argv: list[str] | None = None) -> int:
    """Compose, solve, draw; returns 0."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "02")
    ap.add_argument("--fast", action="store_true", help="draw skeletons only (no mesh rendering)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    system = build()
    geom = system.visual_model()
    print(system, f"{geom.ngeoms} visual objects from {len(system.visuals)} VisualSources")

    task = cg.cooperative_task(system, "point_pair")  # Panda TCP → iiwa flange
    a, b = task.points(system.q0)
    target = cg.control.displaced_target(
        task, system.q0, translation=(0, 0, 0.05), axis=(0, 0, 1), angle=np.deg2rad(10)
    )
    ik = cg.control.gauss_newton_ik(task, system.q0, target)
    a1, b1 = task.points(ik.q)
    print(f"end points at q0: {np.round(a, 3)} and {np.round(b, 3)} m, {np.linalg.norm(b - a):.3f} m apart")
    print(
        f"IK: converged={ik.converged} in {ik.iterations} iterations, error {ik.error:.1e}; the midpoint rose "
        f"{((a1 + b1) / 2 - (a + b) / 2)[2] * 1e3:.1f} mm"
    )

    prims = [task.primitive(ik.q)]
    backend = "skeleton" if args.fast else "auto"
    cg.viz.render(system, ik.q, prims, args.out / "meshes.png", backend=backend, size=(5, 4), dpi=80)
    cg.viz.render(
        build(with_visuals=False), ik.q, prims, args.out / "skeleton.png", size=(5, 4), dpi=80, backend="skeleton"
    )
    summary = {"nq": system.nq, "visual_objects": int(geom.ngeoms), "converged": bool(ik.converged), "error": ik.error}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(f"wrote {', '.join(OUTPUTS)} to {args.out}")
    return 0 if ik.converged else 1


if __name__ == "__main__":
    sys.exit(main())
