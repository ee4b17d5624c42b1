"""The reaching figures (Figs. 7–13, experiments/reaching.py): every preset in --fast mode.

Each preset must converge inside the joint limits, draw both figures, write strict JSON with
the four common keys and a gallery block, and be reproducible byte for byte.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "reaching.py"
_NAME = "test_reaching_script"


def _module():
    mod = sys.modules.get(_NAME)
    if mod is None:
        spec = importlib.util.spec_from_file_location(_NAME, SCRIPT)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[_NAME] = mod  # the script's dataclasses look their module up here
        spec.loader.exec_module(mod)
    return mod


FIGURES = ("fig07", "fig08", "fig09", "fig10", "fig11", "fig12", "fig13")
KIND = {
    "fig07": "line",
    "fig08": "circle",
    "fig09": "circle",
    "fig10": "circle",
    "fig11": "plane",
    "fig12": "sphere",
    "fig13": "sphere",
}
DOF = {"fig07": 17, "fig08": 21, "fig09": 17, "fig10": 24, "fig11": 12, "fig12": 16, "fig13": 34}


def _strict(text: str) -> dict:
    def bad(name):
        raise AssertionError(f"non-strict JSON constant {name}")

    return json.loads(text, parse_constant=bad)


@pytest.fixture(scope="module", params=FIGURES)
def run(request, tmp_path_factory):
    fig = request.param
    out = tmp_path_factory.mktemp(f"reaching_{fig}")
    assert _module().main(["--figure", fig, "--fast", "--quiet", "--out", str(out)]) == 0
    return fig, out, _strict((out / "metrics.json").read_text())


def test_presets_are_the_issue_table():
    mod = _module()
    assert mod.FIGURES == FIGURES
    for fig, p in mod.PRESETS.items():
        assert p.kind == KIND[fig] and p.paper_dof == DOF[fig]
    assert mod.PRESETS["fig13"].system == "two_g1" and mod.PRESETS["fig07"].system == "g1_arms"


def test_converges_inside_the_limits(run):
    from coop_ga.control.ilqr import ILQROptions

    fig, _, m = run
    tol = ILQROptions().tol
    assert m["tol"] == tol
    # the four keys of every reaching figure, at the top level
    assert m["converged"] is True, m["ilqr_message"]
    assert 0.0 <= m["terminal_error"] < tol
    assert 1 <= m["iterations"] <= 5  # the paper: "typically ... five or less iterations"
    assert m["max_limit_violation"] == 0.0
    assert m["joint_limit_violation_rad"] == 0.0
    assert m["velocity_limit_violation_rad_s"] == 0.0 and m["acceleration_limit_violation_rad_s2"] == 0.0
    assert m["ilqr_converged"] is True and m["ilqr_iterations"] == m["iterations"]
    assert m["reachable_by_gauss_newton_ik"] is True
    assert m["initial_error"] > 0.1  # a real motion, not a target at the start
    assert m["fast"] is True and m["horizon"] == 100 and m["horizon_s"] == pytest.approx(2.5)
    assert m["kind"] == KIND[fig] and m["dof"] == m["nq"] == DOF[fig] == m["paper_dof"]
    hist = m["terminal_error_history"]
    assert len(hist) == m["iterations"] + 1 and hist[-1] == pytest.approx(m["terminal_error"])
    # no wall-clock time in the committed metrics; they are in timing.json
    assert not [k for k in m if k.endswith("_s") and "time" in k]
    assert all("time_s" not in x for x in m["ilqr_iteration_stats"])


def test_final_primitive_is_the_target(run):
    fig, _, m = run
    kind = KIND[fig]
    assert f"initial_{kind}" in m and f"final_{kind}" in m and kind in m["target"]
    if "final_axis_error_deg" in m:
        assert m["final_axis_error_deg"] < 0.01
    if kind in ("circle", "sphere"):
        assert m["final_centre_error_m"] < 1e-4 and m["radius_error_m"] < 1e-4
        ratio = m["target"][kind]["radius_m"] / m[f"initial_{kind}"]["radius_m"]
        assert ratio == pytest.approx(m["target"]["scale"], rel=1e-5)  # 6 significant digits each
    else:
        assert m["final_point_error_m"] < 1e-4


def test_dilation_command(run):
    """Flat primitives (line, plane): the e0∞ component of the command and of the error is zero.

    The similarity of a flat primitive is a motor, so the e0∞ row of J^G vanishes identically;
    the compiled graph returns an exact 0.0 (measured).  Had it come from cancellation, its
    rounding error would be at most γ_nq Σ_j |J_ij| |q̇_j| ≤ nq·nq·1.1e-16·max|J|·max|q̇|
    ≈ 12·12·1.1e-16·1.3·0.2 ≈ 4e-15 here, so 1e-14 bounds it.  Round primitives (circle,
    sphere) dilate: the command's e0∞ integrates to log(r_n / r_0) (the scale is a group
    homomorphism), up to the trapezoid rule's O(Δt²) error.
    """
    fig, out, m = run
    d = np.load(out / "trajectory.npz")
    B = d["command_bivector"]
    assert m["max_abs_dilation_command"] == pytest.approx(np.abs(B[:, 3]).max(), rel=1e-5, abs=0)
    if KIND[fig] in ("line", "plane"):
        assert m["max_abs_dilation_command"] <= 1e-14 and m["max_abs_dilation_error"] <= 1e-14
        assert np.abs(d["error_bivector"][:, 3]).max() <= 1e-14
        assert m["max_abs_command"] > 0.01  # it moved
    else:
        assert m["max_abs_dilation_command"] > 0.01
        assert m["integrated_dilation_command"] == pytest.approx(m["log_radius_ratio_final_initial"], abs=1e-4)
        assert m["log_radius_ratio_final_initial"] == pytest.approx(np.log(m["target"]["scale"]), abs=1e-5)


def test_files(run):
    import matplotlib.image as mpimg

    fig, out, m = run
    g = m["gallery"]
    assert set(g) == {"title", "claim", "evidence", "agrees", "figures"}
    assert g["agrees"] is True and g["figures"] == ["scene.png", "bivector.png", "animation.gif"]
    assert f"{m['iterations']} iterations" in g["evidence"] and "0.25 s" in g["evidence"]
    if fig == "fig11":
        assert "Dilation (e0∞) of the command: max |·| = 0" in g["evidence"]
    for name in g["figures"][:2]:
        img = mpimg.imread(out / name)
        assert img.shape[0] > 500 and img.shape[1] > 500, name
        assert float(np.std(img[..., :3])) > 0.05, name  # not blank
    from PIL import Image

    with Image.open(out / "animation.gif") as gif:  # --fast: 4 frames, small
        assert gif.n_frames == 4 and gif.size == (384, 288)
        gif.seek(3)
        assert float(np.std(np.asarray(gif.convert("RGB")))) > 5.0  # the last frame is not blank
    assert (out / "animation.gif").stat().st_size < 1_500_000
    d = np.load(out / "trajectory.npz")
    nq = DOF[fig]
    assert d["q"].shape == (101, nq) and d["u"].shape == (100, nq) and d["command_bivector"].shape == (101, 7)
    np.testing.assert_allclose(d["command_bivector"][0], 0.0, atol=1e-12)  # starts at rest
    assert np.linalg.norm(d["error_bivector"][-1]) == pytest.approx(m["terminal_error"], rel=1e-5)
    timing = _strict((out / "timing.json").read_text())
    assert timing["solve_time_s"] > 0 and len(timing["ilqr_iteration_time_s"]) == m["iterations"]


def test_same_seed_same_bytes(tmp_path):
    main = _module().main
    for sub in ("a", "b"):
        assert main(["--figure", "fig11", "--fast", "--quiet", "--out", str(tmp_path / sub)]) == 0
    for name in ("metrics.json", "trajectory.npz"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name


def test_target_overrides(tmp_path):
    args = ["--figure", "fig12", "--fast", "--quiet", "--out", str(tmp_path), "--scale", "1.1"]
    assert _module().main([*args, "--translation", "0", "0", "0.004"]) == 0
    m = _strict((tmp_path / "metrics.json").read_text())
    assert m["target"]["scale"] == 1.1 and m["target"]["translation_m"] == [0.0, 0.0, 0.004]
    assert m["target"]["sphere"]["radius_m"] == pytest.approx(1.1 * m["initial_sphere"]["radius_m"])
    assert m["converged"] is True and m["max_limit_violation"] == 0.0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--figure", "fig07", "--scale", "1.2"], "argument --scale: a dilation leaves a line unchanged"),
        (["--figure", "fig11", "--scale", "0.9"], "argument --scale: a dilation leaves a plane unchanged"),
        (["--tilt-axis", "0", "0", "0"], "argument --tilt-axis: expected a non-zero vector"),
        (["--figure", "fig99"], "argument --figure: invalid choice: 'fig99'"),
        (
            ["--figure", "fig08", "--tilt-deg", "179"],
            "the target options give no valid target: target: its circle's axis",
        ),
        (["--horizon", "0"], "argument --horizon: expected an integer >= 1, got '0'"),
    ],
)
def test_bad_options(argv, message, tmp_path, capsys):
    with pytest.raises(SystemExit) as ex:
        _module().main([*argv, "--quiet", "--out", str(tmp_path)])
    assert ex.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("fig", FIGURES)
def test_default_horizon_converges(fig):
    """The committed figures use the default 250 knots × 0.01 s: every preset's target is reachable
    (Gauss–Newton IK) and the iLQR converges there too, inside the limits (solver only, no drawing)."""
    import coop_ga as cg
    from coop_ga.control import gauss_newton_ik, ilqr_reach

    mod = _module()
    setup = mod.preset_setup(fig)
    assert (setup.horizon, setup.dt, setup.fast) == (250, 0.01, False)
    s = cg.systems.load(setup.preset.system)
    task = cg.cooperative_task(s, setup.preset.kind)
    q0 = np.array(s.q0, dtype=float)
    target = mod.make_target(task, q0, setup)
    assert gauss_newton_ik(task, q0, target).converged
    res = ilqr_reach(task, q0, target, horizon=setup.horizon, dt=setup.dt)
    assert res.converged and res.error < 1e-5 and 1 <= res.iterations <= 5, res.message
    assert mod.limit_violation(res.trajectory, s.q_lower, s.q_upper) == 0.0 and res.within_limits
