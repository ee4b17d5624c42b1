#!/usr/bin/env python
"""Physics in the loop: real-time factor of three_franka + a 2 kg box at 1 kHz with a joint PD controller.

    python benchmarks/sim.py [--seconds 5] [--ci] [--out results/benchmarks/sim] [--quiet]

Scene: ``coop_ga.sim.build_scene(three_franka, objects=[Box 0.2 m, 2 kg on the floor at the centre])``
(21 joints, 33 collision capsules, the box's 4 floor contacts, visual meshes), Δt = 1 ms,
``implicitfast``.  Three loops over the same number of physics steps, timed in the same run:

* ``bare mj_step (anchor)``: ``mujoco.mj_step`` in a plain Python loop with a constant ``ctrl`` (the
  gravity torque at q0) — what MuJoCo alone costs from Python;
* ``Simulation, constant τ``: :class:`coop_ga.sim.Simulation` whose controller returns the anchor's
  constant torque — the loop's own cost (state mapping, torque checks, logging every step) on the
  same physics;
* ``Simulation + joint PD``: the controller ``τ = g(q) + K_p (q0 − q) − K_d q̇`` called every step
  (1 kHz), ``g`` from Pinocchio (``computeGeneralizedGravity``), per-joint gains
  ``K_p = ω² M_ii(q0)``, ``K_d = 2 ω M_ii(q0)`` (ω = 20 rad/s, critically damped per joint).

Printed: simulated seconds per wall second (≥ 1 is real time), the ratio of each loop's time per step
to the anchor's, and the controller's share of a tick (time inside the controller callback over the
loop's wall time).  Before the timings count, the run is checked: the arms hold q0 (max |q − q0|) and
the box stays on the floor.  ``--ci``: 0.2 s simulated per loop (seconds of wall time; the CI test
reads the JSON, never the times).  Results go to ``<out>/results.json``.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import print_table

import coop_ga as cg
from coop_ga.harness import Experiment, positive_float

ANCHOR = "bare mj_step (anchor)"
CI_SECONDS = 0.2
OMEGA = 20.0  # [rad/s] PD bandwidth per joint


def _scene() -> Any:
    from coop_ga.sim import Box, build_scene

    s = cg.systems.load("three_franka")
    box = Box(name="box", size=(0.2, 0.2, 0.2), mass=2.0, pos=(0.0, 0.0, 0.1))
    return build_scene(s, objects=[box])


def _pd(system: Any) -> Any:
    """The joint PD with gravity compensation of the module docstring, and its call timer."""
    import pinocchio as pin

    model, data = system.model, system.model.createData()
    Mii = np.diag(pin.crba(model, data, system.q0)).copy()
    kp, kd, q0 = OMEGA**2 * Mii, 2.0 * OMEGA * Mii, system.q0.copy()
    spent = [0.0]

    def controller(t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> np.ndarray:
        t0 = time.perf_counter()
        tau = pin.computeGeneralizedGravity(model, data, q) + kp * (q0 - q) - kd * qd
        spent[0] += time.perf_counter() - t0
        return tau

    return controller, spent


def _gravity(system: Any) -> np.ndarray:
    import pinocchio as pin

    return np.asarray(pin.computeGeneralizedGravity(system.model, system.model.createData(), system.q0))


def _bare(scene: Any, steps: int) -> float:
    """Wall time [s] of ``steps`` plain ``mj_step`` calls."""
    import mujoco

    m, d = scene.model, scene.make_data()
    d.ctrl[scene.actuator_index] = _gravity(scene.system)
    t0 = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(m, d)
    return time.perf_counter() - t0


def _loop(scene: Any, steps: int, controller: Any) -> tuple[float, Any]:
    from coop_ga.sim import Simulation

    sim = Simulation(scene, controller)
    t0 = time.perf_counter()
    sim.step(steps)
    return time.perf_counter() - t0, sim


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/sim"))
    exp.add("--seconds", type=positive_float, default=5.0, help="simulated time per loop [s]")
    exp.add("--ci", action="store_true", help=f"small mode: {CI_SECONDS:g} s per loop (times meaningless)")
    args = exp.parse(argv)
    seconds = CI_SECONDS if args.ci else args.seconds
    with exp.stage("building the scene (three_franka + box)"):
        scene = _scene()
    steps = round(seconds / scene.model.opt.timestep)
    controller, spent = _pd(scene.system)
    times: dict[str, float] = {}
    with exp.stage(f"timing 3 loops × {steps} steps"):
        times[ANCHOR] = _bare(scene, steps)
        g = _gravity(scene.system)
        times["Simulation, constant τ"], _ = _loop(scene, steps, lambda t, q, qd, sensors: g)
        times["Simulation + joint PD"], sim = _loop(scene, steps, controller)
    hold = float(np.abs(sim.q - scene.system.q0).max())
    box_z = float(sim.object_pose("box")[0][2])
    assert hold < 0.05 and abs(box_z - 0.1) < 0.005, (hold, box_z)  # the run did what it should
    rows, records = [], []
    for name, t in times.items():
        rt = seconds / t
        rows.append([name, f"{1e6 * t / steps:.1f}", f"{t / times[ANCHOR]:.2f}", f"{rt:.2f}"])
        records.append({"loop": name, "us_per_step": 1e6 * t / steps, "ratio": t / times[ANCHOR], "realtime": rt})
    share = spent[0] / times["Simulation + joint PD"]
    print_table(
        f"three_franka + box, Δt = 1 ms, {steps} steps per loop (same run)",
        ["loop", "µs/step", "ratio to anchor", "sim s / wall s"],
        rows,
    )
    realtime = seconds / times["Simulation + joint PD"]
    print(
        f"controller share of a tick: {100 * share:.1f} %  ({1e6 * spent[0] / steps:.1f} µs per call); "
        f"real time with the controller: {realtime:.2f}× ({'PASS' if realtime >= 1.0 else 'MISS'} ≥ 1)\n"
        f"check: arms within {hold:.2e} rad of q0, box at z = {box_z:.4f} m"
    )
    exp.write_json(
        "results.json",
        {
            "ci": bool(args.ci),
            "steps": steps,
            "simulated_s": seconds,
            "rows": records,
            "controller_share": share,
            "controller_us_per_call": 1e6 * spent[0] / steps,
            "realtime_with_controller": realtime,
            "issue_target_realtime": "PASS" if realtime >= 1.0 else "MISS",
            "check": {"max_q_error_rad": hold, "box_z_m": box_z},
        },
        digits=None,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
