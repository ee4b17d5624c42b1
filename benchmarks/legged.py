"""Hexapod leg kinematics per batch: closed-form FK/IK against Pinocchio FK (the anchor) and DLS IK.

    python benchmarks/legged.py [--batches 1 100 10000] [--ci] [--out results/benchmarks/legged] [--quiet]

For batches of N random configurations inside the joint limits of the registered ``hexapod``
(18 DOF, six feet), the per-batch time of:

* ``pinocchio FK (anchor)``: ``forwardKinematics`` + ``updateFramePlacements`` once per
  configuration (a Python loop over the batch; Pinocchio has no batch API) — the six feet are
  then in ``data.oMf``;
* ``closed-form FK``: :meth:`coop_ga.legged.legs.LegModel.fk` on the (N, 18) batch (numpy);
* ``FK + Jacobians``: :meth:`~coop_ga.legged.legs.LegModel.jacobians` (the feet come with it);
* ``closed-form IK``: :meth:`~coop_ga.legged.legs.LegModel.ik` of the (N, 6, 3) feet, limits checked;
* ``DLS IK``: :meth:`~coop_ga.legged.legs.LegModel.dls_ik` of the same feet from the stand pose
  (tol 1e-10 m); the feet are the stand feet displaced by U(±2 cm) (the walking workspace, where
  DLS from the stand pose converges to the closed-form branch);
* ``GA motor product``: :meth:`~coop_ga.legged.legs.LegModel.fk_via_motors` (the seed's product of
  motors with Python multivectors, one configuration at a time; batches ≤ 100 only).

Every route is checked before timing (FK against Pinocchio by frame name, IK∘FK, DLS against
the closed form).  The table gives µs per batch, µs per configuration and the ratio to the anchor of
the same N, measured in the same run.  ``--ci`` runs batches 1 and 50 with three calls per route
(for ``tests/legged/test_legs.py``: the JSON shape and the accuracy checks, never the times).
Results go to ``<out>/results.json`` (times in µs).
"""

from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import per_call_us, print_table

import coop_ga as cg
from coop_ga.harness import Experiment, int_at_least
from coop_ga.legged.legs import LEGS, hexapod_legs

ANCHOR = "pinocchio FK (anchor)"


def _few_calls_us(fn: Any, calls: int = 3) -> float:
    """Best of ``calls`` single calls [µs] (the ``--ci`` mode's timer: fast, noisy)."""
    best = math.inf
    for _ in range(calls):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best * 1e6


def _check_batch(legs, m, d, fids: list[int], pin, q: np.ndarray, targets: np.ndarray, check: dict) -> np.ndarray:
    """Closed-form FK against Pinocchio, IK∘FK, DLS IK against the closed form (and the GA motor product for
    small batches) on one batch of ``n`` configurations ``q`` (n, 18); the worst errors go into ``check``.
    Returns the feet ``p`` (n, 6, 3) [m]."""
    n = len(q)
    p = legs.fk(q)
    ref = np.zeros_like(p)
    for k in range(n):
        pin.forwardKinematics(m, d, q[k])
        pin.updateFramePlacements(m, d)
        ref[k] = [d.oMf[f].translation for f in fids]
    err_fk = float(np.abs(p - ref).max())
    err_ik = float(np.abs(legs.ik(p, branch=legs.branch_of(q)) - q).max())
    res = legs.dls_ik(targets, legs.q_stand)
    assert res.all_converged, res.message
    err_dls = float(np.abs(res.q - legs.ik(targets)).max())
    assert err_fk < 1e-14 and err_ik < 1e-8 and err_dls < 1e-7, (err_fk, err_ik, err_dls)
    check["fk_vs_pinocchio_m"] = max(check["fk_vs_pinocchio_m"], err_fk)
    check["ik_fk_rad"] = max(check["ik_fk_rad"], err_ik)
    check["dls_vs_closed_rad"] = max(check["dls_vs_closed_rad"], err_dls)
    check["dls_max_iterations"] = max(check["dls_max_iterations"], int(res.iterations.max()))
    if n <= 100:
        err_motor = float(np.abs(legs.fk_via_motors(q[0]) - p[0]).max())
        assert err_motor < 1e-14, err_motor
    return p


def _time_batch(legs, m, d, pin, q: np.ndarray, targets: np.ndarray, ci: bool) -> tuple[list, dict[str, float]]:
    """``(routes, times)``: every route of one batch and its time per batch [µs] (a few calls only with ``ci``)."""
    n = len(q)

    def pin_fk(q: np.ndarray = q) -> None:
        for qk in q:
            pin.forwardKinematics(m, d, qk)
            pin.updateFramePlacements(m, d)

    routes: list[tuple[str, Any]] = [
        (ANCHOR, pin_fk),
        ("closed-form FK", lambda q=q: legs.fk(q)),
        ("FK + Jacobians", lambda q=q: legs.jacobians(q)),
        ("closed-form IK", lambda t=targets: legs.ik(t)),
        ("DLS IK", lambda t=targets: legs.dls_ik(t, legs.q_stand)),
    ]
    if n <= 100:
        routes.append(("GA motor product", lambda q=q: [legs.fk_via_motors(qk) for qk in q]))
    times = {}
    for name, fn in routes:
        if ci:  # a few calls only (the CI test reads the JSON, never the times)
            times[name] = _few_calls_us(fn)
        else:
            slow = name == "GA motor product"
            times[name] = per_call_us(fn, min_time=0.05 if slow else 0.2, repeat=3 if slow else 5)
    return routes, times


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/legged"))
    exp.add("--batches", nargs="+", type=int_at_least(1), default=[1, 100, 10000], metavar="N", help="batch sizes")
    exp.add(
        "--ci",
        action="store_true",
        help="small mode: batches 1 and 50, three calls per route (seconds; times meaningless)",
    )
    args = exp.parse(argv)
    import pinocchio as pin

    batches = [1, 50] if args.ci else sorted(set(args.batches))
    s = cg.systems.load("hexapod")
    legs = hexapod_legs(s)
    m, d = s.model, s.model.createData()
    fids = [m.getFrameId(f"{leg}_foot") for leg in LEGS]
    rng = exp.rng

    rows: list[list[str]] = []
    records: list[dict[str, Any]] = []
    check = {"fk_vs_pinocchio_m": 0.0, "ik_fk_rad": 0.0, "dls_vs_closed_rad": 0.0, "dls_max_iterations": 0}
    for n in exp.progress(batches, "batches"):
        q = legs.from_legs(rng.uniform(legs.q_lower, legs.q_upper, (n, 6, 3)))
        targets = legs.fk(legs.q_stand) + rng.uniform(-0.02, 0.02, (n, 6, 3))
        _check_batch(legs, m, d, fids, pin, q, targets, check)
        routes, times = _time_batch(legs, m, d, pin, q, targets, args.ci)
        anchor = times[ANCHOR]
        for name, _ in routes:
            t = times[name]
            rows.append([name, str(n), f"{t:.1f}", f"{t / n:.3f}", f"{t / anchor:.3f}"])
            records.append({"route": name, "batch": n, "us_per_batch": t, "us_per_config": t / n, "ratio": t / anchor})
    print_table(
        "hexapod feet (6 legs) per batch [µs], ratio to Pinocchio FK of the same batch (same run)",
        ["route", "N", "µs/batch", "µs/config", "ratio to anchor"],
        rows,
    )
    print(
        f"checks: FK vs Pinocchio {check['fk_vs_pinocchio_m']:.1e} m, IK∘FK {check['ik_fk_rad']:.1e} rad, "
        f"DLS vs closed form {check['dls_vs_closed_rad']:.1e} rad (≤ {check['dls_max_iterations']} iterations)"
    )
    exp.write_json("results.json", {"rows": records, "check": check, "batches": batches, "ci": bool(args.ci)})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
