#!/usr/bin/env python
"""The hexapod walking in MuJoCo with the closed-loop controller in the loop: simulated seconds per wall second.

    python benchmarks/sim_hexapod.py [--seconds 4] [--gait tripod] [--ci] [--out results/benchmarks/sim_hexapod]

Scene: :func:`coop_ga.sim.hexapod.hexapod_scene` on flat ground (Δt = 1 ms, elliptic cones, 19 robot geoms);
controller: :class:`coop_ga.sim.walking.HexapodWalker` (plans at 200 Hz, joint PD at 1 kHz), walking straight
ahead at the gait's nominal speed with the map.  Two loops over the same number of physics steps, timed in the
same run:

* ``bare mj_step (anchor)``: ``mujoco.mj_step`` in a plain Python loop with the standing pose's torques held;
* ``Simulation + walker``: :class:`coop_ga.sim.Simulation` with the walker in the loop (the pose functions of the
  stance planes are built before the timing starts).

Printed: simulated seconds per wall second of each loop (≥ 1: real time), simulated seconds per CPU second of the
process (``time.process_time``: what one core gives when the machine is not shared — the wall-clock numbers of a
loaded machine are not), its ratio to the anchor, and the controller's share of a tick — the CPU time inside
the walker's plans and servo calls over the loop's — with its cost per plan and per servo call.  The run is
checked before the numbers count: the robot walked forward, no torque was clipped.  ``--ci``: 0.4 s simulated (the times mean nothing; the CI test reads the JSON's shape).
Results go to ``<out>/results.json``.  Times depend on the machine's load: compare ratios within one run.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, os.path.dirname(__file__))
from _timing import print_table

from coop_ga.harness import Experiment, positive_float

ANCHOR = "bare mj_step (anchor)"
LOOP = "Simulation + walker"
CI_SECONDS = 0.4


def _setup(gait: str) -> tuple[Any, Any, Any, Any]:
    from coop_ga.legged import Terrain
    from coop_ga.sim.hexapod import hexapod_scene
    from coop_ga.sim.walking import HexapodWalker, VelocityCommand, WalkingOptions, standing_start

    hs = hexapod_scene(Terrain.flat(), visuals=False)
    opt = WalkingOptions(gait=gait)
    tab = opt.table()
    v = 0.08 / (tab.duty * tab.period)
    walker = HexapodWalker(hs, VelocityCommand.constant(v, start=0.05, ramp=0.5 * tab.period), opt)
    q0, pose = standing_start(hs, opt)
    return hs, walker, q0, pose


def _bare(hs: Any, walker: Any, q0: Any, pose: Any, steps: int) -> tuple[float, float]:
    """(wall, CPU) time [s] of ``steps`` plain ``mj_step`` calls (the walker's first torques held)."""
    import numpy as np

    from coop_ga.sim._mujoco import mj

    mujoco = mj()
    m, d = hs.model, hs.scene.make_data(q0, base_pose=pose)
    d.ctrl[hs.scene.actuator_index] = np.clip(walker._tau_ff if walker._started else 0.0, -1.5, 1.5)
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        mujoco.mj_step(m, d)
    return time.perf_counter() - t0, time.process_time() - c0


def main(argv: list[str] | None = None) -> int:
    from coop_ga.sim import Simulation

    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/sim_hexapod"))
    exp.add("--seconds", type=positive_float, default=4.0, help="simulated time per loop [s]")
    exp.add("--gait", choices=("tripod", "ripple", "wave"), default="tripod", help="gait of the walk")
    exp.add("--ci", action="store_true", help=f"small mode: {CI_SECONDS:g} s per loop (times meaningless)")
    args = exp.parse(argv)
    seconds = CI_SECONDS if args.ci else args.seconds
    with exp.stage("building the scene and the walker (stance-plane pose functions)"):
        hs, walker, q0, pose = _setup(args.gait)
    steps = round(seconds / hs.model.opt.timestep)
    sim = Simulation(hs.scene, walker, q=q0, base_pose=pose)
    with exp.stage(f"timing 2 loops × {steps} steps"):
        t0, c0 = time.perf_counter(), time.process_time()
        sim.step(steps)
        t_loop, c_loop = time.perf_counter() - t0, time.process_time() - c0
        t_bare, c_bare = _bare(hs, walker, q0, pose, steps)
    x = float(hs.scene.base_pose(sim.data)[0][0])
    assert x > 0.0 and sim.log().saturated_updates == 0, (x, sim.log().saturated_updates)  # it walked
    tm = walker.timing
    ctrl_s = tm["plan_s"] + tm["servo_s"]
    share = ctrl_s / c_loop  # both CPU seconds (the walker times itself with time.process_time)
    rows, records = [], []
    for name, t, c in ((ANCHOR, t_bare, c_bare), (LOOP, t_loop, c_loop)):
        rows.append([name, f"{1e6 * t / steps:.1f}", f"{t / t_bare:.2f}", f"{seconds / t:.2f}", f"{seconds / c:.2f}"])
        records.append(
            {
                "loop": name,
                "us_per_step": 1e6 * t / steps,
                "ratio": t / t_bare,
                "realtime": seconds / t,
                "cpu_us_per_step": 1e6 * c / steps,
                "realtime_cpu": seconds / c,
            }
        )
    print_table(
        f"hexapod {args.gait} walk on flat ground, Δt = 1 ms, {steps} steps per loop (same run)",
        ["loop", "µs/step", "ratio to anchor", "sim s / wall s", "sim s / CPU s"],
        rows,
    )
    realtime = seconds / t_loop
    per_plan = 1e6 * tm["plan_s"] / max(tm["plans"], 1)
    per_servo = 1e6 * tm["servo_s"] / max(tm["servo_calls"], 1)
    print(
        f"controller share of a tick: {100 * share:.1f} % (plans at 200 Hz: {per_plan:.0f} µs each; servo at 1 kHz: "
        f"{per_servo:.1f} µs each); real time with the controller: {realtime:.2f}× wall-clock "
        f"({'PASS' if realtime >= 1.0 else 'MISS'} ≥ 1), {seconds / c_loop:.2f}× per CPU second of one core "
        f"({'PASS' if seconds / c_loop >= 1.0 else 'MISS'} ≥ 1); load average {os.getloadavg()[0]:.1f}\n"
        f"check: walked {x:.3f} m, no clipped torque"
    )
    exp.write_json(
        "results.json",
        {
            "ci": bool(args.ci),
            "gait": args.gait,
            "steps": steps,
            "simulated_s": seconds,
            "rows": records,
            "controller_share": share,
            "plan_us": per_plan,
            "servo_us": per_servo,
            "plans": int(tm["plans"]),
            "realtime_with_controller": realtime,
            "realtime_with_controller_cpu": seconds / c_loop,
            "issue_target_realtime": "PASS" if realtime >= 1.0 else "MISS",
            "load_average": os.getloadavg()[0],
            "check": {"walked_m": x, "saturated_updates": 0},
        },
        digits=None,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
