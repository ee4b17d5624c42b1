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

import numpy as np

from coop_ga.harness import Experiment, finite_float, nonneg_float, positive_float


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--perturb", type=nonneg_float, default=0.0, help="uniform perturbation [rad] of q0 (0: nominal q0)")
    exp.add("--angle", type=finite_float, default=30.0, help="how far along the circle the arm moves [deg]")
    exp.add("--arm", type=int, choices=(0, 1, 2), default=0, help="index of the moving arm / end point")
    exp.add("--duration", type=positive_float, default=4.0, help="duration [s]")
    exp.add("--dt", type=positive_float, default=0.01, help="time step [s] (Eq 61)")
    exp.add("--secondary-gain", type=positive_float, default=2.0, help="point-reaching gain [1/s]")
    exp.add("--primary-gain", type=nonneg_float, default=10.0, help="primary (hold) feedback gain [1/s]")
    args = exp.parse(argv)
    plt = exp.pyplot()

    import coop_ga as cg
    from coop_ga import viz
    from coop_ga.control.nullspace import nullspace_point_reach, point_on_circle

    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    rng = exp.rng
    q0 = s.q0 + rng.uniform(-args.perturb, args.perturb, s.nq)
    target = point_on_circle(t, q0, args.arm, np.deg2rad(args.angle))
    kw = dict(duration=args.duration, dt=args.dt, secondary_gain=args.secondary_gain, primary_gain=args.primary_gain)
    res = {
        "nullspace": nullspace_point_reach(t, q0, args.arm, target, project=True, **kw),
        "direct": nullspace_point_reach(t, q0, args.arm, target, project=False, **kw),
    }

    X = t.primitive(q0)
    c, r, n = np.asarray(cg.center(X), float), cg.radius(X), np.asarray(cg.normal(X), float)
    metrics = {
        "system": "three_franka",
        "kind": "circle",
        "arm": args.arm,
        "angle_deg": args.angle,
        "target_point_m": target.tolist(),
        "circle": {"center": c.tolist(), "radius": r, "normal": n.tolist()},
        "seed": args.seed,
        "perturb_rad": args.perturb,
    }
    for k, v in res.items():
        metrics[k] = {
            "initial_point_error_m": float(v.point_error[0]),
            "final_point_error_m": float(v.point_error[-1]),
            "max_similarity_distance": float(v.similarity_distance.max()),
            "final_similarity_distance": float(v.similarity_distance[-1]),
        }
    exp.write_npz(
        "trajectories.npz",
        t=res["nullspace"].t,
        target=target,
        **{
            f"{k}_{f}": getattr(v, f)
            for k, v in res.items()
            for f in ("trajectory", "points", "point_error", "similarity_distance")
        },
    )
    exp.write_json("metrics.json", metrics)

    # ------------------------------------------------------------------ figure
    P = viz.PALETTE
    fig = plt.figure(figsize=(13, 4.6))
    for col, (k, title) in enumerate(
        [("direct", "without nullspace (Fig. 16)"), ("nullspace", "nullspace projection, Eq 60 (Fig. 17)")]
    ):
        v = res[k]
        ax = fig.add_subplot(1, 3, col + 1, projection="3d", computed_zorder=False)  # layers: zorder below
        drawn = [
            viz.draw_robot(ax, s, q0, color=P.initial_robot, lw=1.6, ends=False, label="initial", zorder=1),
            viz.draw_robot(ax, s, v.trajectory[-1], color=P.final_robot, lw=1.6, ends=False, label="final", zorder=2),
        ]
        drawn.append(
            viz.draw_primitive(ax, X, color=P.initial_primitive, lw=1.8, label=r"circle $V_{Sc}(q_0)$", zorder=3)
        )
        drawn.append(
            viz.draw_primitive(
                ax,
                t.primitive(v.trajectory[-1]),
                color=P.final_primitive,
                ls="--",
                lw=1.4,
                label="final circle",
                zorder=4,
            )
        )
        ax.plot(*v.points.T, color=P.trajectory, lw=2, label="arm path", zorder=5)
        ax.scatter(*target, color=P.initial_primitive, s=40, depthshade=False, label="target", zorder=6)
        ax.set_title(title)
        viz.set_equal_3d(ax, np.vstack([d.points for d in drawn]), tight=True)
        ax.view_init(elev=35, azim=-60)
        ax.tick_params(labelsize=7)
        if col == 0:
            ax.legend(fontsize=7, loc="upper left")
    ax = fig.add_subplot(1, 3, 3)
    for k, ls in [("direct", "--"), ("nullspace", "-")]:
        v = res[k]
        viz.plot_error(ax, v.t, v.point_error, floor=1e-9, color="tab:blue", ls=ls, label=f"point error [m] ({k})")
        viz.plot_error(
            ax, v.t, v.similarity_distance, floor=1e-12, color=P.trajectory, ls=ls, label=f"similarity distance ({k})"
        )
    ax.set_xlabel("t [s]")
    ax.legend(fontsize=7)
    ax.set_title(r"$\|p - p^*\|$ and $\|\log(\tilde V_{Sc}(q_0)\, V_{Sc}(q))\|$")
    fig.tight_layout()
    png = exp.save(fig, "nullspace_secondary.png")
    for k in res:
        print(
            f"{k:9s} final point error {metrics[k]['final_point_error_m']:.2e} m, "
            f"max similarity distance {metrics[k]['max_similarity_distance']:.2e}"
        )
    print(f"wrote {exp.out}/metrics.json, trajectories.npz, {png.name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
