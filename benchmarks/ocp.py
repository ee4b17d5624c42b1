"""The reaching OCP of Eq 53–57 solved by coop_ga's iLQR and by CasADi Opti + IPOPT, in one run.

Problem (the flagship of ``experiments/circle_reaching.py``): ``three_franka``, cooperative
circle, from rest at q0 to the initial circle moved by 25° about +x, scaled by 1.25 and
displaced by (0.10, −0.05, 0.10) m; 250 knots × Δt = 0.01 s; double integrator x = [q; q̇],
u = q̈ (exact ZOH); cost ``Σ uᵀRu + ‖log(Ṽ_Sc(q_n) V_Sd)‖²_Q + q̇_nᵀQ_v q̇_n`` with
R = 1e-3 I, Q = 1e5 I, Q_v = 1e2 I.

Solvers:

* ``iLQR (riccati)`` / ``iLQR (condensed)``: :func:`coop_ga.control.ilqr_reach` with the
  Riccati backward pass (default) or its closed-form equivalent; Newton-type terminal
  model (Lagrangian Hessian), tol ‖e‖ < 1e-5;
* ``iLQR (Gauss–Newton)``: the same with the Gauss–Newton terminal Hessian only;
* ``IPOPT (multiple shooting)``: CasADi ``Opti`` with decision variables q, q̇ at every knot
  and u, the dynamics as equality constraints, the same cost; the terminal error is
  built symbolically from ``task.symbolic(q)['versor']`` and coop_ga's ``log`` on CasADi
  SX (exact Hessian of the Lagrangian by CasADi AD, ``print_level 0``).  Same initial
  guess as iLQR (u = 0, the system at rest at q0).

Times: iLQR is timed best-of-``--repeat`` after a warm-up (the compiled task is cached);
IPOPT's time is its own ``t_wall_total`` of the solve (graph construction reported
separately).  The ratio column is solve time / iLQR (riccati) solve time.

Run: ``python benchmarks/ocp.py`` (add ``--repeat N``).  The table is also written to
``<out>/results.json`` (times in s).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import print_table  # noqa: E402

import coop_ga as cg  # noqa: E402
from coop_ga.control.ilqr import (  # noqa: E402
    DEFAULT_Q,
    DEFAULT_QV,
    DEFAULT_R,
    ReachingOCP,
    displaced_target,
    ilqr_reach,
)
from coop_ga.cooperative import versor_coeffs, versor_from_coeffs  # noqa: E402
from coop_ga.harness import Experiment, positive_float, positive_int  # noqa: E402

TARGET = dict(translation=(0.10, -0.05, 0.10), axis=(1.0, 0.0, 0.0), angle=np.deg2rad(25.0), scale=1.25)


def ipopt_solve(task, q0: np.ndarray, Vd, horizon: int, dt: float, R: float, Q: float, Qv: float,
                max_iter: int = 1000) -> dict:
    """Multiple-shooting transcription in CasADi Opti, solved by IPOPT (exact Hessian)."""
    import casadi as ca

    from coop_ga.geometry.groups import SIMILARITY_BLADES, log as sim_log

    t_build = time.perf_counter()
    n = task.nq
    qs = ca.SX.sym("q", n)
    vd = ca.SX.sym("Vd", 12)
    Vc = versor_from_coeffs(task.symbolic(qs)["versor"])
    W = (Vc.reverse() * versor_from_coeffs(vd)).with_blades(SIMILARITY_BLADES)
    f_err = ca.Function("terminal_error", [qs, vd], [sim_log(W)])

    opti = ca.Opti()
    X = opti.variable(2 * n, horizon + 1)
    U = opti.variable(n, horizon)
    h = 0.5 * dt * dt
    opti.subject_to(X[:, 0] == np.concatenate([q0, np.zeros(n)]))
    # x_{k+1} = A x_k + B u_k (exact ZOH of q̈ = u), all knots at once
    opti.subject_to(X[:n, 1:] == X[:n, :-1] + dt * X[n:, :-1] + h * U)
    opti.subject_to(X[n:, 1:] == X[n:, :-1] + dt * U)
    e = f_err(X[:n, horizon], versor_coeffs(Vd))
    J = R * ca.sumsqr(U) + Q * ca.sumsqr(e) + Qv * ca.sumsqr(X[n:, horizon])
    opti.minimize(J)
    opti.set_initial(X, np.tile(np.concatenate([q0, np.zeros(n)])[:, None], (1, horizon + 1)))
    opti.set_initial(U, 0.0)
    opti.solver("ipopt", {"print_time": False, "ipopt.sb": "yes"},
                {"print_level": 0, "max_iter": max_iter, "tol": 1e-10})
    t_build = time.perf_counter() - t_build
    t0 = time.perf_counter()
    try:
        sol = opti.solve()
        ok = True
    except RuntimeError:  # IPOPT did not converge: report what it has
        sol = opti.debug
        ok = False
    wall = time.perf_counter() - t0
    stats = opti.stats()
    Uv = np.array(sol.value(U)).reshape(n, horizon).T
    Xv = np.array(sol.value(X)).reshape(2 * n, horizon + 1)
    return {"u": Uv, "q_n": Xv[:n, -1], "qd_n": Xv[n:, -1], "iterations": int(stats.get("iter_count", -1)),
            "solve_time_s": float(stats.get("t_wall_total", wall)), "wall_s": wall, "build_s": t_build,
            "success": ok and bool(stats.get("success", False)), "status": stats.get("return_status", "?")}


def _best(fn, repeat: int):
    best = None
    for _ in range(repeat):
        r = fn()
        if best is None or r.solve_time_s < best.solve_time_s:
            best = r
    return best


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/ocp"))
    exp.add("--repeat", type=positive_int, default=5, help="iLQR repetitions (best time reported)")
    exp.add("--horizon", type=positive_int, default=250, help="knots")
    exp.add("--dt", type=positive_float, default=0.01, help="time step [s]")
    exp.add("--no-ipopt", action="store_true", help="skip the IPOPT solve")
    args = exp.parse(argv)

    s = cg.systems.load("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0)
    Vd, _ = displaced_target(task, q0, **TARGET)
    ocp = ReachingOCP(task, q0, Vd, horizon=args.horizon, dt=args.dt)
    print(f"three_franka circle reaching: nq = {task.nq}, {args.horizon} knots × {args.dt:g} s, "
          f"initial ‖e‖ = {np.linalg.norm(task.error(q0, Vd)):.3f}", flush=True)

    rows, records = [], []
    ref = None
    variants = (("iLQR (riccati)", {}), ("iLQR (condensed)", {"backward": "condensed"}),
                ("iLQR (Gauss–Newton, riccati)", {"hessian": "gauss_newton"}))
    for label, kw in exp.progress(variants, "iLQR variants"):
        ilqr_reach(task, q0, Vd, horizon=args.horizon, dt=args.dt, **kw)  # warm-up (compile, build)
        r = _best(lambda: ilqr_reach(task, q0, Vd, horizon=args.horizon, dt=args.dt, **kw), args.repeat)
        if ref is None:
            ref = r.solve_time_s
        rows.append([label, str(r.iterations), f"{r.solve_time_s * 1e3:.1f}", f"{r.terminal_error:.2e}",
                     f"{ocp.cost(r.u):.6f}", "yes" if r.converged else "no", f"{r.solve_time_s / ref:.2f}"])
        records.append({"solver": label, "iterations": r.iterations, "solve_time_s": r.solve_time_s,
                        "terminal_error": r.terminal_error, "cost": ocp.cost(r.u), "converged": r.converged})

    if not args.no_ipopt:
        import casadi as ca

        if not ca.has_nlpsol("ipopt"):
            rows.append(["IPOPT (multiple shooting)", "-", "-", "-", "-", "IPOPT not available in this casadi", "-"])
        else:
            with exp.stage("IPOPT (multiple shooting)"):
                ip = ipopt_solve(task, q0, Vd, args.horizon, args.dt, DEFAULT_R, DEFAULT_Q, DEFAULT_QV)
            err = float(np.linalg.norm(task.error(ip["q_n"], Vd)))
            rows.append(["IPOPT (multiple shooting)", str(ip["iterations"]), f"{ip['solve_time_s'] * 1e3:.1f}",
                         f"{err:.2e}", f"{ocp.cost(ip['u']):.6f}",
                         f"{'yes' if ip['success'] else 'no'} ({ip['status']})", f"{ip['solve_time_s'] / ref:.2f}"])
            records.append({"solver": "IPOPT (multiple shooting)", "iterations": ip["iterations"],
                            "solve_time_s": ip["solve_time_s"], "terminal_error": err, "cost": ocp.cost(ip["u"]),
                            "converged": ip["success"], "status": ip["status"], "build_s": ip["build_s"],
                            "wall_s": ip["wall_s"]})
            print(f"  IPOPT: graph/Opti construction {ip['build_s']:.2f} s (not in the solve time), "
                  f"wall time of opti.solve() {ip['wall_s']:.2f} s", flush=True)
    print_table("reaching OCP (Eq 53–57), three_franka circle: iLQR vs IPOPT",
                ["solver", "iterations", "solve [ms]", "terminal ‖e‖", "cost J", "converged", "time / iLQR"], rows)
    exp.write_json("results.json", {"horizon": args.horizon, "dt_s": args.dt, "repeat": args.repeat, "rows": records})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
