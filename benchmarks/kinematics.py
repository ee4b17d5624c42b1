"""Per-call time of motor forward kinematics + end-frame Jacobians against Pinocchio, in one run.

    python benchmarks/kinematics.py [--only NAME ...] [--out results/benchmarks/kinematics] [--quiet]

For every registered system, at its q0, the same outputs (the world motor/placement of
every end frame and its body-frame geometric Jacobian) by:

* ``compiled``: ``CompiledFunction(ca.Function(q → [motors (8×k), Jacobians (7k×nq)]),
  codegen=True).call_views(q)`` — the motor code traced once into CasADi SX, generated
  C (gcc, cached), called through bound numpy buffers (copy q in, NaN check, ~0.1 µs
  dispatch);
* ``C only``: the bound compiled function alone (``eval()``, no Python-side checks);
* ``numpy``: the multivector path itself, ``tree.frame_motors(q)`` +
  ``tree.geometric_jacobians(q)`` (plain Python floats; for reference);
* ``pin (a)``: ``computeJointJacobians`` + ``updateFramePlacements`` + one
  ``getFrameJacobian(LOCAL)`` per end frame — the cheapest correct Pinocchio sequence
  for several frames (one pass over the tree);
* ``pin (b)``: ``forwardKinematics`` + ``updateFramePlacements`` + one
  ``computeFrameJacobian(LOCAL)`` per end frame (each call re-walks its chain);

and the ratio compiled / min(pin (a), pin (b)).  Every route is checked against
Pinocchio before timing.  First run compiles each system (~1–5 s each, then cached).  The
table is also written to ``<out>/results.json`` (times in µs).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import per_call_us, print_table

import coop_ga as cg
from coop_ga.codegen import CompiledFunction
from coop_ga.geometry.groups import MOTOR_BLADES
from coop_ga.harness import Experiment
from coop_ga.kinematics import LOCAL_TO_TANGENT


def kinematics_function(system) -> ca.Function:
    """q → (motor coefficients 8×k in MOTOR_BLADES order, stacked geometric Jacobians 7k×nq)."""
    q = ca.SX.sym("q", system.nq)
    motors = system.tree.frame_motors(q)
    M = ca.horzcat(*[ca.vertcat(*Mi.with_blades(MOTOR_BLADES).coeffs) for Mi in motors])
    J = ca.vertcat(*system.tree.geometric_jacobians(q))
    return ca.Function(f"kin_{system.name}", [q], [ca.densify(M), ca.densify(J)], ["q"], ["motors", "jacobians"])


def _check_routes(name: str, s, cf, q: np.ndarray, m, d, fids: list[int], pin) -> None:
    """The compiled function, Pinocchio and the numpy tree give the same motors and Jacobians at ``q``."""
    Mc, Jc = (np.array(a) for a in cf.call_views(q))
    pin.computeJointJacobians(m, d, q)
    pin.updateFramePlacements(m, d)
    J_ref = np.vstack([LOCAL_TO_TANGENT @ pin.getFrameJacobian(m, d, fid, pin.LOCAL) for fid in fids])
    assert np.abs(Jc - J_ref).max() < 1e-10, name
    assert np.abs(np.vstack(s.tree.geometric_jacobians(q)) - Jc).max() < 1e-12, name
    Mn = np.array([Mi.with_blades(MOTOR_BLADES).coeffs for Mi in s.tree.frame_motors(q)], float).T
    assert np.abs(Mn - Mc).max() < 1e-12, name


def _pinocchio_routes(m, d, q: np.ndarray, fids: list[int], pin) -> tuple[float, float]:
    """Per-call times [µs] of Pinocchio's two routes to the end-frame Jacobians: (a) and (b) of the table."""

    def pin_a() -> None:
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        for fid in fids:
            pin.getFrameJacobian(m, d, fid, pin.LOCAL)

    def pin_b() -> None:
        pin.forwardKinematics(m, d, q)
        pin.updateFramePlacements(m, d)
        for fid in fids:
            pin.computeFrameJacobian(m, d, q, fid, pin.LOCAL)

    return per_call_us(pin_a), per_call_us(pin_b)


def _bench_system(name: str, pin) -> tuple[list[str], dict]:
    """One system's table row and JSON record: build, check every route, time them."""
    s = cg.systems.load(name)
    m, d = s.model, s.model.createData()
    fids = [m.getFrameId(f) for f in s.end_frames]
    q = s.q0.copy()
    t0 = time.perf_counter()
    f = kinematics_function(s)
    cf = CompiledFunction(f, codegen=True)
    t_build = time.perf_counter() - t0
    _check_routes(name, s, cf, q, m, d, fids, pin)
    t_comp = per_call_us(lambda: cf.call_views(q))
    t_c = per_call_us(cf.eval)
    t_np = per_call_us(lambda: (s.tree.frame_motors(q), s.tree.geometric_jacobians(q)), min_time=0.1, repeat=3)
    t_a, t_b = _pinocchio_routes(m, d, q, fids, pin)
    row = [
        name,
        str(s.nq),
        str(len(fids)),
        str(f.n_instructions()),
        f"{t_comp:.2f}",
        f"{t_c:.2f}",
        f"{t_np:.0f}",
        f"{t_a:.2f}",
        f"{t_b:.2f}",
        f"{t_comp / min(t_a, t_b):.2f}",
    ]
    record = {
        "system": name,
        "nq": s.nq,
        "frames": len(fids),
        "sx_instructions": f.n_instructions(),
        "compiled_us": t_comp,
        "c_only_us": t_c,
        "numpy_us": t_np,
        "pin_a_us": t_a,
        "pin_b_us": t_b,
        "ratio": t_comp / min(t_a, t_b),
        "build_or_load_s": t_build,
    }
    return row, record


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/kinematics"))
    exp.add("--only", nargs="*", metavar="NAME", choices=cg.systems.names(), help="benchmark only these systems")
    args = exp.parse(argv)
    import pinocchio as pin

    rows, records = [], []
    for name in exp.progress(args.only or cg.systems.names(), "timing"):
        row, record = _bench_system(name, pin)
        rows.append(row)
        records.append(record)
    print_table(
        "motor FK + end-frame geometric Jacobians per call [µs] (q0 of each system; same run)",
        ["system", "nq", "frames", "SX instr", "compiled", "C only", "numpy", "pin (a)", "pin (b)", "compiled/pin"],
        rows,
    )
    print(
        "pin (a): computeJointJacobians + updateFramePlacements + getFrameJacobian per frame;"
        " pin (b): forwardKinematics + updateFramePlacements + computeFrameJacobian per frame"
    )
    exp.write_json("results.json", {"rows": records})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
