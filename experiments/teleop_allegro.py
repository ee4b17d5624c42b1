#!/usr/bin/env python
"""§4.5 / Fig. 20–21: teleoperating a four-fingered hand through its cooperative sphere.

The six axes of a space-mouse-like input are mapped to a similarity bivector (translations
→ e1∞, e2∞, e3∞; rotations about x, y → e23, e13; rotation about z → dilation e0∞; see
:mod:`coop_ga.control.teleop`) and drive differential IK (Eq 48) with Eq 61.

Default (scripted, headless): Fig. 21 — from the nominal configuration, one step of
Δt = 0.25 s with the pure dilation commands ``B = −e0∞`` (d = e⁻¹ = 0.3679, closes the
hand) and ``B = +e0∞`` (d = e = 2.718, opens it); the same 0.25 s is also integrated with
25 steps of 0.01 s.  Then a short scripted teleoperation session (translate, close,
open) at Δt = 0.01 s.  ``--interactive`` opens a matplotlib window driven by the keyboard
(bindings in :mod:`coop_ga.control.teleop`; falls back to the script without a display).

Writes to ``--out``: ``metrics.json`` (radius before/after for each command, the
first-order expectation e^{βΔt}, centre displacement), ``session.npz`` and
``teleop_allegro.png`` (hand skeleton and sphere after −e0∞ / original / after +e0∞,
plus radius and centre over the scripted session).

    python experiments/teleop_allegro.py --out out/teleop
"""

from __future__ import annotations

import warnings

import numpy as np

from coop_ga.harness import Experiment, nonneg_float, positive_float

SESSION = [  # (duration [s], (tx, ty, tz, rx, ry, rz))
    (0.5, (0, 0, 0, 0, 0, 0)),
    (0.5, (1, 0, 0, 0, 0, 0)),
    (0.5, (0, 0, 1, 0, 0, 0)),
    (0.5, (0, 0, 0, 0, 0, -1)),
    (1.0, (0, 0, 0, 0, 0, 1)),
    (0.5, (-1, 0, -1, 0, 0, 0)),
]


def _dilation_drift(commands: np.ndarray, centers: np.ndarray) -> float | None:
    """Path length [m] of the sphere centre over the steps with a pure dilation command."""
    if len(commands) == 0:
        return None
    pure = np.all(commands[:, :5] == 0, axis=1) & (commands[:, 5] != 0)
    steps = np.linalg.norm(np.diff(centers, axis=0), axis=1)
    return float(steps[pure].sum())


def main(argv: list[str] | None = None) -> int:
    import coop_ga as cg

    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--perturb", type=nonneg_float, default=0.0, help="uniform perturbation [rad] of q0 (0: nominal q0)")
    exp.add("--system", choices=cg.systems.names(), default="allegro", help="registered system")
    exp.add("--kind", choices=cg.KINDS, default="sphere", help="cooperative primitive")
    exp.add("--fig21-dt", type=positive_float, default=0.25, help="Δt of the Fig. 21 dilation step [s]")
    exp.add("--dt", type=positive_float, default=0.01, help="Δt of the teleoperation session [s] (Eq 61)")
    exp.add("--translation-gain", type=nonneg_float, default=0.5, help="k_t [radii/s per unit input]")
    exp.add("--dilation-gain", type=nonneg_float, default=1.0, help="k_d [1/s per unit input]")
    exp.add("--interactive", action="store_true", help="keyboard teleoperation in a matplotlib window")
    args = exp.parse(argv)
    plt = exp.pyplot(interactive=args.interactive)

    from coop_ga import viz
    from coop_ga.control.teleop import ScriptedInput, Teleoperator, run_interactive

    s = cg.systems.load(args.system)
    t = cg.cooperative_task(s, args.kind)
    rng = exp.rng
    q0 = np.clip(s.q0 + rng.uniform(-args.perturb, args.perturb, s.nq), s.q_lower, s.q_upper)
    gains = dict(translation_gain=args.translation_gain, dilation_gain=args.dilation_gain)

    def geom(q):
        X = t.primitive(q)
        return np.asarray(cg.center(X), float), float(cg.radius(X))

    c0, r0 = geom(q0)
    metrics: dict = {
        "system": args.system,
        "kind": args.kind,
        "seed": args.seed,
        "perturb_rad": args.perturb,
        "initial_radius_m": r0,
        "initial_center_m": c0.tolist(),
        "fig21": {},
    }
    configs = {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", cg.DegeneracyWarning)
        warnings.simplefilter("ignore", cg.JointLimitWarning)
        for beta, name in [(-1.0, "close"), (1.0, "open")]:
            one = Teleoperator(t, q0, dt=args.fig21_dt, **gains)
            one.step([0, 0, 0, 0, 0, beta])
            n_fine = round(args.fig21_dt / 0.01)
            fine = Teleoperator(t, q0, dt=0.01, **gains)
            fine.run([[0, 0, 0, 0, 0, beta]] * n_fine)
            c1, r1 = geom(one.q)
            c2, r2 = geom(fine.q)
            clamped = int(np.sum((one.q <= s.q_lower + 1e-12) | (one.q >= s.q_upper - 1e-12)))
            metrics["fig21"][name] = {
                "command": f"{beta:+g} e0inf",
                "d_of_command": float(np.exp(beta)),
                "dt_s": args.fig21_dt,
                "radius_before_m": r0,
                "radius_after_m": r1,
                "ratio": r1 / r0,
                "ratio_first_order_expected": float(np.exp(beta * args.fig21_dt)),
                "center_displacement_m": float(np.linalg.norm(c1 - c0)),
                "joints_at_limit": clamped,
                "fine_integration": {
                    "steps": n_fine,
                    "dt_s": 0.01,
                    "radius_after_m": r2,
                    "ratio": r2 / r0,
                    "center_displacement_m": float(np.linalg.norm(c2 - c0)),
                },
            }
            configs[name] = one.q
            print(
                f"{name:5s} ({beta:+g} e0∞, Δt={args.fig21_dt}): radius {r0:.4f} → {r1:.4f} m "
                f"(ratio {r1 / r0:.4f}, first order e^{{βΔt}} = {np.exp(beta * args.fig21_dt):.4f}; "
                f"{n_fine}×0.01 s: {r2 / r0:.4f})"
            )

        # scripted (or interactive) session
        tel = Teleoperator(t, q0, dt=args.dt, **gains)
        if args.interactive:
            mode = run_interactive(tel, fallback_script=SESSION)
        else:
            tel.run(ScriptedInput(SESSION, args.dt))
            mode = "scripted"
    n_degen = sum(1 for w in caught if issubclass(w.category, cg.DegeneracyWarning))
    for w in caught:
        if not issubclass(w.category, cg.DegeneracyWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    log = tel.log.arrays()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cg.DegeneracyWarning)
        geo = [geom(q) for q in log["q"]]
        wd = np.array([t.well_definedness(q) for q in log["q"]])
    if n_degen:
        print(
            f"note: {n_degen} DegeneracyWarnings (sphere close to coplanar points); min well-definedness "
            f"in the session {wd.min():.3g}"
        )
    centers = np.array([g[0] for g in geo])
    radii = np.array([g[1] for g in geo])
    metrics["session"] = {
        "mode": mode,
        "dt_s": args.dt,
        "script": [[d, list(c)] for d, c in SESSION] if mode == "scripted" else None,
        "duration_s": float(log["t"][-1]),
        "radius_min_m": float(radii.min()),
        "radius_max_m": float(radii.max()),
        "final_radius_m": float(radii[-1]),
        "min_well_definedness": float(wd.min()),
        "degeneracy_warnings": n_degen,
        # clamping at a joint limit breaks the pure similarity motion (e.g. the centre drifts)
        "joints_at_limit_during_session": sorted(
            {
                int(j)
                for j in np.flatnonzero(np.any((log["q"] <= s.q_lower + 1e-9) | (log["q"] >= s.q_upper - 1e-9), axis=0))
            }
        ),
        "center_path_during_pure_dilation_m": _dilation_drift(log["commands"], centers),
    }

    exp.write_npz(
        "session.npz",
        t=log["t"],
        q=log["q"],
        commands=log["commands"],
        bivectors=log["bivectors"],
        centers=centers,
        radii=radii,
        q_close=configs["close"],
        q_open=configs["open"],
        q0=q0,
    )
    exp.write_json("metrics.json", metrics)

    # ------------------------------------------------------------------ figure (Fig. 21 + session)
    fig = plt.figure(figsize=(15, 4.4))
    panels = [
        ("close", configs["close"], r"$B = -e_{0\infty}$ ($d$ = 0.3679): close"),
        ("orig", q0, "original"),
        ("open", configs["open"], r"$B = +e_{0\infty}$ ($d$ = 2.718): open"),
    ]
    axes = [fig.add_subplot(1, 4, i + 1, projection="3d") for i in range(3)]
    pts = []
    for ax, (_name, q, title) in zip(axes, panels):
        pts.append(viz.draw_robot(ax, s, q, color=viz.PALETTE.robot, lw=2.0, end_size=18).points)
        pts.append(viz.draw_primitive(ax, t.primitive(q), color=viz.PALETTE.initial_primitive, alpha=0.7).points)
        ax.set_title(f"{title}\nradius {geom(q)[1] * 1000:.1f} mm", fontsize=9)
        ax.tick_params(labelsize=6)
    for ax in axes:  # one scale for the three panels
        viz.set_equal_3d(ax, np.vstack(pts), pad=0.005)
    ax = fig.add_subplot(1, 4, 4)
    ax.plot(log["t"], radii * 1000, "k-", lw=2, label="radius")
    ax2 = ax.twinx()
    for k, col in enumerate(("tab:red", "tab:blue", "tab:purple")):
        ax2.plot(log["t"], (centers[:, k] - centers[0, k]) * 1000, color=col, lw=1, ls="--", label=f"centre {'xyz'[k]}")
    ax2.set_ylabel("centre displacement [mm]", fontsize=8)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="upper left")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("radius [mm]")
    ax.grid(alpha=0.3)
    ax.set_title(f"{mode} session (translate x, z, close, open, back)", fontsize=9)
    fig.suptitle(f"Teleoperation of the {args.system} cooperative {args.kind} (cf. Fig. 20–21)")
    fig.tight_layout()
    png = exp.save(fig, "teleop_allegro.png")
    print(f"wrote {exp.out}/metrics.json, session.npz, {png.name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
