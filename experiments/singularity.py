#!/usr/bin/env python
"""§4.4 / Figs. 18–19: a geometric singularity of the cooperative circle of three Franka arms.

System ``three_franka`` (21 joints), cooperative circle X_c = P1 ∧ P2 ∧ P3 through the three
TCPs (Eq 14; P1, P2, P3 = TCPs 0, 1, 2), **tracked only, never controlled**: arm 0 drives its TCP onto the line through the
other two TCPs, which stay put, so the three end points become collinear and the circle
degenerates into that line (a circle of infinite radius).

Set-up
------
* Start configuration q_s.  At q0 every point of the line through TCPs 1 and 2 is ≥ 1.06 m from
  arm 0's shoulder, beyond a Panda's reach, so first arms 1 and 2 move their TCPs (the same
  point-reaching controller, inside the limits) to ``(±half_width, line_y, line_z)`` — by default
  (±0.30, −0.05, 0.45) m.  Arm 0 stays at q0.  q_s is the "initial" configuration of every figure.
* Target: the point ``p* = P2 + f (P3 − P2)`` of that line (``--target-fraction`` f, default 0.5:
  the midpoint, the point of the line closest to arm 0's shoulder).
* Controller (arm 0 only; arms 1, 2 have zero velocity): Euclidean point reaching
  ``v = k (p* − p_0)`` capped at ``--max-speed`` [m/s] (what ``coop_ga.control.point_reaching_velocity``
  commands), mapped to arm 0's seven joint velocities by the limit-aware QP of ``coop_ga.control``
  (``solve_qp``: min ½‖J_p q̇ − v‖² + ½λ²‖q̇‖² inside ``velocity_bounds`` — the position limits over Δt
  with the safety gain 0.95 and the velocity limits), then q_{t+1} = q_t + Δt q̇ (Eq 61).

Stopping rule (the library raises at the singularity)
-----------------------------------------------------
Every guarded evaluation of the task computes the well-definedness w of the end points
(``coop_ga.well_definedness``: smallest triangle altitude / longest edge / (√3/2); 1 = equilateral,
0 = collinear).  Below ``task.warn_below`` = 1e-2 it emits a ``DegeneracyWarning``; at or below
``task.raise_below`` = 1e-6 it raises ``DegeneratePrimitiveError``.  Before each step the script
computes w at the *next* configuration from the forward kinematics (the same function, unguarded)
and stops at the last step whose w is above the raise threshold (``stopped_reason``); a raise that
slipped through would be caught and reported as well.  So the run ends with
raise_below < w_final and w_next ≤ raise_below.  The warnings are collected
(``coop_ga.diagnostics.collect_warnings``) and counted, not printed once per step.

Recorded per step
-----------------
* circle: centre [m], radius [m], normal (``coop_ga.center/radius/normal`` of X_c), the 10
  coefficients of X_c on e012 … e23∞ (taken to be the paper's "circle parameters" of Fig. 19a),
  and the closed-form circumcentre/circumradius of the three points as a cross-check of the
  read-outs;
* B_Sc = log V_Sc(q) (``task.log``): the 7 coordinates ``[θ12, θ13, θ23, β, t1, t2, t3]`` on
  ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` with V = exp(b) = V_T V_R V_D — t is the translation
  (≈ the centre), β = ln(radius) the dilation, θ the rotation of the unit circle onto X_c;
* the 7 eigenvalues of the task-space manipulability M_S = J^G J^Gᵀ (Eq 59,
  ``coop_ga.cooperative.manipulability``; J^G the 7×21 body-frame Jacobian, Eq 30) computed as the
  squared singular values of J^G (an eigendecomposition of M_S itself resolves eigenvalues only
  down to ε·λ_max, ≈ 1e-3 here at the end), and the same eigenvalues from the closed-form
  Jacobian route (``task.jacobian_closed_form``) to tell resolved values from rounding noise.
  The circle has 6 DOF, so rank J^G = 6 and λ₁ ≡ 0 (rotation of the circle about its own normal,
  Table 1); "smallest eigenvalue" below means λ₂, the smallest of the six that are not
  structurally zero;
* w, the distance of TCP 0 to the line through TCPs 1, 2 [m], and the joint limits' margin.

Findings (default run; the numbers are in ``metrics.json``): the radius grows like 1/w (0.32 m →
~9e4 m), the centre runs away with it and the e0-carrying coefficients of X_c (e012, e013, e023,
e123) fall ∝ w to ~0, the bivector's translation components diverge ∝ 1/w and β = ln r grows
logarithmically; of the six non-structural eigenvalues two fall ∝ w² (by ~10 orders of magnitude to ~1e-10, i.e. to zero),
two stay O(1) and two *grow* ∝ 1/w² (to ~1e13) — the paper mentions only the falling ones.  Below
w ≈ 6e-6 the small eigenvalues of the two Jacobian routes disagree: J^G has lost its small
directions to rounding before the guard raises at 1e-6.

Writes to ``--out``: ``metrics.json`` (with the ``gallery`` block), ``trajectory.npz``,
``fig18_scene.png``, ``fig19_circle_parameters.png``, ``fig19_bivector.png``,
``fig19_manipulability.png``, ``fig18_animation.gif`` (the motion, ``--frames`` frames; the circle drawn only while
its radius is at most DRAW_RADIUS_MAX); wall-clock times in ``timing.json``.

    python experiments/singularity.py --out results/fig18_19_singularity
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np

from coop_ga.harness import Experiment, finite_float, int_at_least, positive_float

#: relative margin of the stopping rule on the raise threshold (the compiled and the numpy
#: well-definedness agree to rounding; this keeps a borderline step from reaching the guard)
STOP_MARGIN = 1e-9
#: a non-structural eigenvalue counts as resolved when the two Jacobian routes agree to this (relative)
RESOLVED_RTOL = 1e-2
#: the structural zero eigenvalue (≤ 1e-28 here) is drawn at this floor on the log axes
EIG_FLOOR = 1e-15
#: radius [m] above which a circle is no longer drawn in the scene (it would dwarf the robots)
DRAW_RADIUS_MAX = 0.8


# ---------------------------------------------------------------------- geometry helpers
def distance_to_line(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance [m] of point p (3,) to the line through a, b (3,) (world frame)."""
    u = (b - a) / np.linalg.norm(b - a)
    d = p - a
    return float(np.linalg.norm(d - (d @ u) * u))


def circumcircle(P: np.ndarray) -> tuple[np.ndarray, float]:
    """Closed-form circumcentre (3,) [m] and circumradius [m] of three points P (3, 3), world frame.

    ``c = p1 + ((|a|² b − |b|² a) × (a × b)) / (2|a × b|²)`` and ``r = |a||b||a − b| / (2|a × b|)``
    with a = p2 − p1, b = p3 − p1 — an independent check of the CGA read-outs (Eq 24, 27)."""
    p1, p2, p3 = np.asarray(P, dtype=float)
    a, b = p2 - p1, p3 - p1
    axb = np.cross(a, b)
    n2 = float(axb @ axb)
    c = p1 + np.cross((a @ a) * b - (b @ b) * a, axb) / (2.0 * n2)
    r = float(np.linalg.norm(a) * np.linalg.norm(b) * np.linalg.norm(a - b) / (2.0 * np.sqrt(n2)))
    return c, r


def sorted_eigenvalues(J: np.ndarray) -> np.ndarray:
    """Eigenvalues (7,) ascending of M_S = J Jᵀ (Eq 59) for J (7, nq), as squared singular values of J."""
    return np.sort(np.linalg.svd(np.asarray(J, dtype=float), compute_uv=False) ** 2)


def arm_columns(system: Any, frame: str) -> np.ndarray:
    """Indices of the joints of the arm that carries end frame ``frame`` (``arm<i>_…`` prefix)."""
    prefix = frame.split("_", 1)[0] + "_"
    cols = [j for j, n in enumerate(system.joint_names) if n.startswith(prefix)]
    if not cols:
        from coop_ga.errors import InvalidInputError

        raise InvalidInputError(f"no joint of {system.name!r} starts with {prefix!r} (end frame {frame!r})")
    return np.asarray(cols)


# ---------------------------------------------------------------------- the point-reaching controller
def point_velocity(
    task: Any,
    q: np.ndarray,
    index: int,
    cols: np.ndarray,
    target: np.ndarray,
    *,
    dt: float,
    gain: float,
    max_speed: float,
    damping: float,
) -> tuple[np.ndarray, bool]:
    """Joint velocity (nq,) [rad/s] moving end point ``index`` toward ``target`` (3,) [m, world] with
    the joints ``cols`` only, inside the position (over ``dt``) and velocity limits.

    ``v = gain (p* − p)`` capped at ``max_speed`` [m/s]; q̇_cols = argmin ½‖J_p q̇ − v‖² + ½λ²‖q̇‖²
    s.t. the box of ``coop_ga.control.qp.velocity_bounds`` (``solve_qp``; the damped least-squares
    solution whenever it is inside the box).  Returns (q̇, whether a bound was active)."""
    from coop_ga.control.qp import DEFAULT_LIMIT_GAIN, damped_lstsq, solve_qp, velocity_bounds

    lim = task.system.limits
    p = task.tree.end_points_array(q)[index]
    Jp = task.tree.euclidean_point_jacobians(q)[index][:, cols]
    v = gain * (np.asarray(target, dtype=float) - p)
    s = float(np.linalg.norm(v))
    if s > max_speed:
        v *= max_speed / s
    lb, ub = velocity_bounds(q, lim.lower, lim.upper, lim.velocity, dt, DEFAULT_LIMIT_GAIN)
    sol = solve_qp(Jp, v, damping, lb[cols], ub[cols], x_free=damped_lstsq(Jp, v, damping), what="point reaching")
    qd = np.zeros_like(q)
    qd[cols] = sol.x
    return qd, bool(sol.used_qp)


def advance(task: Any, q: np.ndarray, qd: np.ndarray, dt: float) -> np.ndarray:
    """q + Δt q̇ (Eq 61), clipped into the position limits (a rounding correction only: q̇ is in the box)."""
    lim = task.system.limits
    return np.clip(q + dt * qd, lim.lower, lim.upper)


def prepare_start(
    task: Any, q0: np.ndarray, targets: dict[int, np.ndarray], cols: dict[int, np.ndarray], *, tol: float = 1e-9
) -> tuple[np.ndarray, int]:
    """Move end points ``targets`` {index: (3,) m, world} to their targets with their own arms (the
    others fixed), inside the limits; returns (q_s, steps).  Raises InvalidInputError if they are not
    reached within ``tol`` [m] (1000 steps, or earlier when the error stops shrinking: < 0.1 % in 50 steps)."""
    from coop_ga.errors import InvalidInputError

    q = np.array(q0, dtype=float)
    dt, gain, speed = 0.02, 10.0, 1.0
    history: list[float] = []
    for k in range(1000):
        P = task.tree.end_points_array(q)
        err = max(float(np.linalg.norm(P[i] - p)) for i, p in targets.items())
        if err < tol:
            return q, k
        history.append(err)
        if k >= 50 and err > 0.999 * history[k - 50]:
            break  # stalled (out of reach or at a limit)
        qd = np.zeros_like(q)
        for i, p in targets.items():
            qd += point_velocity(task, q, i, cols[i], p, dt=dt, gain=gain, max_speed=speed, damping=1e-3)[0]
        q = advance(task, q, qd, dt)
    raise InvalidInputError(
        f"the fixed end points {[np.round(p, 3).tolist() for p in targets.values()]} m are not reachable inside the "
        f"joint limits (remaining error {err:.3g} m); choose --half-width/--line-y/--line-z closer to the arms"
    )


def drive(
    task: Any, q_s: np.ndarray, target: np.ndarray, cols0: Any, args: Any, record: Any, rec: dict[str, list[Any]]
) -> tuple[str, float, int]:
    """Drive TCP 0 from q_s towards ``target`` with the point-reaching control, recording every step, until the
    duration is up or the next step would reach the raise threshold; returns ``(why it stopped, w at the step
    it did not take, QP steps)``."""
    import coop_ga as cg
    from coop_ga.errors import DegeneratePrimitiveError

    dt = args.dt
    q = q_s.copy()
    w_next, qp_steps = float("nan"), 0
    record(q)
    while True:
        t_now = dt * (len(rec["q"]) - 1)
        if t_now >= args.duration - 1e-12:
            return f"duration {args.duration:g} s reached with w = {rec['w'][-1]:.3g}", w_next, qp_steps
        qd, active = point_velocity(
            task, q, 0, cols0, target, dt=dt, gain=args.gain, max_speed=args.max_speed, damping=args.damping
        )
        qp_steps += active
        q_next = advance(task, q, qd, dt)
        w_next = float(cg.well_definedness("circle", task.tree.end_points_array(q_next)))
        if w_next <= task.raise_below * (1.0 + STOP_MARGIN):
            why = (
                f"raise threshold: the next step would give w = {w_next:.4g} <= raise_below = "
                f"{task.raise_below:g} (DegeneratePrimitiveError); stopped at the last step above it"
            )
            return why, w_next, qp_steps
        try:
            record(q_next)
        except DegeneratePrimitiveError as e:  # the prediction missed it: stop here and say so
            return f"DegeneratePrimitiveError caught at the next step: {e}", w_next, qp_steps
        q = q_next


# ---------------------------------------------------------------------- main
def _parse(argv: list[str] | None) -> Experiment:
    """The command line."""
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--dt", type=positive_float, default=0.01, help="time step [s] of the point-reaching control (Eq 61)")
    exp.add("--gain", type=positive_float, default=2.0, help="point-reaching gain k [1/s]")
    exp.add("--max-speed", type=positive_float, default=0.25, help="TCP speed cap [m/s]")
    exp.add("--damping", type=positive_float, default=1e-3, help="damping λ of the point-reaching least squares")
    exp.add("--duration", type=positive_float, default=20.0, help="longest simulated time [s] if w never reaches 1e-6")
    exp.add("--half-width", type=positive_float, default=0.30, help="TCPs 1, 2 are placed at x = ±half-width [m]")
    exp.add("--line-y", type=finite_float, default=-0.05, help="y [m] of the line through TCPs 1, 2")
    exp.add("--line-z", type=finite_float, default=0.45, help="z [m] of the line through TCPs 1, 2")
    exp.add(
        "--target-fraction",
        type=finite_float,
        default=0.5,
        help="target p* = P2 + f (P3 − P2) on the line (0.5: the midpoint)",
    )
    exp.add("--frames", type=int_at_least(2), default=30, help="frames of fig18_animation.gif (--fast: 4)")
    exp.add_fast("CI run (same controller and stop rule)", dt=0.05, frames=4)
    exp.parse(argv)
    return exp


#: what :func:`_recorder` records at every step
RECORDED = (
    "q",
    "points",
    "w",
    "center",
    "radius",
    "normal",
    "xc",
    "circumcenter",
    "circumradius",
    "log",
    "eig",
    "eig_cf",
    "distance",
)


def _recorder(task: Any, closed_form: bool) -> tuple[dict[str, list[Any]], Any]:
    """``(rec, record)``: ``record(q)`` appends the circle, its read-outs, its bivector and the manipulability
    eigenvalues (compiled and, for the canonical chart, closed-form) at ``q`` to the lists of ``rec``."""
    import coop_ga as cg
    from coop_ga.cooperative import cooperative_primitive

    rec: dict[str, list[Any]] = {k: [] for k in RECORDED}

    def record(q: np.ndarray) -> None:
        st = task.evaluate(q)  # guarded: warns below 1e-2, raises at 1e-6
        X = cooperative_primitive("circle", [cg.point(p) for p in st.points])  # = task.primitive(q)
        cc, cr = circumcircle(st.points)
        eig = sorted_eigenvalues(st.jacobian)
        eig_cf = sorted_eigenvalues(task.jacobian_closed_form(q)[1]) if closed_form else np.full(7, np.nan)
        row = {
            "q": q.copy(),
            "points": st.points,
            "w": st.well_definedness,
            "center": np.asarray(cg.center(X), dtype=float).reshape(3),
            "radius": float(cg.radius(X)),
            "normal": np.asarray(cg.normal(X), dtype=float).reshape(3),
            "xc": np.asarray(X.coeffs, dtype=float),
            "circumcenter": cc,
            "circumradius": cr,
            "log": st.log,
            "eig": eig,
            "eig_cf": eig_cf,
            "distance": distance_to_line(st.points[0], st.points[1], st.points[2]),
        }
        for k, v in row.items():
            rec[k].append(v)

    return rec, record


def _resolved(E: np.ndarray, Ecf: np.ndarray, closed_form: bool) -> tuple[np.ndarray, int]:
    """``(rel, k_res)``: which eigenvalues are resolved — the compiled and the closed-form routes agree on the
    non-structural ones up to step ``k_res``; ``rel`` (T,) their largest relative difference."""
    T = len(E)
    if closed_form:
        rel = np.max(np.abs(E[:, 1:] - Ecf[:, 1:]) / np.maximum(np.abs(Ecf[:, 1:]), 1e-300), axis=1)
        bad = np.flatnonzero(rel > RESOLVED_RTOL)
        k_res = int(bad[0] - 1) if bad.size else T - 1
    else:
        rel, k_res = np.full(T, np.nan), T - 1
    return rel, max(k_res, 0)


def _analyse(
    task: Any, R: dict[str, np.ndarray], closed_form: bool, dt: float, cols: dict, q_s: np.ndarray, P_s: np.ndarray
) -> dict[str, Any]:
    """Everything measured on the recorded run ``R``: power laws vs w, eigenvalue changes, limits, read-outs."""
    import coop_ga as cg
    from coop_ga.algebra import blade_name
    from coop_ga.cooperative import cooperative_primitive

    lim = task.system.limits  # position [rad] and velocity [rad/s] limits, (nq,) each
    T = len(R["w"])
    t = dt * np.arange(T)
    Q, W, E, Ecf = R["q"], R["w"], R["eig"], R["eig_cf"]
    rel, k_res = _resolved(E, Ecf, closed_form)
    # power laws in the resolved asymptotic range w ≤ warn_below: log λ_i, log r, log |t| vs log w
    fit = np.arange(T)[(W <= task.warn_below) & (np.arange(T) <= k_res)]

    def slope(y: np.ndarray) -> float:
        if fit.size < 3 or np.any(y[fit] <= 0):
            return float("nan")
        return float(np.polyfit(np.log(W[fit]), np.log(y[fit]), 1)[0])

    tnorm = np.linalg.norm(R["log"][:, 4:], axis=1)
    e0, ef, er = E[0], E[-1], E[k_res]
    names = [blade_name(b) for b in cooperative_primitive("circle", [cg.point(p) for p in P_s]).blades]
    xc0, xcf = R["xc"][0], R["xc"][-1]
    # circle coefficients: which fall by > 100x (relative to the largest coefficient at the start)
    big0 = np.abs(xc0) > 1e-6 * np.max(np.abs(xc0))
    below_warn = int(np.sum(W < task.warn_below))
    fixed_cols = np.r_[cols[1], cols[2]]
    return {
        "T": T,
        "t": t,
        "rel": rel,
        "k_res": k_res,
        "fit": fit,
        "eig_slopes": [slope(E[:, i]) for i in range(1, 7)],
        "radius_slope": slope(R["radius"]),
        "tnorm": tnorm,
        "translation_slope": slope(tnorm),
        "e0": e0,
        "ef": ef,
        "er": er,
        "fallen": int(np.sum(ef[1:] < e0[1:] / 10.0)),
        "grown": int(np.sum(ef[1:] > e0[1:] * 10.0)),
        "fallen_res": int(np.sum(er[1:] < e0[1:] / 10.0)),
        "limit_violation": float(max(0.0, np.max(lim.lower - Q), np.max(Q - lim.upper))),
        "vel_excess": float(max(0.0, np.max(np.abs(np.diff(Q, axis=0)) / dt - lim.velocity))) if T > 1 else 0.0,
        "others_moved": float(np.max(np.abs(Q[:, fixed_cols] - q_s[fixed_cols]))),
        # read-outs against the closed-form circumcircle
        "r_rel": np.abs(R["radius"] - R["circumradius"]) / R["circumradius"],
        "c_rel": np.linalg.norm(R["center"] - R["circumcenter"], axis=1) / R["circumradius"],
        "names": names,
        "xc0": xc0,
        "xcf": xcf,
        "xc_fallen": [n for n, a, b, m in zip(names, xc0, xcf, big0) if m and abs(b) < abs(a) / 100.0],
        "B0": R["log"][0],
        "Bf": R["log"][-1],
        "below_warn": below_warn,
        "t_warn": float(t[np.argmax(W < task.warn_below)]) if below_warn else float("nan"),
        "n_circles_drawn": int(np.sum(R["radius"] <= DRAW_RADIUS_MAX)),
    }


def _draw_scene(
    exp: Experiment, s: Any, task: Any, q_s: np.ndarray, R: dict, A: dict, Xs: list, line_ends: tuple
) -> Any:
    """Fig. 18: start and end, the circles as they grow (up to :data:`DRAW_RADIUS_MAX`), the line, TCP 0's path."""
    from coop_ga import viz

    t, W, a_pt, b_pt = A["t"], R["w"], *line_ends
    drawable = np.flatnonzero(R["radius"] <= DRAW_RADIUS_MAX)
    k_last = int(drawable[-1]) if drawable.size else 0
    scene = viz.Scene()
    scene.robot(s, q_s, "initial", "initial configuration")
    scene.robot(s, R["q"][-1], "final", f"final configuration (t = {t[-1]:.2f} s)")
    scene.primitive(Xs[0], "initial", f"initial circle (r = {R['radius'][0]:.2f} m)")
    r_log = np.geomspace(R["radius"][0], R["radius"][k_last], 6)[1:-1]
    inter = sorted({int(np.argmin(np.abs(np.log(R["radius"][: k_last + 1] / r)))) for r in r_log} - {0, k_last})
    for j, k in enumerate(inter):
        scene.primitive(
            Xs[k], "intermediate", "intermediate circles" if j == 0 else None, fraction=(j + 1) / (len(inter) + 1)
        )
    scene.primitive(
        Xs[k_last],
        "final",
        f"last circle with r ≤ {DRAW_RADIUS_MAX:g} m (t = {t[k_last]:.2f} s, w = {W[k_last]:.2g})",
    )
    u = (b_pt - a_pt) / np.linalg.norm(b_pt - a_pt)
    ext = 0.35 * np.linalg.norm(b_pt - a_pt)
    line = a_pt + np.linspace(-ext, np.linalg.norm(b_pt - a_pt) + ext, 14)[:, None] * u
    dots = {"color": viz.PALETTE.trajectories[1]}
    scene.curve(line, "trajectory", "degenerate line through TCPs 1, 2 (dots)", markers=True, style=dots)
    scene.curve(R["points"][:, 0], "trajectory", "TCP 0 path")
    return viz.render_scene(
        scene,
        exp.out / "fig18_scene.png",
        view=(34.0, -62.0),
        size=(7.5, 6.5),
        title=(
            f"Fig. 18: TCP 0 driven onto the line through TCPs 1, 2\n"
            f"stopped at w = {W[-1]:.3g} (raise at {task.raise_below:g}), r = {R['radius'][-1]:.3g} m"
        ),
    )


def _draw_circle_parameters(exp: Experiment, plt: Any, R: dict, A: dict) -> Any:
    """Fig. 19a: the circle's coefficients, radius, centre and normal over time."""
    t, W = A["t"], R["w"]
    fig, axs = plt.subplots(2, 2, figsize=(12, 7.5), sharex=True)
    ax = axs[0, 0]
    for j, n in enumerate(A["names"]):
        ax.plot(t, R["xc"][:, j], lw=1.4, label="$e_{" + n[1:].replace("∞", r"\infty") + "}$")
    ax.set_title(r"coefficients of $X_c = P_1\wedge P_2\wedge P_3$ (Eq 14)")
    ax.set_ylabel("coefficient")
    ax.legend(ncol=5, fontsize=7)
    ax.grid(True, alpha=0.3)
    ax = axs[0, 1]
    ax.semilogy(t, R["radius"], color="C0", lw=1.6, label="radius $r$ [m]")
    ax.semilogy(t, R["distance"], color="C3", lw=1.6, label="distance of TCP 0 to the line [m]")
    ax.semilogy(t, W, color="0.3", lw=1.2, ls="--", label="well-definedness $w$")
    ax.set_title(f"radius {R['radius'][0]:.3g} → {R['radius'][-1]:.3g} m (∝ $w^{{{A['radius_slope']:.2f}}}$)")
    ax.set_ylabel("[m] | w [1]")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3, which="both")
    ax = axs[1, 0]
    for j, lab in enumerate("xyz"):
        ax.plot(t, R["center"][:, j], lw=1.6, label=f"$c_{lab}$")
    ax.set_yscale("symlog", linthresh=1.0)
    ax.set_title("centre (symlog)")
    ax.set_ylabel("centre [m]")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("t [s]")
    ax = axs[1, 1]
    for j, lab in enumerate("xyz"):
        ax.plot(t, R["normal"][:, j], lw=1.6, label=f"$n_{lab}$")
    ax.set_title("unit normal")
    ax.set_ylabel("normal [1]")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("t [s]")
    fig.suptitle("Fig. 19a: the cooperative circle while TCP 0 reaches the line (circle tracked, not controlled)")
    fig.tight_layout()
    png19a = exp.save(fig, "fig19_circle_parameters.png")
    plt.close(fig)
    return png19a


def _draw_bivector(exp: Experiment, plt: Any, R: dict, A: dict) -> Any:
    """Fig. 19b: the bivector ``log V_Sc`` over time."""
    from coop_ga import viz

    tnorm, B0, Bf = A["tnorm"], A["B0"], A["Bf"]
    fig, ax = plt.subplots(figsize=(10, 4.5))
    viz.plot_bivector(ax, A["t"], R["log"])
    ax.set_yscale("symlog", linthresh=0.1)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(viz.bivector_ylabel(r"$\log V_{Sc}$") + ", symlog")
    ax.set_title(
        r"Fig. 19b: $B_{Sc} = \log V_{Sc}(q_t)$ "
        f"(translation ‖t‖ {tnorm[0]:.2f} → {tnorm[-1]:.3g}, β = ln r {B0[3]:.2f} → {Bf[3]:.2f})"
    )
    fig.tight_layout()
    png19b = exp.save(fig, "fig19_bivector.png")
    plt.close(fig)
    return png19b


def _draw_manipulability(exp: Experiment, plt: Any, task: Any, R: dict, A: dict) -> Any:
    """Fig. 19c: the manipulability eigenvalues and the well-definedness over time."""
    t, W, E, T, k_res, eig_slopes = A["t"], R["w"], R["eig"], A["T"], A["k_res"], A["eig_slopes"]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 7.5), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    for i in range(7):
        lab = rf"$\lambda_1$ ≡ 0 (structural: rank 6; drawn at {EIG_FLOOR:g})" if i == 0 else rf"$\lambda_{i + 1}$"
        if i > 0 and np.isfinite(eig_slopes[i - 1]):
            lab += rf" ($\propto w^{{{eig_slopes[i - 1]:.2f}}}$)"
        ax1.semilogy(t, np.maximum(E[:, i], EIG_FLOOR), lw=1.5 if i else 1.0, ls="-" if i else ":", label=lab)
    if k_res < T - 1:
        ax1.axvspan(t[k_res], t[-1], color="0.85", zorder=0, label="small eigenvalues not resolved (routes disagree)")
    ax1.set_ylabel(r"eigenvalues of $\mathcal{J}^G \mathcal{J}^{G\top}$")
    ax1.set_title(r"Fig. 19c: task-space manipulability $M_S = \mathcal{J}^G\mathcal{J}^{G\top}$ (Eq 59), 21 joints")
    ax1.legend(fontsize=7, ncol=2, loc="lower left", bbox_to_anchor=(0.0, 0.06))
    ax1.grid(True, alpha=0.3, which="both")
    ax2.semilogy(t, W, color="k", lw=1.6, label="well-definedness $w$")
    ax2.axhline(task.warn_below, color="orange", ls="--", label=f"warn_below = {task.warn_below:g}")
    ax2.axhline(task.raise_below, color="red", ls="--", label=f"raise_below = {task.raise_below:g} (stop)")
    for a in (ax1, ax2):
        a.axvline(t[-1], color="red", lw=0.8, ls=":")
    ax2.set_ylabel("w")
    ax2.set_xlabel("t [s]")
    ax2.legend(fontsize=8)
    ax2.grid(True, alpha=0.3, which="both")
    fig.tight_layout()
    png19c = exp.save(fig, "fig19_manipulability.png")
    plt.close(fig)
    return png19c


def _evidence(task: Any, R: dict, A: dict) -> tuple[str, bool]:
    """``(evidence, agrees)``: the numbers that back or contradict the paper's claim."""
    W, tnorm, e0, ef, er, k_res = R["w"], A["tnorm"], A["e0"], A["ef"], A["er"], A["k_res"]
    fallen, grown, eig_slopes = A["fallen"], A["grown"], A["eig_slopes"]
    agrees = bool(
        R["radius"][-1] > 100 * R["radius"][0]
        and fallen >= 2
        and tnorm[-1] > 100 * tnorm[0]
        and len(A["xc_fallen"]) >= 2
        and A["limit_violation"] == 0.0
    )
    evidence = (
        f"TCP 0 reached {R['distance'][-1]:.2g} m from the line; w fell {W[0]:.3g} → {W[-1]:.3g} and the run stopped "
        f"one step before the guard's raise threshold {task.raise_below:g}. Agrees: the radius grew "
        f"{R['radius'][0]:.3g} → {R['radius'][-1]:.3g} m (∝ w^{A['radius_slope']:.2f}, toward infinity), the "
        f"coefficients {', '.join(A['xc_fallen'])} of X_c fell > 100× toward 0, the bivector's translation diverged "
        f"(‖t‖ {tnorm[0]:.2f} → {tnorm[-1]:.3g}) and {fallen} of the 6 non-structural manipulability eigenvalues fell "
        f"> 10× (λ₂ {e0[1]:.3g} → {er[1]:.3g} at w = {W[k_res]:.2g}, ∝ w^{eig_slopes[0]:.2f}; below that w the small "
        f"eigenvalues are rounding noise, {ef[1]:.2g} at the stop, as the two Jacobian routes disagree). Beyond the "
        f"paper: {grown} eigenvalues grew > 10× (to {ef[-1]:.3g}, ∝ w^{eig_slopes[-1]:.2f}) and {6 - fallen - grown} changed < 10×."
    )
    return evidence, agrees


def _metrics_setup(args: Any, s: Any, task: Any, run: dict, R: dict, A: dict) -> dict[str, Any]:
    """The first half of metrics.json: the setup, the stop, the warnings and the circle's read-outs."""
    W = R["w"]
    stopped_reason = run["stopped_reason"]
    return {
        "system": "three_franka",
        "kind": "circle",
        "nq": s.nq,
        "seed": args.seed,
        "fast": bool(args.fast),
        "dt_s": args.dt,
        "gain_per_s": args.gain,
        "max_speed_m_s": args.max_speed,
        "damping": args.damping,
        "duration_limit_s": args.duration,
        "driven_end_point": 0,
        "fixed_end_points_m": [run["a_pt"], run["b_pt"]],
        "target_point_m": run["target"],
        "target_fraction": args.target_fraction,
        "start_preparation_steps": run["prep_steps"],
        "warn_below": task.warn_below,
        "raise_below": task.raise_below,
        "steps": A["T"] - 1,
        "duration_s": float(A["t"][-1]),
        "stopped_reason": stopped_reason,
        "stopped_at_threshold": stopped_reason.startswith("raise threshold"),
        "well_definedness_initial": W[0],
        "well_definedness_final": W[-1],
        "well_definedness_next_refused": run["w_next"],
        "steps_below_warn": A["below_warn"],
        "time_first_below_warn_s": A["t_warn"],
        "warnings": run["warnings"],
        "warnings_note": "counts of guarded calls (task.evaluate and task.jacobian_closed_form: 2 per step)",
        "distance_to_line_initial_m": R["distance"][0],
        "distance_to_line_final_m": R["distance"][-1],
        "radius_initial": R["radius"][0],
        "radius_final": R["radius"][-1],
        "radius_growth": R["radius"][-1] / R["radius"][0],
        "radius_slope_vs_w": A["radius_slope"],
        "center_initial_m": R["center"][0],
        "center_final_m": R["center"][-1],
        "normal_initial": R["normal"][0],
        "normal_final": R["normal"][-1],
        "readout_radius_max_rel_error": float(np.max(A["r_rel"])),
        "readout_center_max_error_per_radius": float(np.max(A["c_rel"])),
        "circle_coefficient_blades": A["names"],
        "circle_coefficients_initial": A["xc0"],
        "circle_coefficients_final": A["xcf"],
        "circle_coefficients_fallen_100x": A["xc_fallen"],
    }


def _metrics_results(R: dict, A: dict, qp_steps: int) -> dict[str, Any]:
    """The second half of metrics.json: the bivector, the eigenvalues, their resolution and the limits."""
    W, E, Ecf, fit, k_res = R["w"], R["eig"], R["eig_cf"], A["fit"], A["k_res"]
    e0, ef, er, B0, Bf, tnorm = A["e0"], A["ef"], A["er"], A["B0"], A["Bf"], A["tnorm"]
    return {
        "bivector_basis": ["e12", "e13", "e23", "e0inf", "e1inf", "e2inf", "e3inf"],
        "bivector_initial": B0,
        "bivector_final": Bf,
        "bivector_max_abs": np.max(np.abs(R["log"]), axis=0),
        "translation_norm_initial": tnorm[0],
        "translation_norm_final": tnorm[-1],
        "translation_slope_vs_w": A["translation_slope"],
        "dilation_initial": B0[3],
        "dilation_final": Bf[3],
        "eigenvalues_initial": e0,
        "eigenvalues_final": ef,
        "eigenvalues_closed_form_final": Ecf[-1],
        "structural_zero_eigenvalue_max_relative": float(np.max(E[:, 0] / E[:, -1])),
        "min_eigenvalue_initial": e0[1],
        "min_eigenvalue_final": ef[1],
        "min_eigenvalue_ratio": float(ef[1] / e0[1]),
        "min_eigenvalue_note": "λ₂, the smallest of the 6 eigenvalues that are not structurally zero (rank J^G = 6)",
        "eigenvalues_fallen_10x": A["fallen"],
        "eigenvalues_grown_10x": A["grown"],
        "eigenvalue_slopes_vs_w": A["eig_slopes"],
        "eigenvalue_fit_range_w": [float(W[fit].min()), float(W[fit].max())] if fit.size else None,
        "condition_number_initial": e0[-1] / e0[1],
        "condition_number_final": ef[-1] / ef[1],
        "resolved_rtol": RESOLVED_RTOL,
        "resolved_last_step": k_res,
        "resolved_down_to_well_definedness": W[k_res],
        "eigenvalues_last_resolved": er,
        "min_eigenvalue_last_resolved": er[1],
        "min_eigenvalue_ratio_last_resolved": float(er[1] / e0[1]),
        "eigenvalues_fallen_10x_last_resolved": A["fallen_res"],
        "routes_max_rel_difference_final": float(A["rel"][-1]),
        "max_limit_violation": A["limit_violation"],
        "max_velocity_excess_rad_s": A["vel_excess"],
        "fixed_arms_max_joint_motion_rad": A["others_moved"],
        "qp_active_steps": qp_steps,
        "circles_drawn_radius_max_m": DRAW_RADIUS_MAX,
        "circles_below_draw_radius": A["n_circles_drawn"],
    }


def _run(exp: Experiment, s: Any, task: Any, cols: dict, closed_form: bool) -> tuple[dict[str, Any], dict, Any, Any]:
    """Place TCPs 1, 2 on the line, then drive TCP 0 onto it: ``(run, rec, prep stage, run stage)``."""
    from coop_ga.diagnostics import collect_warnings

    args = exp.args
    fixed = {
        1: np.array([args.half_width, args.line_y, args.line_z]),
        2: np.array([-args.half_width, args.line_y, args.line_z]),
    }
    with exp.stage("start configuration (arms 1, 2 place their TCPs)") as st_prep:
        q_s, prep_steps = prepare_start(task, np.array(s.q0, dtype=float), fixed, cols)
    P_s = task.tree.end_points_array(q_s)
    a_pt, b_pt = P_s[1], P_s[2]
    target = a_pt + args.target_fraction * (b_pt - a_pt)
    rec, record = _recorder(task, closed_form)
    with exp.stage("driving TCP 0 onto the line (circle tracked)") as st_run, collect_warnings(emit=False) as cw:
        stopped_reason, w_next, qp_steps = drive(task, q_s, target, cols[0], args, record, rec)
    run = {
        "q_s": q_s,
        "prep_steps": prep_steps,
        "P_s": P_s,
        "a_pt": a_pt,
        "b_pt": b_pt,
        "target": target,
        "stopped_reason": stopped_reason,
        "w_next": w_next,
        "qp_steps": qp_steps,
        "warnings": dict(cw.counts),
    }
    return run, rec, st_prep, st_run


def _print_summary(exp: Experiment, run: dict, R: dict, A: dict, pngs: list[Any]) -> None:
    """A few lines on stdout."""
    args = exp.args
    dt, W, tnorm, e0, ef = args.dt, R["w"], A["tnorm"], A["e0"], A["ef"]
    print(f"three_franka circle singularity ({'fast, ' if args.fast else ''}Δt = {dt:g} s, {A['T'] - 1} steps)")
    print(f"  stopped: {run['stopped_reason']}")
    print(f"  w {W[0]:.3g} → {W[-1]:.3g}, distance to line {R['distance'][0]:.3g} → {R['distance'][-1]:.3g} m")
    print(f"  radius {R['radius'][0]:.3g} → {R['radius'][-1]:.3g} m, ‖t‖ {tnorm[0]:.3g} → {tnorm[-1]:.3g}")
    print(f"  eigenvalues initial {np.array2string(e0, precision=3)}")
    print(f"  eigenvalues final   {np.array2string(ef, precision=3)}")
    print(f"  resolved down to w = {W[A['k_res']]:.3g}; slopes vs w {np.round(A['eig_slopes'], 2).tolist()}")
    print(f"  warnings {run['warnings']}; joint-limit violation {A['limit_violation']:g}")
    print(f"  wrote {exp.out}/metrics.json, trajectory.npz, {', '.join(p.name for p in pngs)}")


def _write_trajectory(exp: Experiment, R: dict, A: dict) -> None:
    """``trajectory.npz``: the run and everything recorded along it."""
    exp.write_npz(
        "trajectory.npz",
        t=A["t"],
        q=R["q"],
        end_points=R["points"],
        well_definedness=R["w"],
        center=R["center"],
        radius=R["radius"],
        normal=R["normal"],
        circle_coefficients=R["xc"],
        bivector=R["log"],
        eigenvalues=R["eig"],
        eigenvalues_closed_form=R["eig_cf"],
        distance_to_line=R["distance"],
    )


def _gallery(task: Any, R: dict, A: dict, figures: list[str]) -> dict[str, Any]:
    """The gallery block: the paper's claim and the numbers that back or contradict it."""
    evidence, agrees = _evidence(task, R, A)
    return {
        "title": "Figs. 18–19: geometric singularity of the cooperative circle (three_franka)",
        "claim": (
            "As the three end points of the cooperative circle approach collinearity, the circle degenerates "
            "(radius → ∞), several bivector components diverge and several task-space manipulability "
            "eigenvalues drop to zero."
        ),
        "evidence": evidence,
        "agrees": agrees,
        "figures": figures,
    }


def main(argv: list[str] | None = None) -> int:
    exp = _parse(argv)
    args = exp.args
    plt = exp.pyplot()

    import coop_ga as cg
    from coop_ga import viz
    from coop_ga.cooperative import cooperative_primitive

    t_start = time.perf_counter()
    with exp.stage("loading three_franka and its cooperative circle"):
        s = cg.systems.load("three_franka")
        task = cg.cooperative_task(s, "circle")
        task.evaluate(s.q0)
    cols = {i: arm_columns(s, f) for i, f in enumerate(task.end_frames)}
    closed_form = task.chart_axis is None  # the closed forms of Appendix B are for the canonical chart
    run, rec, st_prep, st_run = _run(exp, s, task, cols, closed_form)
    R = {k: np.asarray(v) for k, v in rec.items()}
    A = _analyse(task, R, closed_form, args.dt, cols, run["q_s"], run["P_s"])

    with exp.stage("plotting"):
        Xs = [cooperative_primitive("circle", [cg.point(p) for p in R["points"][k]]) for k in range(A["T"])]
        png18 = _draw_scene(exp, s, task, run["q_s"], R, A, Xs, (run["a_pt"], run["b_pt"]))
        png19a = _draw_circle_parameters(exp, plt, R, A)
        png19b = _draw_bivector(exp, plt, R, A)
        png19c = _draw_manipulability(exp, plt, task, R, A)

    with exp.stage(f"animating fig18_animation.gif ({args.frames} frames)"):
        # the circle only while it is drawable (r ≤ DRAW_RADIUS_MAX): a huge circle would frame nothing else
        circles = [X if r <= DRAW_RADIUS_MAX else None for X, r in zip(Xs, R["radius"])]
        gif = viz.animate(
            s,
            R["q"],
            circles,
            exp.out / "fig18_animation.gif",
            t=A["t"],
            frames=args.frames,
            fps=10.0,
            view=(34.0, -62.0),
            size=(4.8, 3.6),
            dpi=80,
            title="Fig. 18: TCP 0 driven onto the line",
        )

    _write_trajectory(exp, R, A)
    pngs = [png18, png19c, png19a, png19b]
    metrics = {
        "gallery": _gallery(task, R, A, [p.name for p in pngs] + [gif.name]),
        **_metrics_setup(args, s, task, run, R, A),
        **_metrics_results(R, A, run["qp_steps"]),
    }
    exp.write_json("metrics.json", metrics)
    exp.write_timing(
        {
            "start_preparation_s": st_prep.seconds,
            "run_s": st_run.seconds,
            "total_s": time.perf_counter() - t_start,
        }
    )
    _print_summary(exp, run, R, A, [png18, png19a, png19b, png19c])
    return 0


if __name__ == "__main__":
    sys.exit(main())
