"""Physics with MuJoCo: three arms around a box on the floor, a push, a replayable log.

``coop_ga.sim.build_scene`` builds a MuJoCo model (``MjSpec``, in code) from the same Pinocchio model the
kinematics use — the three iiwa 14 of ``three_iiwa14`` with their limits, effort-limited motors and
collision capsules — plus a floor and a free 2 kg box.  ``Simulation`` runs it at 1 kHz with a controller
callback ``(t, q, q̇, sensors) → τ`` (here: Pinocchio's gravity torque plus a joint PD that holds q0) and a
5 N push on the box (``Disturbance``, MuJoCo's ``xfrc_applied``).  The log is saved (``model.xml`` with 17
significant digits, ``log.npz``, ``metrics.json``) and ``coop_ga.sim.replay`` re-simulates it with MuJoCo
alone: the largest qpos difference is printed (0.0: bit for bit).  The cooperative circle through the three
flanges is read from the final state.  Needs ``pip install 'coop_ga[sim]'`` (mujoco ≥ 3.2).

Writes ``run/model.xml``, ``run/log.npz``, ``run/metrics.json`` and ``summary.json``; play the run with
``python -m coop_ga.viewer --play DIR/run``.

Run::

    python examples/08_physics_box_hold.py --out /tmp/ex08 --seconds 0.5
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import pinocchio as pin

import coop_ga as cg
from coop_ga.sim import Box, Disturbance, Simulation, build_scene, replay

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("run/model.xml", "run/log.npz", "run/metrics.json", "summary.json")
#: Optional packages this example needs (the test skips it without them): the ``sim`` extra.
REQUIRES = ("mujoco",)


def main(argv: list[str] | None = None) -> int:
    """Simulate, save, replay; returns 0 when the replay reproduces the run and the arms held q0."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "08")
    ap.add_argument("--seconds", type=float, default=0.3, help="simulated time [s] (default 0.3: 300 steps)")
    ap.add_argument("--fast", action="store_true", help="simulate 0.2 s")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    seconds = 0.2 if args.fast else args.seconds

    system = cg.systems.load("three_iiwa14")
    box = Box(name="box", size=(0.2, 0.2, 0.2), mass=2.0, pos=(0.0, 0.0, 0.1), friction=0.8)
    scene = build_scene(system, objects=[box])  # Δt = 1 ms

    model, data = system.model, system.model.createData()
    Mii = np.diag(pin.crba(model, data, system.q0))  # PD gains scaled by each joint's inertia at q0

    def hold(t: float, q: np.ndarray, qd: np.ndarray, sensors: object) -> np.ndarray:
        """τ (21,) [N m]: gravity compensation + joint PD towards q0."""
        return pin.computeGeneralizedGravity(model, data, q) + Mii * (400.0 * (system.q0 - q) - 40.0 * qd)

    push = Disturbance("box", force=(0.0, 5.0, 0.0), start=0.05, stop=0.15)  # world frame [N]
    sim = Simulation(scene, hold, disturbances=[push])
    log = sim.run(seconds)
    position, _ = sim.object_pose("box")
    wrench = sim.object_wrench("box")
    folder = log.save(args.out / "run")
    diff = replay(folder)

    q_end = log.q[-1]  # (nq,) the robot's joints in Pinocchio's order
    task = cg.cooperative_task(system, "circle")
    drift = float(np.abs(q_end - system.q0).max())
    radius = float(cg.radius(task.primitive(q_end)))
    print(f"simulated {seconds:.2f} s ({len(log.time)} steps at 1 kHz); box at {np.round(position, 4)} m")
    print(f"contact force on the box {np.round(wrench[:3], 2)} N (its weight: {2.0 * 9.81:.2f} N)")
    print(f"arms held q0 within {drift:.1e} rad; cooperative circle radius {radius:.4f} m")
    print(f"replay from {folder.name}/model.xml + log.npz: largest qpos difference {diff:.1e}")
    summary = {"seconds": seconds, "box_position_m": position.tolist(), "q_drift_rad": drift, "replay_diff": diff}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(f"wrote {', '.join(OUTPUTS)} to {args.out}")
    return 0 if diff == 0.0 and drift < 1e-2 else 1


if __name__ == "__main__":
    sys.exit(main())
