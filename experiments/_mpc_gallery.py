"""What the two closed-loop MPC experiments (``sim_mpc_track.py``, ``sim_mpc_carry.py``) share: simulating their
cases and writing the gallery folder.

Every number of ``metrics.json`` depends on the cases alone (the MPC's budget is a count of iterations, the
physics is MuJoCo's, the seeds are fixed), so a re-run leaves it byte-identical; every wall-clock number (the
ticks' times, the overruns of the period, the load, the simulations' and the rendering's wall time) goes to
``timing.json`` (untracked).  The rate itself is measured by ``benchmarks/mpc.py``.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from typing import Any

from coop_ga.harness import Experiment

#: the tick-time figure: wall clock, so untracked like timing.json (.gitignore)
TIMING_FIGURE = "timing.png"


def simulate_cases(
    exp: Experiment,
    cases: Sequence[Any],
    simulate: Callable[[Any], tuple[Any, dict[str, Any], dict[str, Any]]],
    name: Callable[[Any], str] = lambda case: str(case.name),
) -> tuple[list[Any], list[dict[str, Any]], dict[str, Any]]:
    """``simulate(case) -> (run, metrics, timing)`` for every case (named by ``name(case)``): ``(runs, metrics,
    timing by case name)``; prints whether each run holds its claims (its metrics' ``failures``)."""
    runs, per, timing = [], [], {}
    for case in cases:
        label = name(case)
        with exp.stage(f"simulating {label}"):
            t = time.perf_counter()
            run, m, timing[label] = simulate(case)
            timing[label]["run_and_metrics_s"] = time.perf_counter() - t
        runs.append(run)
        per.append(m)
        if not exp.quiet:
            print(f"  {label}: {'ok' if not m['failures'] else 'FAILED: ' + '; '.join(m['failures'])}")
    return runs, per, timing


def summary_head(experiment: str, per: list[dict[str, Any]], fast: bool, name: Callable[[dict[str, Any]], str]) -> dict:
    """The summary's common keys: the experiment, ``fast``, the runs and how many hold their claims, the failures
    by run (``name(metrics)``)."""
    return {
        "experiment": experiment,
        "fast": fast,
        "runs_count": len(per),
        "success_count": sum(not m["failures"] for m in per),
        "failures": {name(m): m["failures"] for m in per if m["failures"]},
    }


def tick_timing(timing: dict[str, Any], names: Sequence[str]) -> dict[str, Any]:
    """The worst of the runs ``names`` (their :func:`~coop_ga.sim.mpc_track.mpc_timing`): median / p95 / max tick
    [s], overruns and ticks, with the load average (wall clock on a shared machine)."""
    runs = [timing[n] for n in names]
    return {
        "load_average": list(os.getloadavg()),
        "tick_median_s": max(r["tick_s"]["median"] for r in runs),
        "tick_p95_s": max(r["tick_s"]["p95"] for r in runs),
        "tick_max_s": max(r["tick_s"]["max"] for r in runs),
        "overruns": sum(r["overruns"] for r in runs),
        "ticks": sum(r["ticks"] for r in runs),
    }


def tick_sentence(per: list[dict[str, Any]], instants: Sequence[int]) -> str:
    """The evidence's sentence on the ticks, from deterministic numbers only; ``instants``: each run's tick
    instants (its simulated tracking time over the period)."""
    ticks, total = sum(m["mpc_ticks"] for m in per), sum(instants)
    warm = max(m["iterations_per_tick"]["median"] for m in per)
    period = per[0]["period_s"]
    solved = (
        "every one re-planned"
        if ticks == total
        else f"{ticks} re-planned, the other {total - ticks} answered with the braking fallback from an infeasible "
        "state (counted in the runs' fallbacks)"
    )
    return (
        f"MPC: {total} tick instants (one per {1000 * period:.0f} ms of simulated time), {solved}; none skipped; "
        f"{warm:.0f} iLQR iterations per warm tick (a count, not a time: the runs do not depend on the machine); "
        "the ticks' wall times are in timing.json, the sustained rate in benchmarks/mpc.py."
    )


def write_gallery(
    exp: Experiment,
    runs: list[Any],
    summary: dict[str, Any],
    timing: dict[str, Any],
    plot: Callable[[Experiment, list[Any]], str],
    render: Callable[[Experiment, Any], str] | None,
    gallery: Callable[[dict[str, Any], list[str]], dict[str, Any]],
) -> None:
    """Write the folder: the first run's ``model.xml`` + ``log.npz``, the figure (``plot``), the GIF (``render``,
    unless None), ``metrics.json`` (the first run's log fields, ``summary`` and the ``gallery`` block) and
    ``timing.json`` (``timing`` and the rendering's wall time)."""
    t0 = time.perf_counter()
    runs[0].log.save(exp.out)  # model.xml, log.npz (metrics.json rewritten below)
    figures = [plot(exp, runs)]
    if render is not None:
        t = time.perf_counter()
        figures.append(render(exp, runs[0]))
        timing["render_s"] = time.perf_counter() - t
    metrics = {**runs[0].log.metrics(), **summary}
    metrics["gallery"] = gallery(metrics, figures)
    exp.write_json("metrics.json", metrics)
    timing["write_s"] = time.perf_counter() - t0
    exp.write_timing(timing)
    if not exp.quiet:
        print(metrics["gallery"]["evidence"])


def render_gif(exp: Experiment, log: Any, name: str, camera: Any, overlays: Callable[[int, Any], list[Any]]) -> str:
    """The MuJoCo offscreen GIF of ``log`` at 10 frames/s (400 × 300 with ``--fast``, else 640 × 480); returns
    ``name``."""
    from coop_ga.sim import render

    w, h = (400, 300) if exp.fast else (640, 480)
    render.render_log(log, exp.out / name, fps=10.0, width=w, height=h, camera=camera, overlays=overlays)
    return name


def plot_tick_times(exp: Experiment, series: Sequence[tuple[str, Sequence[Any]]], period: float) -> str:
    """``timing.png`` (untracked, like ``timing.json``): every run's MPC tick wall times [ms] against the simulated
    time, with the period; ``series``: (run name, its :class:`~coop_ga.control.mpc.MPCTick` s)."""
    plt = exp.pyplot()
    fig, a = plt.subplots(figsize=(7, 4))
    for name, ticks in series:
        a.plot([k.time for k in ticks], [1000 * k.tick_time for k in ticks], ".", ms=2, label=name)
    a.axhline(1000 * period, color="r", ls="--", lw=0.8, label="period")
    a.set_yscale("log")
    a.set_ylabel("MPC tick, wall [ms]")
    a.set_xlabel("t [s] (simulated)")
    a.set_title(f"MPC tick wall times (load {os.getloadavg()[0]:.1f})", fontsize=9)
    a.legend(fontsize=6)
    fig.tight_layout()
    exp.save(fig, TIMING_FIGURE)
    plt.close(fig)
    return TIMING_FIGURE
