"""Contact points anywhere on the body (paper §5.4): the G1 hugs with its chest and forearms.

``systems.EndPoint(link, offset)`` is a point at a position [m] in a link's frame; it enters a system as an
operational frame of the Pinocchio model, so the motor FK, the cooperative task, its Jacobian and the
controllers treat it like a hand.  First, Fig. 9's chest point: ``g1_arms`` plus ``EndPoint("torso_link",
G1_CHEST_OFFSET)`` gives the registered ``g1_torso_arms`` end points exactly, and the chest point's Jacobian
equals Pinocchio's frame Jacobian.  Then a hug: the circle through the chest point and a point on each forearm
(midway along the elbow link) is the cooperative primitive; differential IK (inside the joint limits) opens
the hug by 10 % (a larger object) and turns it 0.2 rad about the vertical (turning the hugged object).

Writes ``metrics.json`` (per target: converged, final error, steps, radius before/after) and ``scene.png``.

Run::

    python examples/10_body_contact_point.py --out /tmp/ex10
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
from coop_ga.systems import EndPoint
from coop_ga.systems.library import G1_CHEST_OFFSET

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("metrics.json", "scene.png")

CHEST = EndPoint("torso_link", G1_CHEST_OFFSET, name="chest_point")
#: midway along each forearm: the wrist roll joint sits 0.1 m along the elbow link's x axis, 1 cm below it
FOREARMS = [EndPoint(f"{side}_elbow_link", (0.05, 0.0, -0.005), name=f"{side}_forearm") for side in ("left", "right")]
TARGETS = {"open by 10 %": {"scale": 1.1}, "turn 0.2 rad": {"axis": (0.0, 0.0, 1.0), "angle": 0.2}}


def fig9_check(rng: np.random.Generator) -> tuple[float, float]:
    """Largest |Δ| [m] between the chest-point system and ``g1_torso_arms`` over random q, and between the chest
    point's Jacobian and Pinocchio's frame Jacobian at q0."""
    ref = cg.systems.load("g1_torso_arms")
    new = cg.systems.load("g1_arms").with_end_frames([CHEST, "right_rubber_hand", "left_rubber_hand"])
    diff = max(
        float(np.abs(new.end_points(q) - ref.end_points(q)).max()) for q in (ref.random_q(rng) for _ in range(20))
    )
    J = np.asarray(new.tree.euclidean_point_jacobians(new.q0)[0], dtype=float)
    fid = new.model.getFrameId("chest_point")
    Jp = pin.computeFrameJacobian(new.model, new.model.createData(), new.q0, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
    return diff, float(np.abs(J - Jp).max())


def main(argv: list[str] | None = None) -> int:
    """Fig. 9's chest point, then the hug; returns 0 when the check holds and every target is reached."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "10")
    ap.add_argument("--fast", action="store_true", help="draw a skeleton instead of the meshes")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    diff, jac = fig9_check(np.random.default_rng(0))
    print(
        f"Fig. 9 chest point via EndPoint: end points = g1_torso_arms' to {diff:.1e} m; Jacobian = Pinocchio's to {jac:.1e}"
    )
    hug = cg.systems.load("g1_arms").with_end_frames([CHEST, *FOREARMS], name="g1_hug")
    task = cg.cooperative_task(hug, "circle")
    q0 = hug.q0
    r0 = float(cg.radius(task.primitive(q0)))
    print(f"hug circle through {', '.join(hug.end_frames)}: radius {r0 * 1e3:.1f} mm at q0")
    metrics: dict[str, object] = {"system": "g1_hug", "kind": "circle", "fig9_end_point_diff_m": diff,
                                  "chest_jacobian_vs_pinocchio": jac, "radius_q0_m": r0}  # fmt: skip
    ok = diff < 1e-12 and jac < 1e-12
    finals = []
    for label, displacement in TARGETS.items():
        target = cg.control.displaced_target(task, q0, **displacement)
        run = cg.control.diff_ik_reach(task, q0, target)
        r1 = float(cg.radius(task.primitive(run.q)))
        lim = hug.limits
        assert lim is not None
        inside = bool(np.all((run.trajectory >= lim.lower - 1e-9) & (run.trajectory <= lim.upper + 1e-9)))
        metrics[label] = {"converged": bool(run.converged), "error": float(run.error), "steps": len(run.trajectory),
                          "radius_m": r1, "within_limits": inside}  # fmt: skip
        print(
            f"{label:13s}: converged={run.converged}, final ‖e‖ {run.error:.1e} in {len(run.trajectory)} steps, "
            f"radius {r1 * 1e3:.1f} mm, within the joint limits: {inside}"
        )
        ok = ok and run.converged and inside
        finals.append(run.q)
    (args.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    cg.viz.render(
        hug,
        finals[0],
        [(task.primitive(q0), {"color": "tab:green"}), task.primitive(finals[0])],
        args.out / "scene.png",
        backend="skeleton" if args.fast else "auto",
        size=(5, 5),
        dpi=80,
    )
    print(f"wrote {', '.join(OUTPUTS)} to {args.out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
