"""Mixed primitives in one controller (paper §5.7): a circle of three feet and a line of two others.

A similarity task can drive the primitive of a *subset* of a system's end frames:
``SimilarityTask(target, model=cooperative_task(system, "circle", points=(0, 1, 2)))``.  On the hexapod (six feet):

1. a circle through three feet (lf, lr, rm) and a line through two others (rf, lm), two tasks stacked in one
   differential-IK step, each moved to its own target (the circle turned, moved and enlarged by 2 %, the line
   turned and moved) inside the joint limits;
2. the same two at the first priority level and a point pair of a circle foot (lf) and the sixth foot (rr) at
   the second: it asks for 6 DOF where the first level leaves 4, so the first level is reached exactly and the
   second only as far as the first's nullspace allows — printed as the projected gradient of ½‖e₂‖² (zero at
   the best the nullspace allows) next to ‖e₂‖ at the start and the end.

Writes ``metrics.json`` (per part: errors, steps, within the limits; the second level's residual and projected
gradient) and ``scene.png`` (the start primitives in green, the reached ones in the default colours).

Run::

    python examples/11_mixed_primitives.py --out /tmp/ex11
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

import coop_ga as cg
from coop_ga.control import Configuration, SimilarityTask, default_limits, displaced_target, run_ik

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("metrics.json", "scene.png")

DT = 0.02


def _targets(tasks: dict, q0: np.ndarray) -> dict:
    return {
        "circle": displaced_target(tasks["circle"], q0, translation=(0.01, -0.01, 0.02), axis=(1, 0, 0), angle=0.08,
                                   scale=1.02),
        "line": displaced_target(tasks["line"], q0, translation=(-0.01, 0.02, 0.01), axis=(0, 0, 1), angle=0.1),
        "pair": displaced_target(tasks["pair"], q0, translation=(0.03, 0.02, 0.02), axis=(0, 1, 0), angle=0.2,
                                 scale=1.1),
    }  # fmt: skip


def _within(system: cg.systems.System, traj: np.ndarray) -> bool:
    return bool(np.all((traj >= system.limits.lower) & (traj <= system.limits.upper)))


def second_level_optimality(tasks: dict, targets: dict, q: np.ndarray) -> float:
    """‖N₁ J₂ᵀ e₂‖ / ‖J₂ᵀ e₂‖: the gradient of ½‖e₂‖² projected on the nullspace of the first level's J₁ (0: the
    second level is as close as the first level allows, to first order)."""
    J1 = np.vstack([tasks[k].error_jacobian(q, targets[k]) for k in ("circle", "line")])
    N = np.eye(q.size) - np.linalg.pinv(J1) @ J1
    g = tasks["pair"].error_jacobian(q, targets["pair"]).T @ tasks["pair"].error(q, targets["pair"])
    return float(np.linalg.norm(N @ g) / np.linalg.norm(g))


def main(argv: list[str] | None = None) -> int:
    """Both parts; returns 0 when the first part reaches both targets and the second the first level exactly
    with a stationary second level, all inside the joint limits."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "11")
    ap.add_argument("--fast", action="store_true", help="draw a skeleton instead of the meshes")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    system = cg.systems.load("hexapod")
    q0 = np.asarray(system.q0, dtype=float)
    tasks = {
        "circle": cg.cooperative_task(system, "circle", points=(0, 1, 2)),
        "line": cg.cooperative_task(system, "line", points=(3, 4)),
        "pair": cg.cooperative_task(system, "point_pair", points=(0, 5)),
    }
    targets = _targets(tasks, q0)
    for k, t in tasks.items():
        print(f"{k:6s}: end frames {', '.join(t.end_frames)}; ‖e‖ at q0 {np.linalg.norm(t.error(q0, targets[k])):.3f}")
    limits = default_limits(system.limits)
    first = [SimilarityTask(targets[k], model=tasks[k]) for k in ("circle", "line")]

    run = run_ik(Configuration(tasks["circle"], q0), first, limits, dt=DT, steps=300)
    q1 = run.trajectory[-1]
    e = {k: float(np.linalg.norm(tasks[k].error(q1, targets[k]))) for k in ("circle", "line")}
    mixed = {"errors": e, "steps": int(run.trajectory.shape[0] - 1), "within_limits": _within(system, run.trajectory)}
    print(f"circle + line in one step: ‖e_circle‖ {e['circle']:.1e}, ‖e_line‖ {e['line']:.1e} after "
          f"{mixed['steps']} steps, within the joint limits: {mixed['within_limits']}")  # fmt: skip
    ok = max(e.values()) < 1e-4 and mixed["within_limits"]

    second = SimilarityTask(targets["pair"], model=tasks["pair"], jacobian="exact")
    run2 = run_ik(Configuration(tasks["circle"], q0), first, limits, dt=DT, steps=400, levels=[[second]])
    q2 = run2.trajectory[-1]
    e1 = float(np.linalg.norm(np.concatenate([tasks[k].error(q2, targets[k]) for k in ("circle", "line")])))
    e2 = [float(np.linalg.norm(tasks["pair"].error(q, targets["pair"]))) for q in (q0, q2)]
    grad = second_level_optimality(tasks, targets, q2)
    prio = {"first_level_error": e1, "second_level_error_start": e2[0], "second_level_error_end": e2[1],
            "second_level_projected_gradient": grad, "within_limits": _within(system, run2.trajectory)}  # fmt: skip
    print(f"priorities: level 1 ‖e‖ {e1:.1e}; level 2 (point pair lf–rr) ‖e‖ {e2[0]:.3f} → {e2[1]:.3f}, projected "
          f"gradient {grad:.1e} (as far as level 1's nullspace allows); within the limits: {prio['within_limits']}")  # fmt: skip
    ok = ok and e1 < 1e-8 and grad < 1e-6 and prio["within_limits"]

    (args.out / "metrics.json").write_text(json.dumps({"system": "hexapod", "mixed": mixed, "priorities": prio},
                                                      indent=2))  # fmt: skip
    start = [(tasks[k].primitive(q0), {"color": "tab:green"}) for k in ("circle", "line")]
    cg.viz.render(system, q1, [*start, *(tasks[k].primitive(q1) for k in ("circle", "line"))], args.out / "scene.png",
                  backend="skeleton" if args.fast else "auto", size=(5, 5), dpi=80)  # fmt: skip
    print(f"wrote {', '.join(OUTPUTS)} to {args.out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
