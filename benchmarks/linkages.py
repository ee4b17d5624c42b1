"""Time per crank step: the CGA Lie-algebra Newton tracker against ``scipy.optimize.fsolve``.

    python benchmarks/linkages.py [--steps 360] [--out results/benchmarks/linkages] [--quiet]

For each linkage of :mod:`coop_ga.linkages.library` (4-bar, slider 4-bar, Watt 6-bar,
10-bar), one crank cycle of ``--steps`` angles by

* ``cga``: :meth:`Linkage.track` (predictor, Newton in the Lie algebra of planar motors,
  CasADi Jacobian, branch checks);
* ``fsolve``: ``scipy.optimize.fsolve`` (MINPACK hybrd, finite-difference Jacobian) on the
  coordinate equations of the same linkage — one pose (θ, x, y) per moving link, the joint
  coincidences (and the prismatic conditions) in plain numpy — warm-started from the
  previous step, no branch check;

and the ratio cga / fsolve (same run, same machine).  Both solutions are compared (max
point distance) before the times are reported.  ``<out>/results.json`` holds the table.
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np
import scipy.optimize

sys.path.insert(0, os.path.dirname(__file__))
from _timing import print_table

from coop_ga.harness import Experiment, int_at_least
from coop_ga.linkages import Linkage, Prismatic, Revolute, four_bar, slider_crank, ten_bar, watt_six_bar
from coop_ga.linkages.planar import motor_pose


def _pose_points(lk: Linkage, x: np.ndarray, phi: float) -> dict[str, dict[str, np.ndarray]]:
    out: dict[str, dict[str, np.ndarray]] = {}
    for ln, link in lk.links.items():
        if ln == lk.ground:
            th, t = 0.0, np.zeros(2)
        elif ln == lk.crank:
            th = phi - lk.reference_angle
            R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
            t = lk.pivot - R @ lk.pivot
        else:
            k = lk.moving.index(ln)
            th, t = x[3 * k], x[3 * k + 1 : 3 * k + 3]
        R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
        out[ln] = {pn: R @ np.asarray(p, float) + t for pn, p in link.points.items()}
        out[ln]["__theta"] = np.array([th])
    return out


def coordinate_residual(lk: Linkage, x: np.ndarray, phi: float) -> np.ndarray:
    """The joint conditions in plain coordinates (no algebra): 2 rows per joint."""
    P = _pose_points(lk, x, phi)
    F: list[float] = []
    for j in lk.joints:
        if isinstance(j, Revolute):
            F += list(P[j.a[0]][j.a[1]] - P[j.b[0]][j.b[1]])
        elif isinstance(j, Prismatic):
            g, p, q = j.guide
            a, b = P[g][p], P[g][q]
            u = (b - a) / np.linalg.norm(b - a)
            s = P[j.slider[0]][j.slider[1]] - a
            F += [float(u[0] * s[1] - u[1] * s[0]), float(P[j.slider[0]]["__theta"][0] - P[g]["__theta"][0])]
    return np.array(F)


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--steps", type=int_at_least(8), default=360, help="crank angles per cycle")
    args = exp.parse(argv)
    angles = np.linspace(0.0, 2 * np.pi, args.steps + 1)
    builds = {
        "four_bar": lambda: four_bar(2.0, 0.5, 2.0, 1.5),
        "slider_crank": slider_crank,
        "watt_six_bar": watt_six_bar,
        "ten_bar": ten_bar,
    }
    rows, results = [], {}
    for name, build in builds.items():
        lk = build()
        m0 = lk.assembled(0.0) if hasattr(lk, "assembled") else lk.identity_motors()
        lk.track(angles[:3], m0)  # build the CasADi functions outside the timing
        t0 = time.perf_counter()
        motion = lk.track(angles, m0)
        t_cga = (time.perf_counter() - t0) / len(angles)
        x = np.concatenate([motor_pose(m0[4 * k : 4 * k + 4]) for k in range(len(lk.moving))])
        pts = []
        t0 = time.perf_counter()
        for phi in angles:
            x = scipy.optimize.fsolve(lambda z, phi=phi: coordinate_residual(lk, z, phi), x, xtol=1e-13)
            pts.append(_pose_points(lk, x, phi))
        t_fs = (time.perf_counter() - t0) / len(angles)
        diff = max(
            float(np.abs(motion.point(f"{ln}.{pn}")[k] - pts[k][ln][pn]).max())
            for k in range(len(angles))
            for ln, link in lk.links.items()
            for pn in link.points
        )
        results[name] = {
            "cga_us_per_step": t_cga * 1e6,
            "fsolve_us_per_step": t_fs * 1e6,
            "max_point_difference_m": diff,
        }
        rows.append([name, f"{t_cga * 1e6:.0f}", f"{t_fs * 1e6:.0f}", f"{t_cga / t_fs:.2f}", f"{diff:.1e}"])
    print_table(
        f"time per crank step over one cycle ({len(angles)} angles)",
        ["linkage", "cga [µs]", "fsolve [µs]", "cga / fsolve", "max |Δpoint| [m]"],
        rows,
    )
    exp.write_json("results.json", results, digits=3)
    return 0


if __name__ == "__main__":
    sys.exit(main())
