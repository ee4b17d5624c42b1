"""The hexapod walks: a gait over terrain, the posture carried by the stance primitive.

``coop_ga.legged.walk`` moves the PhantomX-like hexapod (``coop_ga/systems/robots/hexapod``) with a
tripod, ripple or wave gait over flat ground, a slope, steps or random tiles.  The stance feet span the
cooperative primitive (a plane on flat ground, a least-squares sphere on uneven ground) whose similarity
carries the body; every step is checked: the static stability margin, foot slip, joint position and
speed limits, static torques against the stall torque.

Writes ``trajectory.npz`` in the format of ``experiments/hexapod_walk.py`` (``t``, ``q`` (T, 18),
``body`` (T, 7) position + quaternion (x, y, z, w), ``stance`` (T, 6) and the terrain's arrays) — play it
with ``python -m coop_ga.viewer --play DIR/trajectory.npz`` — and ``metrics.json``.

Run::

    python examples/07_hexapod_walk.py --out /tmp/ex07 --gait ripple --terrain steps --distance 0.3
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import coop_ga.legged as L

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("trajectory.npz", "metrics.json")


def main(argv: list[str] | None = None) -> int:
    """Walk, check, save; returns 0 when the walk kept its margins and limits."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "07")
    ap.add_argument("--gait", default="tripod", choices=["tripod", "ripple", "wave"])
    ap.add_argument("--terrain", default="flat", choices=["flat", "slope", "steps", "random"])
    ap.add_argument("--distance", type=float, default=0.2, help="how far to walk [m] (default 0.2)")
    ap.add_argument("--fast", action="store_true", help="walk 0.1 m")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    legs = L.hexapod_legs()  # geometry read from the URDF
    q = legs.ik(legs.fk(legs.q_stand), branch="knee_up")  # closed-form IK of the standing feet
    print(f"closed-form IK ∘ FK at the stand pose: {np.abs(q - legs.q_stand).max():.1e} rad")

    terrain = L.Terrain.make(args.terrain)
    run = L.walk(terrain, L.WalkOptions(gait=args.gait), distance=0.1 if args.fast else args.distance)
    metrics = {
        "gait": args.gait,
        "terrain": args.terrain,
        "distance_m": float(run.distance),
        "min_margin_m": float(run.min_margin),
        "max_slip_m": float(run.max_slip),
        "max_limit_violation_rad": float(run.max_limit_violation),
        "max_velocity_violation": float(run.max_velocity_violation),
        "steps": len(run.t),
    }
    print(
        f"{args.gait} on {args.terrain}: walked {run.distance:.3f} m in {run.t[-1]:.2f} s ({len(run.t)} knots); "
        f"stability margin ≥ {run.min_margin * 1e3:.1f} mm, slip ≤ {run.max_slip:.1e} m, "
        f"position limits exceeded by {run.max_limit_violation:.1e} rad"
    )
    arrays: dict[str, Any] = {"t": run.t, "q": run.q, "body": run.body, "stance": run.stance, **terrain.to_arrays()}
    np.savez(args.out / "trajectory.npz", **arrays)
    (args.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(f"wrote {', '.join(OUTPUTS)} to {args.out}")
    ok = run.min_margin > 0 and run.max_limit_violation == 0 and run.max_velocity_violation == 0
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
