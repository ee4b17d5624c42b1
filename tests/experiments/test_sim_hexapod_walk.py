"""Rows of the physics walk (gait × terrain, with the map and blind) as short walks against the issue's bar; the
experiment script's files, and that its saved log replays with MuJoCo alone."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("mujoco")

import numpy as np

from coop_ga.sim import replay
from coop_ga.sim.walking_experiments import walk_row
from coop_ga.sim.walking_run import BAR
from tests.helpers import read_metrics, script_main

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "sim_hexapod_walk.py"
GALLERY = Path(__file__).resolve().parents[2] / "paper_figures" / "ours_sim_hexapod_walk"
ABLATION = GALLERY.parent / "ours_sim_hexapod_ablation"
#: the gallery runs with a GIF (experiments/sim_hexapod_walk.py's DEFAULT_GIFS)
DEFAULT_GIFS = ("tripod_flat_map", "ripple_steps_blind", "wave_random_map")

#: a subset of the 24 gait × terrain × (map | blind) rows in the test budget (the experiment, ``--all``, runs every
#: row; the script test below adds tripod_flat_map, the ablation's test the blind tripod on an unknown step and
#: slope): the experiment's short walks (ramped in and out over half a cycle; the staircase starts at x = 0.05 m,
#: so that the middle and front feet climb a riser).  ripple/steps/blind: the right front foot's swing ends 1 mm
#: short of the second riser; its probe (coop_ga.sim.walking_blind) finds the riser first — without it
#: (``probe_guard=0``) the shin leans on the riser's edge for 1796 physics steps.  The wave gait's short walk takes
#: 4.3 simulated s: left to the experiment.
ROWS = [
    ("tripod", "steps", True),
    ("ripple", "steps", True),
    ("ripple", "random", True),
]


@pytest.mark.parametrize(("gait", "terrain", "blind"), ROWS, ids=["_".join(map(str, r)) for r in ROWS])
def test_short_walk_meets_the_bar(gait: str, terrain: str, blind: bool, tmp_path: Path) -> None:
    m = walk_row(gait, terrain, blind, distance=0.0, fast=True, out=tmp_path)
    assert m["walked_fraction"] >= BAR["walked_fraction"], m
    assert not m["fell"], m
    assert max(m["max_roll_deg"], m["max_pitch_deg"]) <= BAR["max_tilt_deg"]
    assert m["max_height_error_m"] <= BAR["max_height_error_m"]
    assert m["max_slip_m"] <= BAR["max_slip_m"], m
    assert m["saturated_updates"] == 0 and m["effort_ratio"] <= 1.0, m
    assert m["shin_contact_steps"] == 0, m
    assert m["passed"]
    if (gait, terrain, blind) == ("tripod", "steps", True):
        _front_feet_land_on_treads(tmp_path / "tripod_steps_blind")


def _front_feet_land_on_treads(folder: Path) -> None:
    """Blind on the staircase, from the saved log alone (MuJoCo forward kinematics of ``qpos``): every touchdown
    of a front foot (its leg entering the stance set) puts the 9 mm ball on a tread — its bottom within 2 mm of
    the tread's height — and clear of the next riser's face by more than its radius + 5 mm (a foot set down
    against a riser leaves the shin leaning on its edge); and a front foot climbs the second riser (lands on the
    second step's tread, x > 0.30 m).  Measured to fail where it should: the short blind ripple walk without its
    probe guard (``probe_guard=0``) sets the right front foot down 10.0 mm from the riser (1502 shin steps)."""
    import mujoco

    from coop_ga.legged.terrain import Terrain

    model = mujoco.MjModel.from_xml_path(str(folder / "model.xml"))
    data = mujoco.MjData(model)
    with np.load(folder / "log.npz") as z:
        log = {k: z[k] for k in ("qpos", "stance", "legs", "terrain_x_edges")}
        terrain = Terrain.from_arrays(z)
    edges = log["terrain_x_edges"]
    r = float(model.geom(f"{log['legs'][0]}_foot_capsule3").size[0])
    assert r == pytest.approx(0.009)  # the foot's collision ball, centred on the foot site
    landings = []
    for i, leg in enumerate(log["legs"]):
        if not leg.endswith("f"):
            continue
        site = model.site(f"{leg}_foot").id
        for k in np.flatnonzero(log["stance"][1:, i] & ~log["stance"][:-1, i]) + 1:
            data.qpos[:] = log["qpos"][k]
            mujoco.mj_kinematics(model, data)
            p = data.site_xpos[site].copy()
            ahead = edges[edges > p[0]]
            landings.append(
                (leg, p, float(p[2] - r - terrain.height(p[:2])), ahead.min() - p[0] if len(ahead) else 1.0)
            )
    assert len(landings) >= 2, landings
    for leg, p, lift, gap in landings:
        assert abs(lift) <= 0.002 and gap > r + 0.005, (leg, p, lift, gap)
    assert max(p[0] for _, p, _, _ in landings) > edges[1], landings


def test_script_writes_the_run_files_and_the_table(tmp_path) -> None:
    out = tmp_path / "walk"
    assert script_main(SCRIPT)(["--gait", "tripod", "--terrain", "flat", "--fast", "--quiet", "--out", str(out)]) == 0
    doc = read_metrics(out)
    run = doc["runs"]["tripod_flat_map"]
    assert run["passed"] and doc["all_passed"] and doc["gallery"]["agrees"]
    assert run["walked_fraction"] >= 0.95 and run["max_slip_m"] <= 0.005 and run["shin_contact_steps"] == 0
    assert (out / "walk_tripod_flat_map.gif").stat().st_size > 10_000
    assert "tripod_flat_map" in (out / "table.md").read_text()
    folder = out / "tripod_flat_map"
    assert {p.name for p in folder.iterdir()} >= {"model.xml", "log.npz", "metrics.json"}
    assert read_metrics(folder)["walk"]["label"] == "tripod_flat_map"
    assert replay(folder) == 0.0  # MuJoCo alone re-simulates the log bit for bit
    with np.load(folder / "log.npz") as z:
        T = len(z["time"])
        assert z["body_pose"].shape == (T, 7) and z["stance"].shape == (T, 6) and z["stance"].dtype == bool


def test_the_gallery_logs_replay_with_mujoco_alone() -> None:
    """Every committed gallery run (24 walks, 9 ablation rows) has its model.xml + log.npz; a sample of them (the
    GIF runs and an ablation row, to keep the suite fast) re-simulates exactly with ``mujoco`` and ``numpy`` only;
    the body is the model's free joint (its qpos is ``body_pose``)."""
    import mujoco

    folders = sorted(p.parent for p in GALLERY.glob("*/log.npz"))
    ablation = sorted(p.parent for p in ABLATION.glob("*/log.npz"))
    assert len(folders) == 24 and len(ablation) == 9, (folders, ablation)
    for folder in [*folders, *ablation]:
        assert (folder / "model.xml").stat().st_size > 0 and (folder / "metrics.json").exists(), folder
    for folder in [GALLERY / name for name in DEFAULT_GIFS] + [ABLATION / "feedback_push"]:
        assert replay(folder) == 0.0, folder
        model = mujoco.MjModel.from_xml_path(str(folder / "model.xml"))
        assert model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
        with np.load(folder / "log.npz") as z:
            assert np.array_equal(z["qpos"][:, :7], z["body_pose"])
            assert len(z["ctrl"]) == z["state_rows"][-1] + 1  # a control per physics step


def test_every_gallery_walk_meets_the_bar_and_its_log_agrees() -> None:
    """The 24 committed short walks (``python -m paper_figures``: every gait × terrain, with the map and blind)
    each pass every entry of the bar in their metrics; and their logs back the numbers the bar reads: the body's
    travel (free joint ``qpos``) is the reported distance and ≥ 95 % of the commanded one, its roll and pitch stay
    within 10°, and no control exceeds the URDF effort limit (the actuators' ``ctrlrange``)."""
    import mujoco

    folders = sorted(p.parent for p in GALLERY.glob("*/log.npz"))
    assert len(folders) == 24
    for folder in folders:
        w = read_metrics(folder)["walk"]
        assert w["passed"] and not w["fell"], folder
        assert w["walked_fraction"] >= BAR["walked_fraction"] and w["max_slip_m"] <= BAR["max_slip_m"], w
        assert max(w["max_roll_deg"], w["max_pitch_deg"]) <= BAR["max_tilt_deg"], w
        assert w["max_height_error_m"] <= BAR["max_height_error_m"] and w["shin_contact_steps"] == 0, w
        assert w["saturated_updates"] == 0 and w["effort_ratio"] <= 1.0, w
        model = mujoco.MjModel.from_xml_path(str(folder / "model.xml"))
        with np.load(folder / "log.npz") as z:
            pose, ctrl = z["body_pose"], z["ctrl"]
        travel = pose[-1, :2] - pose[0, :2]
        assert np.linalg.norm(travel) == pytest.approx(w["distance_m"], abs=1e-9), folder
        assert travel[0] >= BAR["walked_fraction"] * w["commanded_distance_m"], (folder, travel)
        xq, yq = (
            pose[:, 4],
            pose[:, 5],
        )  # quaternion (w, x, y, z): the body's z axis in the world: its tilt bounds roll and pitch
        tilt = np.degrees(np.arccos(np.clip(1.0 - 2.0 * (xq**2 + yq**2), -1.0, 1.0)))
        assert tilt.max() <= BAR["max_tilt_deg"], (folder, tilt.max())
        assert np.all(np.abs(ctrl) <= model.actuator_ctrlrange[:, 1] + 1e-6), folder


def test_help_and_bad_values(capsys) -> None:
    with pytest.raises(SystemExit) as ex:
        script_main(SCRIPT)(["--help"])
    assert ex.value.code == 0
    text = capsys.readouterr().out
    for opt in ("--gait", "--terrain", "--blind", "--all", "--fast", "--jobs", "--gifs", "--command"):
        assert opt in text
    with pytest.raises(SystemExit) as ex:
        script_main(SCRIPT)(["--terrain", "ice"])
    assert ex.value.code == 2
