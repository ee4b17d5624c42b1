"""A floating base (a free flyer, nq ≠ nv): the G1's hands reach a target its arms alone cannot.

``systems.load("g1_arms", free_flyer=True)`` (``systems.library.g1_floating()``) is ``g1_arms`` with a free-flyer pelvis (``from_urdf(..., free_flyer=True)``
does the same for any URDF): q = [pelvis position (3) [m]; quaternion x y z w (4); 17 joints], 24 coordinates,
and q̇ = [the pelvis' LOCAL linear and angular velocity (6); 17 joint speeds], 23 velocities.  The motor
kinematics and Jacobians have 23 columns (Pinocchio's velocity convention), every step moves q by
``System.integrate`` (``pinocchio.integrate``: the quaternion stays unit), and the joint limits bound the joints
only (the pelvis has none).

First the kinematics against Pinocchio (frame placements and LOCAL frame Jacobians at random configurations),
then a point-pair target 0.6 m forward, 0.2 m left and 0.3 m up, turned 0.4 rad about the vertical: the
fixed-pelvis G1 does not reach it, the floating one does (differential IK inside the joint limits and
Gauss–Newton), moving its pelvis; the final hands are checked with Pinocchio's forward kinematics.  The same
reach stacked with the dual task space's relative orientation keeps the hands' relative orientation while the
pelvis moves (its 6 × 23 motor Jacobian is differentiated along ``q ⊕ v``).  Last, the iLQR's trajectory to the
same target (30 knots of 50 ms, rest to rest), solved in a local chart q = q0 ⊕ (x − c) of the manifold
(``coop_ga.control.ilqr.chart``): its hands land on the same target points as Gauss–Newton's, the quaternion stays
unit along it and the joints inside their limits; the fixed-pelvis iLQR does not converge.  This is kinematics: the
pelvis moves as an ideal floating joint (no balance, contacts or dynamics; no physics claim).

Writes ``metrics.json`` and ``scene.png``.

Run::

    python examples/13_free_flyer.py --out /tmp/ex13
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
from coop_ga.kinematics import LOCAL_TO_TANGENT

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("metrics.json", "scene.png")

MOVE = {"translation": (0.6, 0.2, 0.3), "axis": (0.0, 0.0, 1.0), "angle": 0.4}


def kinematics_check(s: cg.systems.System, rng: np.random.Generator, n: int) -> float:
    """Largest difference between coop_ga's motors/body Jacobians and Pinocchio's oMf/LOCAL frame Jacobians."""
    d = s.model.createData()
    worst = 0.0
    for q in (s.random_q(rng) for _ in range(n)):
        pin.computeJointJacobians(s.model, d, q)
        pin.framesForwardKinematics(s.model, d, q)
        J = s.tree.geometric_jacobians(q)
        for i, f in enumerate(s.end_frames):
            fid = s.model.getFrameId(f)
            JL = pin.getFrameJacobian(s.model, d, fid, pin.LOCAL)
            worst = max(worst, float(np.abs(J[i] - LOCAL_TO_TANGENT @ JL).max()))
        worst = max(worst, float(np.abs(s.end_points(q) - _hands(s, q)).max()))
    return worst


def _hands(s: cg.systems.System, q: np.ndarray) -> np.ndarray:
    """The end points by Pinocchio's forward kinematics."""
    d = s.model.createData()
    pin.framesForwardKinematics(s.model, d, q)
    return np.array([d.oMf[s.model.getFrameId(f)].translation for f in s.end_frames])


def _expected(s: cg.systems.System, q: np.ndarray) -> np.ndarray:
    """The hands at q moved by MOVE about their centroid: where the target puts them."""
    p = _hands(s, q)
    c = p.mean(axis=0)
    R = pin.AngleAxis(MOVE["angle"], np.array(MOVE["axis"])).toRotationMatrix()
    return (p - c) @ R.T + c + np.array(MOVE["translation"])


def _dual_hold(task: cg.CooperativeTask, target: cg.Similarity) -> dict[str, float]:
    """The reach by run_ik with and without the hands' relative orientation held (dual task space, CasADi VM):
    the final ‖e‖, the largest relative-orientation error [rad] along each run and the held run's final one."""
    from coop_ga.control import Configuration, SimilarityTask, default_limits, run_ik
    from coop_ga.control.tasks import DualTask, DualTaskSpace

    s = task.system
    space = DualTaskSpace(task, codegen=False)
    rel = DualTask(space, "relative", space.relative(s.q0), components="orientation")
    out: dict[str, float] = {}
    for hold in (False, True):
        tasks = [SimilarityTask(target), rel] if hold else [SimilarityTask(target)]
        run = run_ik(Configuration(task, s.q0), tasks, default_limits(s.limits), steps=300)
        drift = max(float(np.linalg.norm(rel.error(Configuration(task, x)))) for x in run.trajectory)
        if hold:
            qf = run.trajectory[-1]
            out.update(error=float(np.linalg.norm(task.error(qf, target))), drift_rad=drift,
                       final_rad=float(np.linalg.norm(rel.error(Configuration(task, qf)))))  # fmt: skip
        else:
            out["drift_free_rad"] = drift
    return out


def _ilqr(task: cg.CooperativeTask, fixed: cg.CooperativeTask, target: cg.Similarity) -> dict[str, object]:
    """The iLQR's rest-to-rest reach (30 knots of 50 ms) with the floating and the fixed pelvis: its numbers."""
    s = task.system
    r = cg.control.ilqr_reach(task, s.q0, target, horizon=30, dt=0.05)
    rf = cg.control.ilqr_reach(fixed, fixed.system.q0, target, horizon=30, dt=0.05)
    hands = float(np.abs(_hands(s, r.q) - _expected(s, s.q0)).max())
    quat = float(np.abs(np.linalg.norm(r.trajectory[:, 3:7], axis=1) - 1.0).max())
    print(
        f"iLQR trajectory (floating): converged={r.converged} in {r.iterations} iterations, final ‖e‖ {r.error:.1e}, "
        f"hands vs target {hands:.1e} m, pelvis moved {np.linalg.norm(r.q[:3]):.3f} m, quaternion norm error "
        f"{quat:.1e}; fixed pelvis: converged={rf.converged}, ‖e‖ {rf.error:.2g}"
    )
    return {"converged": bool(r.converged), "iterations": int(r.iterations), "error": float(r.error),
            "hands_error_m": hands, "pelvis_moved_m": float(np.linalg.norm(r.q[:3])), "quaternion_norm_error": quat,
            "limit_violation": float(s.limits.position_violation(s.limit_coordinates(r.trajectory))),
            "fixed_pelvis_converged": bool(rf.converged), "fixed_pelvis_error": float(rf.error)}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """Kinematics check, the fixed and floating reaches, the iLQR's trajectory; returns 0 when all hold."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "13")
    ap.add_argument("--fast", action="store_true", help="fewer random configurations, a skeleton drawing")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    s = cg.systems.load("g1_arms", free_flyer=True)
    print(f"{s.name}: nq = {s.nq}, nv = {s.nv}; q0 = pelvis at the origin + g1_arms' q0")
    kin = kinematics_check(s, np.random.default_rng(0), 5 if args.fast else 50)
    print(f"motors and LOCAL Jacobians vs Pinocchio: max |Δ| = {kin:.1e}")
    task = cg.cooperative_task(s, "point_pair")
    target = cg.control.displaced_target(task, s.q0, **MOVE)
    fixed = cg.cooperative_task(cg.systems.load("g1_arms"), "point_pair")
    rf = cg.control.diff_ik_reach(fixed, fixed.system.q0, target, steps=400)
    print(f"fixed pelvis  : converged={rf.converged}, final ‖e‖ {rf.error:.2g}")
    metrics: dict[str, object] = {"system": s.name, "nq": s.nq, "nv": s.nv, "kinematics_vs_pinocchio": kin,
                                  "fixed_pelvis": {"converged": bool(rf.converged), "error": float(rf.error)}}  # fmt: skip
    ok = kin < 1e-12 and not rf.converged
    runs = {
        "diff_ik_reach": cg.control.diff_ik_reach(task, s.q0, target, steps=400),
        "gauss_newton_ik": cg.control.gauss_newton_ik(task, s.q0, target),
    }
    for name, run in runs.items():
        hands = float(np.abs(_hands(s, run.q) - _expected(s, s.q0)).max())
        base = float(np.linalg.norm(run.q[:3]))
        print(
            f"floating pelvis, {name}: converged={run.converged}, final ‖e‖ {run.error:.1e}, "
            f"hands vs target (Pinocchio FK) {hands:.1e} m, pelvis moved {base:.3f} m, "
            f"joint-limit violation {run.limit_violation:.1g}"
        )
        metrics[name] = {"converged": bool(run.converged), "error": float(run.error), "hands_error_m": hands,
                         "pelvis_moved_m": base, "limit_violation": float(run.limit_violation)}  # fmt: skip
        ok = ok and run.converged and hands < 1e-3 and run.limit_violation == 0.0
    held = _dual_hold(task, target)
    print(
        f"with the hands' relative orientation held (dual task space): final ‖e‖ {held['error']:.1e}, relative "
        f"orientation drift {np.degrees(held['drift_rad']):.2g}° (without: {np.degrees(held['drift_free_rad']):.2g}°), "
        f"final {held['final_rad']:.1e} rad"
    )
    metrics["dual_hold"] = held
    # held to the Euler steps' drift while the steps are large, then to rounding
    ok = ok and held["error"] < 1e-8 and held["final_rad"] < 1e-8 and held["drift_rad"] < 0.2 * held["drift_free_rad"]
    metrics["ilqr_reach"] = traj = _ilqr(task, fixed, target)
    ok = ok and traj["converged"] and traj["hands_error_m"] < 1e-5 and not traj["fixed_pelvis_converged"]
    ok = ok and traj["quaternion_norm_error"] < 1e-12 and traj["limit_violation"] == 0.0
    (args.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    q1 = runs["diff_ik_reach"].q
    cg.viz.render(
        s,
        q1,
        [(task.primitive(s.q0), {"color": "tab:green"}), task.primitive(q1)],
        args.out / "scene.png",
        backend="skeleton" if args.fast else "auto",
        size=(5, 5),
        dpi=80,
    )
    print(f"wrote {', '.join(OUTPUTS)} to {args.out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
