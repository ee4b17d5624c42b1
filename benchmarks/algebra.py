"""Per-call times of the core CGA operations: plain numpy path vs compiled CasADi functions.

    python benchmarks/algebra.py [--no-codegen] [--out results/benchmarks/algebra] [--seed 0] [--quiet]

Columns: the numpy path (Multivector objects, generated straight-line products), the
same source traced once into a CasADi SX function and evaluated through a
FunctionBuffer (CasADi's VM), and the same function compiled to C with gcc.  The
anchor is numpy's own ``a @ b`` for two 4×4 matrices (a homogeneous-transform
product), measured in the same run.  The table is also written to ``<out>/results.json``
(times in µs; a column that was not measured is ``null``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import per_call_us, print_table

import coop_ga as cg
from coop_ga.algebra import Multivector
from coop_ga.codegen import CompiledFunction
from coop_ga.geometry.groups import SIMILARITY_BLADES
from coop_ga.harness import Experiment


def sim_from(x) -> Multivector:
    return Multivector(SIMILARITY_BLADES, tuple(x[i] for i in range(12)))


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/algebra"))
    exp.add("--no-codegen", action="store_true", help="skip the gcc-compiled column")
    args = exp.parse(argv)

    rng = exp.rng
    b1, b2 = rng.normal(size=7), rng.normal(size=7)
    V1, V2 = cg.geometry.exp(b1), cg.geometry.exp(b2)
    pts1, pts2 = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    C1, C2 = cg.circle(*pts1), cg.circle(*pts2)
    v1 = np.array(V1.coeffs)
    v2 = np.array(V2.coeffs)

    # symbolic versions of the same operations
    s1, s2 = ca.SX.sym("v1", 12), ca.SX.sym("v2", 12)
    sb = ca.SX.sym("b", 7)
    sp1, sp2 = ca.SX.sym("p1", 9), ca.SX.sym("p2", 9)
    circ = lambda p: cg.circle(p[0:3], p[3:6], p[6:9])  # noqa: E731
    sym = {
        "geometric product (similarity × similarity)": (
            ca.Function("gp", [s1, s2], [ca.vertcat(*(sim_from(s1) * sim_from(s2)).coeffs)]),
            (v1, v2),
            lambda: V1 * V2,
        ),
        "exp (7-vector → versor)": (
            ca.Function("expf", [sb], [ca.vertcat(*cg.geometry.exp(sb).coeffs)]),
            (b1,),
            lambda: cg.geometry.exp(b1),
        ),
        "log (versor → 7-vector)": (
            ca.Function("logf", [s1], [cg.geometry.log(sim_from(s1))]),
            (v1,),
            lambda: cg.geometry.log(V1),
        ),
        "similarity (circle → circle, from points)": (
            ca.Function("simf", [sp1, sp2], [ca.vertcat(*cg.geometry.similarity(circ(sp1), circ(sp2)).coeffs)]),
            (pts1.ravel(), pts2.ravel()),
            lambda: cg.geometry.similarity(cg.circle(*pts1), cg.circle(*pts2)),
        ),
        "apply (V X Ṽ, circle)": (
            ca.Function("applyf", [s1, sp1], [ca.vertcat(*cg.geometry.apply(sim_from(s1), circ(sp1)).coeffs)]),
            (v1, pts1.ravel()),
            lambda: cg.geometry.apply(V1, C1),
        ),
    }
    A, Bm = rng.normal(size=(4, 4)), rng.normal(size=(4, 4))
    anchor = per_call_us(lambda: A @ Bm)
    rows, records = [], []
    for name, (f, fargs, numpy_fn) in exp.progress(sym.items(), "timing", total=len(sym)):
        t_np = per_call_us(numpy_fn)
        vm = CompiledFunction(f, codegen=False)
        t_vm = per_call_us(lambda vm=vm, fargs=fargs: vm.call_views(*fargs))
        if not args.no_codegen:
            cc = CompiledFunction(f, codegen=True)
            t_c = per_call_us(lambda cc=cc, fargs=fargs: cc.call_views(*fargs))
            # compiled and numpy give the same numbers
            assert np.allclose(np.asarray(cc(*fargs)).ravel()[:3], np.asarray(vm(*fargs)).ravel()[:3])
        else:
            t_c = float("nan")
        rows.append(
            [name, f"{t_np:8.1f}", f"{t_vm:6.2f}", f"{t_c:6.2f}", f"{f.n_instructions():5d}", f"{t_c / anchor:6.1f}"]
        )
        records.append(
            {
                "operation": name,
                "numpy_us": t_np,
                "casadi_vm_us": t_vm,
                "compiled_c_us": t_c,
                "sx_instructions": f.n_instructions(),
                "compiled_over_anchor": t_c / anchor,
            }
        )
    print_table(
        f"coop_ga algebra, per call [µs]   (anchor: numpy 4×4 @ 4×4 = {anchor:.2f} µs, same run)",
        ["operation", "numpy path", "CasADi VM", "compiled C", "SX instr.", "C / anchor"],
        rows,
    )
    _ = C2
    exp.write_json("results.json", {"anchor_numpy_4x4_matmul_us": anchor, "rows": records})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
