"""Per-call time of the cooperative evaluation (V_Sc, B_Sc, J^G) against Pinocchio, in one run.

For each system/primitive it prints

* ``coop_ga``: ``task.evaluate_views(q)`` — copy q in, generated C, degeneracy/NaN check;
* ``C only``: the bound compiled function alone (``task.compiled.eval()``, no Python checks);
* ``batch``: per-configuration time of ``task.evaluate_batch`` (CasADi ``map``, 2 threads);
* ``pinocchio``: ``forwardKinematics`` + ``computeFrameJacobian`` (LOCAL) of the same end
  frames — the anchor, measured in the same run;

and the ratio coop_ga / pinocchio (target ≤ 1 for three_franka).

Run: ``python benchmarks/cooperative.py`` (first run compiles the tasks, ~1–10 s each).  The
table is also written to ``<out>/results.json`` (times in µs).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import per_call_us, print_table

import coop_ga as cg
from coop_ga.harness import Experiment, positive_int

CASES = [("three_franka", "circle"), ("allegro", "sphere"), ("two_g1", "sphere")]


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/cooperative"))
    exp.add("--batch", type=positive_int, default=1000, help="configurations per batch call")
    args = exp.parse(argv)
    import pinocchio as pin

    rows, records = [], []
    for name, kind in exp.progress(CASES, "timing"):
        if name not in cg.systems.names():
            rows.append([name, kind, "not registered", "", "", "", "", "", ""])
            continue
        sys_ = cg.systems.load(name)
        t0 = time.perf_counter()
        task = cg.cooperative_task(sys_, kind, codegen=True)
        _ = task.compiled  # build + compile (or load from the disk cache)
        t_build = time.perf_counter() - t0
        q = sys_.q0.copy()
        t_coop = per_call_us(lambda: task.evaluate_views(q))
        t_c = per_call_us(task.compiled.eval)
        Q = np.tile(q, (args.batch, 1))
        task.evaluate_batch(Q)
        t_batch = per_call_us(lambda: task.evaluate_batch(Q), min_time=0.5) / args.batch

        m = sys_.model
        d = m.createData()
        fids = [m.getFrameId(f) for f in task.end_frames]

        def pin_call() -> None:
            pin.forwardKinematics(m, d, q)
            for fid in fids:
                pin.computeFrameJacobian(m, d, q, fid, pin.LOCAL)

        t_pin = per_call_us(pin_call)
        rows.append(
            [
                name,
                kind,
                str(sys_.nq),
                str(task.casadi_function.n_instructions()),
                f"{t_coop:.2f}",
                f"{t_c:.2f}",
                f"{t_batch:.2f}",
                f"{t_pin:.2f}",
                f"{t_coop / t_pin:.2f}",
            ]
        )
        records.append(
            {
                "system": name,
                "kind": kind,
                "nq": sys_.nq,
                "sx_instructions": task.casadi_function.n_instructions(),
                "coop_ga_us": t_coop,
                "c_only_us": t_c,
                "batch_per_config_us": t_batch,
                "pinocchio_us": t_pin,
                "ratio": t_coop / t_pin,
                "build_or_load_s": t_build,
            }
        )
    print_table(
        "cooperative evaluation (V_Sc, B_Sc, J^G) per call [µs]",
        ["system", "kind", "nq", "SX instr", "coop_ga", "C only", "batch/config", "pinocchio FK+J", "ratio"],
        rows,
    )
    exp.write_json("results.json", {"batch": args.batch, "rows": records})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
