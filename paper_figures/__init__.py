"""The paper's figures: what makes each one, and where it goes.

``python -m paper_figures --out DIR`` (see :mod:`paper_figures.__main__`) runs every entry
of :data:`FIGURES` into ``DIR/<folder>/`` and writes the gallery ``DIR/README.md``.  Each
entry is an experiment script (``experiments/*.py``, or ``paper_figures/systems.py``) with
the harness command line; every script writes ``metrics.json`` with a ``gallery`` block
(``title``, ``claim``, ``evidence``, ``agrees``, ``figures``) that the gallery shows.
"""

from __future__ import annotations

import importlib.util
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

__all__ = ["FIGURES", "ROOT", "Figure", "load_script", "select"]

#: the repository root (scripts are addressed relative to it)
ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Figure:
    """One output folder of the gallery.

    key: the id used by ``--only`` (``fig07``, ``fig16_17``, ``table01``, ``systems``).
    folder: ``DIR/<folder>/`` (``figNN_<short name>``, NN the paper's number).
    script: path of the script relative to :data:`ROOT`.  args: its extra arguments.
    numbers: the paper's figure (or table) numbers the folder holds.
    addition: True for our own additions beyond the paper (hexapod, obstacles, linkages, …):
    their folders are ``ours_<name>`` and the gallery lists them after the paper's figures.
    """

    key: str
    folder: str
    script: str
    args: tuple[str, ...] = ()
    numbers: tuple[int, ...] = ()
    addition: bool = False

    @property
    def command(self) -> str:
        """The command that makes this folder alone."""
        return f"python -m paper_figures --only {self.key}"

    def script_command(self, out: str) -> str:
        """The script's own command line writing into ``out``."""
        return " ".join(["python", self.script, *self.args, "--out", out])


FIGURES: tuple[Figure, ...] = (
    Figure("systems", "systems", "paper_figures/systems.py"),
    Figure("fig05_06", "fig05_06_impedance", "experiments/impedance_three_iiwa.py", numbers=(5, 6)),
    Figure("fig07", "fig07_line_g1_arms", "experiments/reaching.py", ("--figure", "fig07"), (7,)),
    Figure("fig08", "fig08_circle_three_franka", "experiments/circle_reaching.py", numbers=(8,)),
    Figure("fig09", "fig09_circle_g1_torso_arms", "experiments/reaching.py", ("--figure", "fig09"), (9,)),
    Figure("fig10", "fig10_circle_franka_and_g1", "experiments/reaching.py", ("--figure", "fig10"), (10,)),
    Figure("fig11", "fig11_plane_three_finger_hand", "experiments/reaching.py", ("--figure", "fig11"), (11,)),
    Figure("fig12", "fig12_sphere_allegro", "experiments/reaching.py", ("--figure", "fig12"), (12,)),
    Figure("fig13", "fig13_sphere_two_g1", "experiments/reaching.py", ("--figure", "fig13"), (13,)),
    Figure("fig14_15", "fig14_15_line_constraint", "experiments/line_constraint.py", numbers=(14, 15)),
    Figure("fig16_17", "fig16_17_nullspace", "experiments/nullspace_secondary.py", numbers=(16, 17)),
    Figure("fig18_19", "fig18_19_singularity", "experiments/singularity.py", numbers=(18, 19)),
    Figure("fig20_21", "fig20_21_teleop", "experiments/teleop_allegro.py", numbers=(20, 21)),
    Figure("table01", "table01_controllable_spaces", "experiments/table1.py", numbers=()),
    # our additions (not in the paper)
    Figure(
        "hexapod_walk_tripod_flat",
        "ours_hexapod_walk_tripod_flat",
        "experiments/hexapod_walk.py",
        ("--gait", "tripod", "--terrain", "flat", "--distance", "0.3", "--dt", "0.04", "--frames", "16"),
        addition=True,
    ),
    Figure(
        "hexapod_walk_ripple_steps",
        "ours_hexapod_walk_ripple_steps",
        "experiments/hexapod_walk.py",
        ("--gait", "ripple", "--terrain", "steps", "--distance", "0.3", "--dt", "0.04", "--frames", "16"),
        addition=True,
    ),
    Figure(
        "hexapod_walk_wave_random",
        "ours_hexapod_walk_wave_random",
        "experiments/hexapod_walk.py",
        ("--gait", "wave", "--terrain", "random", "--distance", "0.2", "--dt", "0.04", "--frames", "16"),
        addition=True,
    ),
    Figure(
        "hexapod_posture",
        "ours_hexapod_posture",
        "experiments/hexapod_posture.py",
        ("--phase-time", "0.6", "--dt", "0.02"),
        addition=True,
    ),
    Figure("obstacles", "ours_obstacle_circle", "experiments/obstacle_circle.py", addition=True),
    Figure("potential_field", "ours_potential_field", "experiments/potential_field.py", addition=True),
    Figure("linkages", "ours_linkages", "experiments/linkages.py", addition=True),
    # constrained planning over a cooperative region (OMPL): the gallery runs the script's --fast version
    Figure("planning_box_lift", "ours_planning_box_lift", "experiments/plan_box_lift.py", ("--fast",), addition=True),
    Figure(
        "sim_plan_box_lift",
        "ours_planning_box_lift_execution",
        "experiments/sim_plan_box_lift.py",
        ("--fast",),
        addition=True,
    ),
    # physics in the loop (MuJoCo): the gallery runs the scripts' --fast (gallery-length) version
    Figure("sim_box_carry", "ours_sim_box_carry", "experiments/sim_box_carry.py", ("--fast",), addition=True),
    Figure(
        "sim_box_no_squeeze",
        "ours_sim_box_no_squeeze",
        "experiments/sim_box_carry.py",
        ("--fast", "--no-squeeze"),
        addition=True,
    ),
    Figure("sim_ball_hold", "ours_sim_ball_hold", "experiments/sim_ball_hold.py", ("--fast",), addition=True),
    Figure(
        "sim_human_partner", "ours_sim_human_partner", "experiments/sim_human_partner.py", ("--fast",), addition=True
    ),
    Figure("sim_mpc_track", "ours_mpc_track", "experiments/sim_mpc_track.py", ("--fast",), addition=True),
    Figure("sim_mpc_carry", "ours_mpc_carry", "experiments/sim_mpc_carry.py", ("--fast",), addition=True),
    Figure(
        "sim_hexapod_walk",
        "ours_sim_hexapod_walk",
        "experiments/sim_hexapod_walk.py",
        ("--all", "--fast", "--jobs", "2"),
        addition=True,
    ),
    Figure(
        "sim_hexapod_ablation",
        "ours_sim_hexapod_ablation",
        "experiments/sim_hexapod_ablation.py",
        ("--fast", "--jobs", "2"),
        addition=True,
    ),
)


def select(names: list[str] | None) -> list[Figure]:
    """The figures named by ``--only`` values, in gallery order.

    A name matches an entry's key or folder (``fig16_17``, ``fig16_17_nullspace``), or a
    single figure number it holds (``fig12``, ``fig17``, ``17``, ``table1``/``table01``).
    Raises ``ValueError`` naming the valid choices for an unknown name.
    """
    if not names:
        return list(FIGURES)
    chosen: list[Figure] = []
    for name in names:
        n = name.strip().lower()
        hits = [f for f in FIGURES if n in (f.key, f.folder)]
        if not hits:
            m = re.fullmatch(r"(fig|table)?0*(\d+)", n)
            if m:
                num = int(m.group(2))
                if m.group(1) == "table":
                    hits = [f for f in FIGURES if f.key == f"table{num:02d}"]
                else:
                    hits = [f for f in FIGURES if num in f.numbers]
        if not hits:
            valid = ", ".join(f.key for f in FIGURES)
            raise ValueError(f"unknown figure {name!r}: choose from {valid} (or a figure number such as fig17)")
        chosen += [f for f in hits if f not in chosen]
    return [f for f in FIGURES if f in chosen]


def load_script(script: str | Path) -> Callable[[list[str] | None], int]:
    """Import a script by path (relative to :data:`ROOT`) and return its ``main``."""
    path = Path(script)
    path = path if path.is_absolute() else ROOT / path
    name = f"_paper_figures_{path.stem}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load {path}")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod  # dataclasses defined in a script look their module up here
    spec.loader.exec_module(mod)
    main: Callable[[list[str] | None], int] = mod.main
    return main
