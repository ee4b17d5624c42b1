#!/usr/bin/env python
"""Issue 13 (our addition, not a paper figure): the hexapod walks with a tripod, ripple or wave gait on
flat ground, steps or a random tile field, its stance legs driven through the stance primitive.

Robot: the PhantomX-size ``hexapod`` (``coop_ga/systems/robots/hexapod``: feet 0.1 m below the body,
leg reach ~0.2 m, 18 AX-12A servos with 1.5 N·m stall torque) on a floating body.  The walk is
:func:`coop_ga.legged.walk.walk` (read its module docstring): a phase table
(:func:`coop_ga.legged.gait.phase_table`), the stance legs and the body solved together by
:func:`coop_ga.legged.posture.posture_step` through the plane / circle / sphere of the stance feet
(so ride height and tilt follow the ground), swing feet on smooth arcs to footholds landed on the
terrain (``Terrain.land``), and at every time step the static stability margin (COM projection in the
support polygon), joint limits, foot slip and the static torques for equal load sharing against the
servo stall torque.

Defaults (WalkOptions): stride 0.08 m, cycle time 1.6 / 2.4 / 4.0 s (tripod / ripple / wave), so the
forward speed is 0.10 / 0.05 / 0.024 m/s and the joint speeds stay below the URDF's limit (6.18 rad/s); lift 0.03 m above the highest terrain under the swing; ride
height 0.10 m; footholds 0.16 m out from each coxa axis; Δt ≈ 0.02 s (0.04 s with ``--fast``).
The walk covers ``--distance`` (1 m; 0.3 m with ``--fast``).  Terrain ``steps``: 0.03 m rises every
0.25 m from x = 0.15 m; ``random``: 0.08 m tiles of height U[0, 0.025] m (seed ``--seed``).

Writes to ``--out``: ``metrics.json`` (distance walked, body tracking error, minimum stability margin,
maximum slip, maximum torque / stall, ``max_limit_violation``, joint speeds against the URDF's speed
limit (``max_velocity_violation``), clearance, the stance
primitives used, and the ``gallery`` block), ``scene.png`` (the robot at the start (light) and at a
mid-walk instant (grey) with the stance primitive of that instant (turquoise) and of the start
(green), the foot paths up to that instant (red) and the terrain profile), ``walk.gif`` (animation, matplotlib
PillowWriter), ``margin.png`` (stability margin over time and the gait diagram), ``height.png`` (body
height vs the terrain under it and the support plane), ``trajectory.npz`` (``t`` (T,) [s], ``q``
(T, 18) URDF order [rad], ``body`` (T, 7) position [m] + quaternion xyzw in W, ``stance`` (T, 6) bool
in the order lf, lm, lr, rf, rm, rr, ``feet`` (T, 6, 3) [m] W, ``margin`` (T,) [m], and the terrain
arrays ``terrain_*`` of ``Terrain.to_arrays``) and ``timing.json``.

    python experiments/hexapod_walk.py --gait ripple --terrain steps --out results/hexapod_walk
"""

from __future__ import annotations

import collections
import sys
import time
from typing import Any

import numpy as np

from coop_ga.harness import Experiment, int_at_least, positive_float

GAITS = ("tripod", "ripple", "wave")
TERRAINS = ("flat", "steps", "random")
VIEW = (24.0, -62.0)
SIZE = (8.0, 5.5)
GIF_DPI = 72


def _stance_primitive(points: np.ndarray, kind: str = "") -> tuple[Any, str]:
    """The stance primitive of stance feet (k, 3) in W for drawing (:func:`coop_ga.legged.stance.stance_primitive`),
    of the kind the posture step used (``kind``; its own decision rule if empty or degenerate)."""
    try:
        from coop_ga.legged.stance import stance_primitive
    except ImportError:  # FALLBACK until coop_ga.legged.stance exists: the circle / plane of three feet
        import itertools

        from coop_ga import geometry

        P = np.asarray(points, dtype=float)
        if len(P) == 3:
            return geometry.circle(*P), "circle"
        best = max(itertools.combinations(range(len(P)), 3), key=lambda c: _area(P[list(c)]))
        return geometry.plane(*P[list(best)]), "plane"
    from coop_ga.errors import CoopGAError

    base = kind.replace("_fit", "")
    try:
        sp = stance_primitive(points, kind=base if base in ("sphere", "plane", "circle") else None)
    except CoopGAError:
        sp = stance_primitive(points)
    return sp.X, str(sp.kind)


def _area(P: np.ndarray) -> float:
    return float(np.linalg.norm(np.cross(P[1] - P[0], P[2] - P[0])))


def _terrain_curves(terrain: Any, x0: float, x1: float, y_side: float) -> list[np.ndarray]:
    """Terrain profiles (polylines in W) along x at y = ±y_side and across at the ends, for the scene."""
    xs = np.linspace(x0, x1, 400)
    out = []
    for y in (-y_side, 0.0, y_side):
        xy = np.column_stack((xs, np.full_like(xs, y)))
        out.append(np.column_stack((xy, terrain.height(xy))))
    return out


def _skeleton(system: Any, q24: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Body hexagon (7, 3) and six leg polylines (4, 3) (coxa, femur, tibia joints, foot) in W."""
    import pinocchio as pin

    m, d = system.model, system.model.createData()
    pin.framesForwardKinematics(m, d, q24)
    legs = []
    for leg in ("lf", "lm", "lr", "rf", "rm", "rr"):
        pts = [np.array(d.oMi[m.getJointId(f"{leg}_{j}_joint")].translation) for j in ("coxa", "femur", "tibia")]
        pts.append(np.array(d.oMf[m.getFrameId(f"{leg}_foot")].translation))
        legs.append(np.array(pts))
    ring = [legs[i][0] for i in (0, 1, 2, 5, 4, 3, 0)]
    return np.array(ring), legs


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--gait", choices=GAITS, default="tripod", help="gait of the phase table")
    exp.add("--terrain", choices=TERRAINS, default="flat", help="terrain kind (random: tiles under --seed)")
    exp.add("--distance", type=positive_float, default=1.0, help="distance to walk [m] (--fast: 0.3 m)")
    exp.add("--dt", type=positive_float, default=0.02, help="time step [s] (rounded to the gait's grid; --fast 0.04)")
    exp.add("--frames", type=int_at_least(2), default=60, help="frames of walk.gif (--fast: 12)")
    exp.add_fast("a short walk and GIF (CI)", distance=0.3, dt=0.04, frames=12)
    args = exp.parse(argv)
    t_start = time.perf_counter()

    from coop_ga import viz
    from coop_ga.legged.body import floating_hexapod
    from coop_ga.legged.legs import hexapod_legs
    from coop_ga.legged.terrain import Terrain
    from coop_ga.legged.walk import SERVO_SPEED, WalkOptions, robot_mass, walk

    distance, dt, frames = float(args.distance), float(args.dt), int(args.frames)
    opts = WalkOptions(gait=args.gait, dt=dt)
    if round(opts.period / dt / 6) < 1:  # walk() would silently use its coarsest grid, T/6, instead
        exp.parser.error(
            f"argument --dt: {dt:g} s is too coarse for the {args.gait} gait: Δt is rounded to a whole sixth of "
            f"its {opts.period:g} s cycle, at most {opts.period / 6:.3g} s; give --dt < {opts.period / 3:.3g} s"
        )
    terrain = Terrain.make(args.terrain, seed=int(exp.seed if exp.seed is not None else 0))
    legs = hexapod_legs()
    with exp.stage(f"walking {distance} m, {args.gait} on {args.terrain}"):
        t0 = time.perf_counter()
        res = walk(terrain, opts, distance=distance, legs=legs)
        walk_time = time.perf_counter() - t0
    T = len(res.t)
    cmd = opts.command()
    kinds = collections.Counter(k for k in res.primitive_kind.tolist() if k)
    track = res.max_tracking_error
    speed_ratio = res.max_joint_speed / SERVO_SPEED
    ok = (
        res.min_margin > 0
        and res.max_limit_violation == 0.0
        and res.max_velocity_violation == 0.0
        and res.max_slip < 1e-6
        and res.max_torque_ratio < 1.0
        and abs(res.distance - distance) < 0.01
    )
    metrics: dict[str, Any] = {
        "gait": args.gait,
        "terrain": args.terrain,
        "seed": exp.seed,
        "fast": bool(args.fast),
        "steps": T - 1,
        "dt_s": res.dt,
        "duration_s": float(res.t[-1]),
        "cycle_time_s": res.table.period,
        "duty": res.table.duty,
        "command": {"vx_m_s": float(cmd[0]), "vy_m_s": float(cmd[1]), "yaw_rate_rad_s": float(cmd[2])},
        "stride_m": opts.stride,
        "lift_height_m": opts.lift_height,
        "ride_height_m": opts.ride_height,
        "commanded_distance_m": distance,
        "distance_m": res.distance,
        "distance_error_m": abs(res.distance - distance),
        "body_tracking_error_m": float(track[0]),
        "body_tracking_error_rad": float(track[1]),
        "body_position_error_m": float(res.body_error.max()),
        "min_stability_margin_m": res.min_margin,
        "max_slip_m": res.max_slip,
        "max_torque_ratio": res.max_torque_ratio,
        "stall_torque_Nm": float(np.max(legs.effort_limit)),
        "max_torque_Nm": res.max_torque_ratio * float(np.max(legs.effort_limit)),
        "max_limit_violation": res.max_limit_violation,
        "max_joint_speed_rad_s": res.max_joint_speed,
        "servo_no_load_speed_rad_s": SERVO_SPEED,
        "max_joint_speed_ratio": speed_ratio,
        "max_velocity_ratio": res.max_velocity_ratio,
        "max_velocity_violation": res.max_velocity_violation,
        "min_swing_clearance_m": float(np.min(res.swing_clearance)),
        "max_contact_error_m": float(np.max(res.contact_error)),
        "min_reach_margin_m": float(np.min(res.reach_margin)),
        "ik_fallback_steps": res.fallback_steps,
        "posture_step": bool(res.posture),
        "stance_primitive_steps": dict(sorted(kinds.items())),
        "min_well_definedness": float(np.nanmin(res.well_definedness))
        if np.any(np.isfinite(res.well_definedness))
        else None,
        "min_stance_legs": int(res.stance.sum(axis=1).min()),
        "mass_kg": robot_mass(legs),
        "body_height_above_ground_m": {
            "min": float(np.min(res.body[:, 2] - res.ground_height)),
            "max": float(np.max(res.body[:, 2] - res.ground_height)),
        },
        "body_rise_m": float(res.body[-1, 2] - res.body[0, 2]),
        "terrain_rise_m": float(res.ground_height[-1] - res.ground_height[0]),
    }
    kinds_txt = ", ".join(f"{k} {v}" for k, v in sorted(kinds.items()))
    metrics["gallery"] = {
        "title": f"Hexapod walking: {args.gait} gait on {args.terrain} ground (our addition, issue 13)",
        "claim": (
            "Driving the stance legs through the cooperative primitive of the stance feet (plane, circle or "
            "sphere) lets the hexapod walk with tripod, ripple and wave gaits on flat and uneven ground, its "
            "ride height and tilt following the terrain, with the feet fixed and the robot statically stable."
        ),
        "evidence": (
            f"{res.distance:.3f} m walked of {distance:.3f} m commanded in {res.t[-1]:.2f} s; minimum static "
            f"stability margin {res.min_margin * 1000:.1f} mm (>0 throughout: {res.min_margin > 0}); max stance-foot "
            f"slip {res.max_slip:.1e} m; max joint-limit violation {res.max_limit_violation:.1e} rad; max static "
            f"torque {res.max_torque_ratio:.2f} × stall; posture tracking residual {track[0]:.1e} m / {track[1]:.1e} "
            f"rad; stance primitives per step: {kinds_txt}. Peak joint speed {res.max_joint_speed:.1f} rad/s = "
            f"{res.max_velocity_ratio:.2f} × the URDF speed limit (the AX-12A's no-load speed; violation "
            f"{res.max_velocity_violation:.1e} rad/s)."
        ),
        "agrees": bool(ok),
        "figures": ["scene.png", "walk.gif", "margin.png", "height.png"],
    }

    # ------------------------------------------------------------------ trajectory.npz
    exp.write_npz(
        "trajectory.npz",
        t=res.t,
        q=res.q,
        body=res.body,
        stance=res.stance,
        feet=res.feet,
        margin=res.margin,
        **terrain.to_arrays(),
    )

    # ------------------------------------------------------------------ scene.png
    t1 = time.perf_counter()
    system = floating_hexapod()
    k_mid = int(np.argmin(np.abs(res.t - 0.6 * res.t[-1])))
    with exp.stage("rendering scene.png"):
        scene = viz.Scene()
        s0, s1 = res.state(0), res.state(k_mid)
        scene.robot(system, s0.floating_q(), "initial", label="start")
        scene.robot(system, s1.floating_q(), "final", label=f"t = {res.t[k_mid]:.2f} s")
        for k, role in ((0, "initial"), (k_mid, "final")):
            st = res.stance[k]
            X, kind = _stance_primitive(res.feet[k][st], str(res.primitive_kind[min(k + 1, T - 1)]))
            scene.primitive(X, role, label=f"stance {kind} ({int(st.sum())} feet), t = {res.t[k]:.2f} s")
            scene.curve(res.feet[k][st], "neutral", markers=True)
        for i in range(6):
            scene.curve(res.feet[: k_mid + 1, i], "trajectory", label="foot paths" if i == 0 else None)
        x0, x1 = float(res.body[:, 0].min()) - 0.3, float(res.body[k_mid, 0]) + 0.3
        for c in _terrain_curves(terrain, x0, x1, 0.3):
            scene.curve(c, "neutral")
        viz.render_scene(
            scene,
            exp.out / "scene.png",
            view=VIEW,
            size=SIZE,
            title=f"{args.gait} gait on {args.terrain}: stance primitive and foot paths",
        )
    render_time = time.perf_counter() - t1

    # ------------------------------------------------------------------ time plots
    plt = exp.pyplot()
    fig, ax = plt.subplots(2, 1, figsize=(7.0, 4.6), sharex=True)
    ax[0].plot(res.t, res.margin * 1000, color="C3", lw=1.2)
    ax[0].axhline(0.0, color="k", lw=0.6)
    ax[0].set_ylabel("stability margin [mm]")
    ax[0].set_title(f"{args.gait} on {args.terrain}: min margin {res.min_margin * 1000:.1f} mm")
    ax[1].imshow(
        res.stance.T,
        aspect="auto",
        cmap="Greys",
        vmin=0,
        vmax=1.6,
        interpolation="nearest",
        extent=(float(res.t[0]), float(res.t[-1]), 5.5, -0.5),
    )
    ax[1].set_yticks(range(6), ["lf", "lm", "lr", "rf", "rm", "rr"])
    ax[1].set_ylabel("stance (dark)")
    ax[1].set_xlabel("t [s]")
    exp.save(fig, "margin.png")
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7.0, 3.4))
    ax.plot(res.t, res.body[:, 2], color="C3", lw=1.2, label="body origin z")
    ax.plot(res.t, res.ground_height, color="k", lw=1.0, label="terrain under the body")
    ax.plot(res.t, res.support_height, color="C2", lw=1.0, ls="--", label="support plane under the body")
    ax.plot(res.t, res.support_height + opts.ride_height, color="C1", lw=0.8, ls=":", label="support + ride height")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("z [m]")
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("body height follows the support plane of the stance feet")
    exp.save(fig, "height.png")
    plt.close(fig)

    # ------------------------------------------------------------------ walk.gif
    t2 = time.perf_counter()
    with exp.stage(f"animating walk.gif ({frames} frames)"):
        from matplotlib.animation import PillowWriter

        idx = np.unique(np.linspace(0, T - 1, frames).round().astype(int))
        fig = plt.figure(figsize=(5.6, 4.2))
        ax3 = fig.add_subplot(projection="3d")
        gx = np.linspace(x0, float(res.body[:, 0].max()) + 0.3, 90)
        gy = np.linspace(float(res.body[:, 1].min()) - 0.35, float(res.body[:, 1].max()) + 0.35, 24)
        GX, GY = np.meshgrid(gx, gy)
        GZ = terrain.height(np.stack((GX, GY), axis=-1))
        writer = PillowWriter(fps=max(1, round(frames / max(float(res.t[-1]), 1e-9))))
        with writer.saving(fig, str(exp.out / "walk.gif"), dpi=GIF_DPI):
            for k in idx:
                ax3.cla()
                ax3.plot_surface(GX, GY, GZ, color="0.85", alpha=0.5, linewidth=0, shade=False)
                ring, leg_lines = _skeleton(system, res.state(int(k)).floating_q())
                ax3.plot(*ring.T, color="0.2", lw=2.2)
                for i, L in enumerate(leg_lines):
                    ax3.plot(*L.T, color="C3" if res.stance[k, i] else "C0", lw=2.0)
                st = res.stance[k]
                if st.sum() >= 3:
                    from coop_ga.legged.walk import convex_hull

                    H = convex_hull(res.feet[k][st][:, :2])
                    Hz = terrain.height(H) + 1e-3
                    ax3.plot(*np.column_stack((H, Hz))[list(range(len(H))) + [0]].T, color="C2", lw=1.5)
                com = res.com[k]
                ax3.scatter([com[0]], [com[1]], [float(terrain.height(com[:2]))], color="k", s=14)
                ax3.plot(*res.body[: k + 1, :3].T, color="C3", lw=0.8)
                c = res.body[k, :3]
                ax3.set_xlim(c[0] - 0.35, c[0] + 0.35)
                ax3.set_ylim(c[1] - 0.35, c[1] + 0.35)
                ax3.set_zlim(float(res.ground_height.min()) - 0.05, float(res.ground_height.min()) + 0.3)
                ax3.set_box_aspect((1.0, 1.0, 0.5))
                ax3.view_init(*VIEW)
                ax3.set_title(f"{args.gait} on {args.terrain}, t = {res.t[k]:.2f} s", fontsize=8)
                ax3.tick_params(labelsize=5)
                writer.grab_frame()
        plt.close(fig)
    gif_time = time.perf_counter() - t2

    exp.write_json("metrics.json", metrics)
    exp.write_timing(
        {
            "walk_s": walk_time,
            "render_s": render_time,
            "gif_s": gif_time,
            "total_runtime_s": time.perf_counter() - t_start,
        }
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
