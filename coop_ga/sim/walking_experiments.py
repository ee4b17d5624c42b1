"""The runs of the physics walking experiments (``experiments/sim_hexapod_walk.py``, ``sim_hexapod_ablation.py``):
one function per row, importable, so that the scripts can spread rows over worker processes.

* :func:`straight_command` — a straight walk at the gait's nominal speed (a stance stroke of 0.08 m: 0.10 /
  0.05 / 0.024 m/s for tripod / ripple / wave) over a distance, ramped in and out over one gait cycle (half a
  cycle, with the acceleration limit raised to match, for the short ``fast`` walks);
* :func:`row_terrain` — a row's terrain (the short walks' staircase starts at :data:`FAST_STEPS_START`);
* :func:`walk_row` — one gait × terrain × (map | blind) run: simulated, saved (``model.xml``, ``log.npz``,
  ``metrics.json``) and rendered to a GIF on request; returns its metrics;
* :func:`ablation_row` — one (variant, disturbance) run of the ablation (:data:`VARIANTS`, :data:`DISTURBANCES`),
  saved the same way.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from .walking import VelocityCommand, WalkingOptions
from .walking_run import render_walk, simulate_walk

__all__ = [
    "DISTURBANCES",
    "FAST_STEPS_START",
    "VARIANTS",
    "ablation_row",
    "disturbance_scenario",
    "row_terrain",
    "straight_command",
    "walk_row",
]

#: the ablation's variants: the closed-loop walker, touchdown from contacts without the stance primitive's
#: feedback, the open-loop replay of the kinematic plan
VARIANTS: tuple[str, ...] = ("feedback", "contacts_only", "open_loop")
#: the ablation's disturbances, unknown to the planner: a 3 cm step, a 10 N lateral push, a 5° slope
DISTURBANCES: tuple[str, ...] = ("step", "push", "slope")


def straight_command(gait: str, distance: float, fast: bool = False) -> tuple[VelocityCommand, WalkingOptions, float]:
    """``(command, options, duration [s])`` of a straight walk of ``distance`` [m] (module docstring)."""
    opt = WalkingOptions(gait=gait)
    tab = opt.table()
    v = 0.08 / (tab.duty * tab.period)
    ramp = (0.5 if fast else 1.0) * tab.period
    if fast:
        opt = replace(opt, max_accel=v / ramp)
    cruise = max(distance / v - ramp, 0.0)
    cmd = VelocityCommand.constant(v, ramp=ramp, duration=cruise + 2 * ramp)
    return cmd, opt, float(cmd.end + (0.3 if fast else 0.5 * tab.period))


def run_name(gait: str, terrain: str, blind: bool) -> str:
    """``<gait>_<terrain>_<map|blind>``."""
    return f"{gait}_{terrain}_{'blind' if blind else 'map'}"


#: the first riser of the short walks' staircase [m]: the middle feet (x = 0) climb it and the front feet (x = 0.233 m,
#: on the first tread from the start) the second riser within their first swing; the default staircase's first
#: riser (x = 0.15 m) would meet no foot in a 0.08 m walk
FAST_STEPS_START = 0.05


def row_terrain(terrain: str, seed: int = 0, fast: bool = False) -> Any:
    """The :class:`~coop_ga.legged.Terrain` of a row: ``Terrain.make(terrain, seed=seed)``, except the short walks'
    steps, which start at :data:`FAST_STEPS_START`."""
    from ..legged import Terrain

    if fast and terrain == "steps":
        return Terrain.steps(start_x=FAST_STEPS_START)
    return Terrain.make(terrain, seed=seed)


def walk_row(
    gait: str,
    terrain: str,
    blind: bool,
    *,
    distance: float = 1.0,
    fast: bool = False,
    tour: bool = False,
    out: str | Path | None = None,
    gif: bool = False,
    seed: int = 0,
) -> dict[str, Any]:
    """Simulate one row (module docstring) on :func:`row_terrain`; with ``out``, save its replayable folder
    ``out/<name>/`` (:meth:`~coop_ga.sim.walking_run.WalkRun.save`); returns its metrics (plus ``wall_s``)."""
    name = run_name(gait, terrain, blind)
    cmd, opt, duration = straight_command(gait, distance, fast)
    if tour:
        cmd = VelocityCommand.tour(float(cmd.values[1, 0]), 0.1, leg=2.0 if fast else 4.0)
        duration = cmd.end + opt.period
    opt = replace(opt, blind=blind)
    t0 = time.perf_counter()
    run = simulate_walk(row_terrain(terrain, seed, fast), cmd, opt, duration=duration, label=name, visuals=gif)
    m = dict(run.metrics())
    m["wall_s"] = time.perf_counter() - t0
    if out is not None:
        run.save(Path(out) / name)
    if out is not None and gif:
        render_walk(run, Path(out) / f"walk_{name}.gif", fps=8.0 if fast else 5.0, width=360, height=270)
    return m


def disturbance_scenario(disturbance: str, t_push: float) -> tuple[Any, tuple[Any, ...]]:
    """``(terrain, disturbances)`` of a disturbance of :data:`DISTURBANCES`: an unknown 3 cm step up at x = 0.15 m,
    a 10 N push along +y on the body from ``t_push`` for 0.3 s on flat ground, an unknown 5° slope up along +x."""
    from ..legged import Terrain
    from .simulation import Disturbance

    if disturbance == "step":
        return Terrain.steps(step_height=0.03, step_length=10.0, start_x=0.15, n_steps=1), ()
    if disturbance == "slope":
        return Terrain.slope(math.radians(5.0)), ()
    if disturbance == "push":
        return Terrain.flat(), (Disturbance("base_link_free", force=(0.0, 10.0, 0.0), start=t_push, stop=t_push + 0.3),)
    raise InvalidInputError(f"disturbance must be one of {DISTURBANCES}, got {disturbance!r}")


def ablation_row(
    variant: str, disturbance: str, distance: float, fast: bool = False, out: str | Path | None = None
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """One blind tripod walk of ``distance`` [m] of the ablation (module docstring; ``fast``: the short ramps of
    :func:`straight_command`): its metrics and its time series (``t``, ``roll``, ``pitch`` [°] every few steps,
    ``t_plan``, ``height_error`` [m] per plan).  With ``out``, its replayable folder ``out/<variant>_<disturbance>/``
    (:meth:`~coop_ga.sim.walking_run.WalkRun.save`).

    Raises:
        InvalidInputError: an unknown variant or disturbance.
    """
    validation.choice(variant, VARIANTS, "variant")
    validation.choice(disturbance, DISTURBANCES, "disturbance")
    cmd, base, duration = straight_command("tripod", distance, fast)
    opt = {
        "feedback": replace(base, blind=True),
        "contacts_only": replace(base, blind=True, posture_gain=0.0),
        "open_loop": replace(base, blind=True, feedback=False),
    }[variant]
    t_push = 0.3 + 0.5 * float(cmd.end)
    terrain, dist = disturbance_scenario(disturbance, t_push)
    t0 = time.perf_counter()
    run = simulate_walk(terrain, cmd, opt, duration=duration, disturbances=dist, label=f"{variant}_{disturbance}")
    m = dict(run.metrics())
    m["wall_s"] = time.perf_counter() - t0
    m["variant"], m["disturbance"] = variant, disturbance
    if out is not None:
        run.save(Path(out) / run.label)
    rpy = np.degrees(run.rpy())
    th, he = run.height_errors()
    step = max(1, len(run.log.time) // 600)
    series = {
        "t": run.log.time[::step],
        "roll": rpy[::step, 0],
        "pitch": rpy[::step, 1],
        "t_plan": th,
        "height_error": he,
    }
    return m, series
