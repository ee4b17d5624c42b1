"""Two arms carry a bar: the hands' point pair is moved as one rigid object (differential IK and iLQR).

The Unitree G1's two hands (registered system ``g1_arms``: waist + two arms, 17 DOF) hold the ends of a
bar.  The cooperative primitive is the point pair hand → hand (unit primitive: (0, ∓1, 0), Eq 14); a
similarity target with scale 1 moves the bar without changing its length, so a controller that reaches
it carries the bar: here 8 cm up, 5 cm forward and turned 15° about the vertical.  Differential IK
(Eq 48, 61: a QP per step inside the joint limits) and iLQR (Eq 53–57, position/velocity/acceleration
limits at every knot) reach the same target; along both trajectories the distance between the hands
(the bar's length) is printed.  (A ``"line"`` task would leave the hands free to slide along the bar.)

Writes ``trajectory.npz`` (``diffik_trajectory``, ``ilqr_trajectory`` (T, 17), ``target`` (12,) V_Sd
coefficients), ``metrics.json`` and ``scene.png``; ``python -m coop_ga.viewer --play DIR/trajectory.npz --key
ilqr_trajectory`` plays it.

Run::

    python examples/03_two_arm_bar_carry.py --out /tmp/ex03
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

import coop_ga as cg

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("trajectory.npz", "metrics.json", "scene.png")


def bar_lengths(task: cg.CooperativeTask, Q: np.ndarray) -> np.ndarray:
    """Distance between the two hands [m] at each row of Q (T, nq)."""
    P = np.stack([task.points(q) for q in Q])  # (T, 2, 3)
    return np.linalg.norm(P[:, 1] - P[:, 0], axis=1)


def main(argv: list[str] | None = None) -> int:
    """Carry the bar with both controllers; returns 0 when both reach the target inside the limits."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "03")
    ap.add_argument("--fast", action="store_true", help="draw a skeleton instead of the meshes")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    task = cg.cooperative_task("g1_arms", "point_pair")
    q0 = task.system.q0
    target = cg.control.displaced_target(
        task, q0, translation=(0.05, 0.0, 0.08), axis=(0, 0, 1), angle=np.deg2rad(15.0), scale=1.0
    )
    dik = cg.control.diff_ik_reach(task, q0, target)
    ocp = cg.control.ilqr_reach(task, q0, target)
    L0 = float(bar_lengths(task, q0[None])[0])
    metrics: dict[str, object] = {"system": "g1_arms", "kind": "point_pair", "bar_length_m": L0}  # read by the viewer
    for name, run in (("diffik", dik), ("ilqr", ocp)):
        L = bar_lengths(task, run.trajectory)
        metrics[name] = {
            "converged": bool(run.converged),
            "error": float(run.error),
            "steps": len(run.trajectory),
            "bar_length_change_max_m": float(np.abs(L - L0).max()),
        }
        print(
            f"{name:7s} converged={run.converged}, final ‖e‖ {run.error:.1e}, {len(run.trajectory)} steps; "
            f"bar length {L0 * 1e3:.1f} mm, largest change on the way {np.abs(L - L0).max() * 1e3:.2f} mm, "
            f"at the end {abs(L[-1] - L0) * 1e3:.4f} mm"
        )
    print(f"iLQR trajectory within the limits: {ocp.within_limits}")
    metrics["ilqr_within_limits"] = bool(ocp.within_limits)

    np.savez(
        args.out / "trajectory.npz",
        diffik_trajectory=dik.trajectory,
        ilqr_trajectory=ocp.trajectory,
        target=target.coeffs,
    )
    (args.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    X_target = target.apply(task.unit)
    cg.viz.render(
        task.system,
        ocp.q,
        [(task.primitive(q0), {"color": "tab:green"}), task.primitive(ocp.q), (X_target, {"color": "k", "ls": "--"})],
        args.out / "scene.png",
        backend="skeleton" if args.fast else "auto",
        size=(5, 5),
        dpi=80,
    )
    print(f"wrote {', '.join(OUTPUTS)} to {args.out}")
    return 0 if dik.converged and ocp.converged and ocp.within_limits else 1


if __name__ == "__main__":
    sys.exit(main())
