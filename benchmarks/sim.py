#!/usr/bin/env python
"""Physics in the loop: real time with a controller at 1 kHz, and the cost of the cooperative wrench.

    python benchmarks/sim.py [--seconds 5] [--hold-seconds 4] [--ci] [--out results/benchmarks/sim] [--quiet]

Part 1 — three_franka + a 2 kg box with a joint PD controller.

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
the box stays on the floor.

Part 2 — three arms + box with the cooperative controller in the loop: the box-carry scenario of
:mod:`coop_ga.sim.carry` (three_iiwa14 with tools, a 2 kg box on a table,
:class:`coop_ga.sim.HoldController` every 1 ms step: task evaluation, similarity error, J̇q̇, the
cooperative wrench of the contact forces, Pinocchio dynamics, a 15-row operational-space solve) for
the first ``--hold-seconds`` of its plan (approach, close, squeeze, lift: contacts from 1.5 s).  The
anchor is the same run's logged controls replayed with bare ``mj_step`` in the same model (the physics
alone, the same contacts).  Printed: simulated seconds per wall second, the ratio to the anchor, the
controller's share of a tick, and CPU-time twins of each (the process's CPU time: on a shared machine
the wall clock also counts other processes' time slices).

Part 3 — the cooperative wrench (:func:`coop_ga.cooperative.wrench_map`) of three end-point forces on
the same task against one cooperative evaluation ``task.evaluate(q)`` (the issue's target: ≤ 1.5×),
the public calls and the hot-loop variants (``evaluate_views``), timed interleaved (best of repeats).

``--ci``: 0.2 s simulated per loop and few wrench repetitions (the CI test reads the JSON, never the
times).  Results go to ``<out>/results.json``.
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
    exp.add("--hold-seconds", type=positive_float, default=4.0, help="simulated time of the carry scenario [s]")
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
    with exp.stage("the carry scenario with the hold controller"):
        held = _hold(CI_SECONDS if args.ci else args.hold_seconds)
    with exp.stage("the cooperative wrench against task.evaluate"):
        wrench = _wrench(200 if args.ci else 5000, 3 if args.ci else 15)
    _print_hold(held, wrench)
    exp.write_json(
        "results.json",
        {
            "hold": held,
            "wrench": wrench,
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


def _hold(seconds: float) -> dict[str, Any]:
    """Part 2 (module docstring): the carry scenario for ``seconds``, timed (wall and CPU), its anchor."""
    import mujoco

    from coop_ga.cooperative import wrench_map
    from coop_ga.sim import Simulation, circle_target
    from coop_ga.sim.carry import CarryCase, carry_setup

    st = carry_setup(CarryCase("benchmark"))
    task, q0 = st.task, st.q_start
    # load every compiled entry point before the clock runs (first calls bind buffers, load libraries)
    task.evaluate(q0)
    task.error_and_jacobian(q0, circle_target((0.0, 0.0, 0.4), 0.3))
    task.jdot_qdot(q0, np.zeros_like(q0))
    wrench_map(task).command(task.points(q0))
    spent = {"wall": 0.0, "cpu": 0.0}

    def timed(t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> Any:
        w0, c0 = time.perf_counter(), time.process_time()
        tau = st.controller(t, q, qd, sensors)
        spent["wall"] += time.perf_counter() - w0
        spent["cpu"] += time.process_time() - c0
        return tau

    sim = Simulation(st.scene, timed, q=st.q_start)
    steps = round(seconds / st.scene.model.opt.timestep)
    w0, c0 = time.perf_counter(), time.process_time()
    sim.step(steps)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    log = sim.log()
    m, d = st.scene.model, mujoco.MjData(st.scene.model)
    d.qpos[:], d.qvel[:] = log.qpos[0], log.qvel[0]
    mujoco.mj_forward(m, d)
    w0, c0 = time.perf_counter(), time.process_time()
    for k in range(steps):  # the anchor: the same physics, the logged controls
        d.ctrl[:] = log.ctrl[k]
        mujoco.mj_step(m, d)
    a_wall, a_cpu = time.perf_counter() - w0, time.process_time() - c0
    replay_error = float(np.max(np.abs(d.qpos - log.qpos[-1])))
    return {
        "simulated_s": seconds,
        "steps": steps,
        "us_per_step": 1e6 * wall / steps,
        "cpu_us_per_step": 1e6 * cpu / steps,
        "anchor_us_per_step": 1e6 * a_wall / steps,
        "anchor_cpu_us_per_step": 1e6 * a_cpu / steps,
        "ratio": wall / a_wall,
        "realtime": seconds / wall,
        "realtime_cpu": seconds / cpu,
        "controller_share": spent["wall"] / wall,
        "controller_us_per_call": 1e6 * spent["wall"] / steps,
        "controller_cpu_us_per_call": 1e6 * spent["cpu"] / steps,
        "issue_target_realtime": "PASS" if seconds / wall >= 1.0 else "MISS",
        "check": {"replay_max_qpos_error": replay_error, "contacts_at_end": int(sim.data.ncon)},
    }


def _wrench(n: int, repeat: int) -> dict[str, Any]:
    """Part 3 (module docstring): interleaved best-of-``repeat`` times of ``n`` calls each [µs per call]."""
    from coop_ga.cooperative import wrench_map
    from coop_ga.sim.carry import carry_task

    task = carry_task()
    wm = wrench_map(task)
    q = np.asarray(task.system.q0, float)
    P = task.points(q)
    F = np.random.default_rng(0).normal(size=P.shape)
    T = np.zeros_like(F)
    flat = [P.reshape(-1).copy(), F.reshape(-1).copy(), T.reshape(-1).copy(), np.zeros(6)]
    calls = {
        "wrench": lambda: wm(P, F, T),
        "evaluate": lambda: task.evaluate(q),
        "wrench_views": lambda: wm.evaluate_views(flat[0], flat[1], flat[2], flat[3], 0.0),
        "evaluate_views": lambda: task.evaluate_views(q),
    }
    best = dict.fromkeys(calls, float("inf"))
    for f in calls.values():
        f()
    for _ in range(repeat):
        for name, f in calls.items():
            t0 = time.perf_counter()
            for _ in range(n):
                f()
            best[name] = min(best[name], (time.perf_counter() - t0) / n)
    us = {k: 1e6 * v for k, v in best.items()}
    ratio = us["wrench"] / us["evaluate"]
    return {
        "us_per_call": us,
        "ratio": ratio,
        "ratio_views": us["wrench_views"] / us["evaluate_views"],
        "instructions": {"wrench": wm.compiled.n_instructions, "evaluate": task.compiled.n_instructions},
        "issue_target_ratio": "PASS" if ratio <= 1.5 else "MISS",
    }


def _print_hold(hold: dict[str, Any], wrench: dict[str, Any]) -> None:
    print_table(
        f"three_iiwa14 + tools + 2 kg box, the hold controller at 1 kHz, {hold['steps']} steps (same run)",
        ["loop", "µs/step", "CPU µs/step", "ratio to anchor", "sim s / wall s", "sim s / CPU s"],
        [
            [
                "replayed controls, bare mj_step (anchor)",
                f"{hold['anchor_us_per_step']:.1f}",
                f"{hold['anchor_cpu_us_per_step']:.1f}",
                "1.00",
                "",
                "",
            ],
            [
                "Simulation + HoldController",
                f"{hold['us_per_step']:.1f}",
                f"{hold['cpu_us_per_step']:.1f}",
                f"{hold['ratio']:.2f}",
                f"{hold['realtime']:.2f}",
                f"{hold['realtime_cpu']:.2f}",
            ],
        ],
    )
    print(
        f"controller share of a tick: {100 * hold['controller_share']:.1f} % ({hold['controller_us_per_call']:.0f} µs "
        f"per call, {hold['controller_cpu_us_per_call']:.0f} µs CPU); real time: {hold['realtime']:.2f}× "
        f"({hold['issue_target_realtime']} ≥ 1)"
    )
    us = wrench["us_per_call"]
    print(
        f"cooperative wrench {us['wrench']:.2f} µs vs task.evaluate {us['evaluate']:.2f} µs: "
        f"{wrench['ratio']:.2f}× ({wrench['issue_target_ratio']} ≤ 1.5); hot paths {us['wrench_views']:.2f} vs "
        f"{us['evaluate_views']:.2f} µs ({wrench['ratio_views']:.2f}×)"
    )


if __name__ == "__main__":
    raise SystemExit(main())
