#!/usr/bin/env python
"""§4.3 / Fig. 16–17: a secondary task in the geometric nullspace of a cooperative circle.

Three Franka arms hold their cooperative circle (primary task, V_Sc(q_0)); the first arm's
end point is sent to the point of the circle ``--angle`` degrees further along it
(secondary task, Eq 60: ``q̇ = J⁺ k_p e + N [q̇_{0,d}; 0; 0]``).  The same secondary
velocity applied without the projector (Fig. 16) reaches the point but leaves the circle.

Writes to ``--out``: ``metrics.json`` (final point errors, max similarity distances),
``trajectories.npz`` and ``nullspace_secondary.png`` (3-D view of the arm paths and the
circle, and point error / similarity distance vs time for both variants).

    python experiments/nullspace_secondary.py --out out/nullspace
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("results/nullspace_secondary"), help="output directory")
    ap.add_argument("--seed", type=int, default=0, help="seed of the optional start perturbation")
    ap.add_argument("--perturb", type=float, default=0.0, help="uniform perturbation [rad] of q0 (0: nominal q0)")
    ap.add_argument("--angle", type=float, default=30.0, help="how far along the circle the arm moves [deg]")
    ap.add_argument("--arm", type=int, default=0, help="index of the moving arm / end point")
    ap.add_argument("--duration", type=float, default=4.0, help="duration [s]")
    ap.add_argument("--dt", type=float, default=0.01, help="time step [s] (Eq 61)")
    ap.add_argument("--secondary-gain", type=float, default=2.0, help="point-reaching gain [1/s]")
    ap.add_argument("--primary-gain", type=float, default=10.0, help="primary (hold) feedback gain [1/s]")
    args = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import coop_ga as cg
    from coop_ga.control.nullspace import nullspace_point_reach, point_on_circle
    from coop_ga.control.teleop import skeleton

    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    rng = np.random.default_rng(args.seed)
    q0 = s.q0 + rng.uniform(-args.perturb, args.perturb, s.nq)
    target = point_on_circle(t, q0, args.arm, np.deg2rad(args.angle))
    kw = dict(duration=args.duration, dt=args.dt, secondary_gain=args.secondary_gain, primary_gain=args.primary_gain)
    res = {"nullspace": nullspace_point_reach(t, q0, args.arm, target, project=True, **kw),
           "direct": nullspace_point_reach(t, q0, args.arm, target, project=False, **kw)}

    args.out.mkdir(parents=True, exist_ok=True)
    X = t.primitive(q0)
    c, r, n = np.asarray(cg.center(X), float), cg.radius(X), np.asarray(cg.normal(X), float)
    metrics = {"system": "three_franka", "kind": "circle", "arm": args.arm, "angle_deg": args.angle,
               "target_point_m": target.tolist(), "circle": {"center": c.tolist(), "radius": r, "normal": n.tolist()},
               "seed": args.seed, "perturb_rad": args.perturb}
    for k, v in res.items():
        metrics[k] = {"initial_point_error_m": float(v.point_error[0]), "final_point_error_m": float(v.point_error[-1]),
                      "max_similarity_distance": float(v.similarity_distance.max()),
                      "final_similarity_distance": float(v.similarity_distance[-1])}
    np.savez(args.out / "trajectories.npz", t=res["nullspace"].t, target=target,
             **{f"{k}_{f}": getattr(v, f) for k, v in res.items()
                for f in ("q_traj", "points", "point_error", "similarity_distance")})
    (args.out / "metrics.json").write_text(json.dumps(metrics, indent=2))

    # ------------------------------------------------------------------ figure
    u = np.cross(n, [1.0, 0, 0]) if abs(n[0]) < 0.9 else np.cross(n, [0, 1.0, 0])
    u /= np.linalg.norm(u)
    w = np.cross(n, u)
    ph = np.linspace(0, 2 * np.pi, 200)
    circ = c + r * (np.outer(np.cos(ph), u) + np.outer(np.sin(ph), w))
    fig = plt.figure(figsize=(13, 4.6))
    for col, (k, title) in enumerate([("direct", "without nullspace (Fig. 16)"), ("nullspace", "nullspace projection, Eq 60 (Fig. 17)")]):
        v = res[k]
        ax = fig.add_subplot(1, 3, col + 1, projection="3d")
        for line in skeleton(t, q0):
            ax.plot(*line.T, "-", color="0.75", lw=1.5)
        for line in skeleton(t, v.q_traj[-1]):
            ax.plot(*line.T, "-o", color="0.3", lw=1.5, ms=2)
        ax.plot(*circ.T, "g-", lw=1.5, label="circle V_Sc(q0)")
        Xf = t.primitive(v.q_traj[-1])
        cf, rf, nf = np.asarray(cg.center(Xf), float), cg.radius(Xf), np.asarray(cg.normal(Xf), float)
        uf = np.cross(nf, u); uf = uf / np.linalg.norm(uf) if np.linalg.norm(uf) > 1e-9 else u
        wf = np.cross(nf, uf)
        ax.plot(*(cf + rf * (np.outer(np.cos(ph), uf) + np.outer(np.sin(ph), wf))).T, "c--", lw=1, label="final circle")
        ax.plot(*v.points.T, "r-", lw=2, label="arm path")
        ax.scatter(*target, color="g", s=40, label="target")
        ax.set_title(title, fontsize=10)
        ax.set_xlim(-0.9, 0.9); ax.set_ylim(-0.9, 0.9); ax.set_zlim(0, 1.2)
        ax.view_init(elev=35, azim=-60)
        if col == 0:
            ax.legend(fontsize=7, loc="upper left")
    ax = fig.add_subplot(1, 3, 3)
    for k, style in [("direct", "--"), ("nullspace", "-")]:
        v = res[k]
        ax.semilogy(v.t, np.maximum(v.point_error, 1e-9), "b" + style, label=f"point error [m] ({k})")
        ax.semilogy(v.t, np.maximum(v.similarity_distance, 1e-12), "r" + style, label=f"similarity distance ({k})")
    ax.set_xlabel("t [s]"); ax.grid(alpha=0.3, which="both"); ax.legend(fontsize=7)
    ax.set_title("‖p − p*‖ and ‖log(Ṽ_Sc(q0) V_Sc(q))‖", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.out / "nullspace_secondary.png", dpi=130)
    for k in res:
        print(f"{k:9s} final point error {metrics[k]['final_point_error_m']:.2e} m, "
              f"max similarity distance {metrics[k]['max_similarity_distance']:.2e}")
    print(f"wrote {args.out}/metrics.json, trajectories.npz, nullspace_secondary.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
