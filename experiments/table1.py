#!/usr/bin/env python
"""Table 1: the controllable bivector space of each cooperative primitive, measured.

The paper's Table 1 lists, for each primitive, the basis blades of the similarity Lie
algebra ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` that its cooperative task controls.  This
script measures the range of the geometric Jacobian ``J^G`` (body frame, Eq 30) on a system
whose end points move freely (``coop_ga.systems.cartesian_points(4)``: ∂p/∂q = I, so
``J^G`` is the similarity part alone), and on robots, and compares:

* **rank**: rank of ``J^G`` (singular values > 1e-8 σ_max) at ``--samples`` random
  configurations (points within ±0.4 m of the bases), min and max;
* **exact at X_u**: with the end points on the unit primitive (V_Sc = 1), the rows of
  ``J^G`` outside the paper's blades are 0 (< 1e-12) and the listed rows have full rank;
* **off-span elsewhere**: at the random configurations, the spectral norm of the range
  projector of ``J^G`` restricted to the excluded rows (0: the paper's blade set spans the
  range; 1: some range direction lies entirely outside it), median and max;
* **rank on robots**: at 5 configurations of ``three_franka`` (point … plane) and
  ``allegro`` (sphere) around q0.

Writes ``table1.md`` (the generated Markdown table with its reading) and ``metrics.json``.

    python experiments/table1.py --out results/table1
"""

from __future__ import annotations

import sys

import numpy as np

from coop_ga.harness import Experiment, positive_int

#: the paper's "controllable bivector space" column of Table 1
PAPER_BLADES: dict[str, tuple[str, ...]] = {
    "point": ("e1∞", "e2∞", "e3∞"),
    "point_pair": ("e12", "e23", "e0∞", "e1∞", "e2∞", "e3∞"),
    "line": ("e12", "e23", "e1∞", "e3∞"),
    "circle": ("e13", "e23", "e0∞", "e1∞", "e2∞", "e3∞"),
    "plane": ("e13", "e23", "e3∞"),
    "sphere": ("e0∞", "e1∞", "e2∞", "e3∞"),
}
#: end points on the unit primitive X_u of each kind (§3.3) [m]
UNIT_POINTS: dict[str, list[tuple[float, float, float]]] = {
    "point": [(0, 0, 0)],
    "point_pair": [(0, -1, 0), (0, 1, 0)],
    "line": [(0, 0, 0), (0, 1, 0)],
    "circle": [(1, 0, 0), (0, 1, 0), (-1, 0, 0)],
    "plane": [(0, 0, 0), (1, 0, 0), (0, 1, 0)],
    "sphere": [(1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0)],
}
#: the robot each kind's rank is also measured on
ROBOT_OF_KIND = {k: "three_franka" for k in ("point", "point_pair", "line", "circle", "plane")} | {"sphere": "allegro"}
RANK_RTOL = 1e-8


def rank(J: np.ndarray) -> int:
    """Numerical rank: singular values above ``RANK_RTOL`` × the largest."""
    s = np.linalg.svd(J, compute_uv=False)
    return int(np.sum(s > RANK_RTOL * s[0])) if s[0] > 0 else 0


def off_span(J: np.ndarray, excluded: list[int]) -> float:
    """‖P_range(J)[excluded, :]‖₂: how far the range of J leaves the span of the allowed rows."""
    U, s, _ = np.linalg.svd(J, full_matrices=False)
    r = int(np.sum(s > RANK_RTOL * s[0]))
    Ur = U[:, :r]
    return float(np.linalg.norm(Ur[excluded], 2)) if excluded else 0.0


def measure(kind: str, samples: int, rng: np.random.Generator) -> dict:
    import coop_ga as cg
    from coop_ga.cooperative import CooperativeTask
    from coop_ga.systems import CARTESIAN_BASES, cartesian_points, load

    free = cartesian_points(4)
    task = CooperativeTask(free, kind, codegen=False)
    names = list(cg.TANGENT_BASIS)
    allowed = [names.index(n) for n in PAPER_BLADES[kind]]
    excluded = [i for i in range(7) if i not in allowed]
    # at the unit primitive
    q = np.zeros(free.nq)
    for i, p in enumerate(UNIT_POINTS[kind]):
        q[3 * i : 3 * i + 3] = np.array(p, float) - CARTESIAN_BASES[i]
    J = task.jacobian(q)
    unit_log = float(np.abs(task.log(q)).max())
    unit_excluded = float(np.abs(J[excluded]).max(initial=0.0))
    unit_allowed_rank = int(np.linalg.matrix_rank(J[allowed], tol=1e-9))
    # random configurations
    ranks, offs = [], []
    for _ in range(samples):
        qr = rng.uniform(-0.4, 0.4, free.nq)
        Jr = task.jacobian(qr)
        ranks.append(rank(Jr))
        offs.append(off_span(Jr, excluded))
    # a robot
    robot = load(ROBOT_OF_KIND[kind])
    rtask = CooperativeTask(robot, kind, codegen=False)
    robot_ranks = []
    for _ in range(5):
        qr = np.clip(robot.q0 + rng.uniform(-0.2, 0.2, robot.nq), robot.q_lower, robot.q_upper)
        robot_ranks.append(rank(rtask.jacobian(qr)))
    return {
        "paper_blades": list(PAPER_BLADES[kind]),
        "paper_dimension": len(allowed),
        "rank_min": min(ranks),
        "rank_max": max(ranks),
        "unit_log_max": unit_log,
        "unit_excluded_rows_max": unit_excluded,
        "unit_allowed_rank": unit_allowed_rank,
        "exact_at_unit": bool(unit_log < 1e-12 and unit_excluded < 1e-12 and unit_allowed_rank == len(allowed)),
        "off_span_median": float(np.median(offs)),
        "off_span_max": float(np.max(offs)),
        "exact_elsewhere": bool(np.max(offs) < 1e-9),
        "robot": robot.name,
        "robot_rank_min": min(robot_ranks),
        "robot_rank_max": max(robot_ranks),
    }


def markdown(rows: dict[str, dict], samples: int) -> str:
    def yn(b: bool) -> str:
        return "yes" if b else "**no**"

    lines = [
        "# Table 1, measured",
        "",
        "Generated by `python experiments/table1.py` (also `python -m paper_figures --only table01`); do not edit.",
        "",
        f"Ranks and off-span norms over {samples} random configurations of 4 free points (±0.4 m around",
        "their bases); robot ranks at 5 configurations around q0.  Off-span: the spectral norm of",
        "the range projector of J^G restricted to the rows *outside* the paper's blades",
        "(0: the blades span the range; 1: a range direction lies entirely outside them).",
        "",
        "| primitive | paper's blades | dim | rank of J^G (free points) | rank on robot | "
        "exact at X_u | off-span median / max elsewhere | exact elsewhere |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for kind, r in rows.items():
        rk = f"{r['rank_min']}" if r["rank_min"] == r["rank_max"] else f"{r['rank_min']}–{r['rank_max']}"
        rr = r["robot_rank_min"] if r["robot_rank_min"] == r["robot_rank_max"] else "varies"
        lines.append(
            f"| {kind.replace('_', ' ')} | {', '.join(r['paper_blades'])} | {r['paper_dimension']} | {rk} | "
            f"{rr} ({r['robot']}) | {yn(r['exact_at_unit'])} | "
            f"{r['off_span_median']:.2f} / {r['off_span_max']:.2f} | {yn(r['exact_elsewhere'])} |"
        )
    lines += [
        "",
        "Reading: the dimension column is right everywhere (rank = the primitive's DOF < 7, so every",
        "cooperative task has a geometric nullspace), and the blade sets are exact at the unit",
        "primitive.  Away from it, for point pairs, lines, circles and planes the range has the",
        "right dimension but is *not* spanned by the listed blades: the minimal-rotation chart",
        "(§3.3, Eq 26) twists about the primitive's axis as the axis moves, and for flats the",
        "reference point moves with a rotation.  See `docs/table1.md` for the explanation.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--samples", type=positive_int, default=200, help="random configurations per primitive")
    exp.add_fast("fewer samples (CI)", samples=20)
    args = exp.parse(argv)
    samples = args.samples
    rows = {}
    for kind in exp.progress(list(PAPER_BLADES), "measuring J^G per primitive"):
        rows[kind] = measure(kind, samples, exp.rng)
    text = markdown(rows, samples)
    (exp.out / "table1.md").write_text(text)
    dims_ok = all(r["rank_min"] == r["rank_max"] == r["paper_dimension"] for r in rows.values())
    robots_ok = all(r["robot_rank_min"] == r["robot_rank_max"] == r["paper_dimension"] for r in rows.values())
    unit_ok = all(r["exact_at_unit"] for r in rows.values())
    not_exact = [k for k, r in rows.items() if not r["exact_elsewhere"]]
    worst = max(rows.values(), key=lambda r: r["off_span_max"])
    metrics = {
        "samples": samples,
        "rows": rows,
        "dimension_matches_rank_everywhere": dims_ok,
        "robot_rank_matches": robots_ok,
        "blades_exact_at_unit_primitive": unit_ok,
        "blades_not_exact_elsewhere": not_exact,
        "gallery": {
            "title": "Table 1: controllable bivector spaces",
            "claim": "Each cooperative primitive controls a fixed subspace of the 7-dimensional similarity "
            "algebra, spanned by the listed blades (dimension = the primitive's DOF).",
            "evidence": (
                f"Rank of J^G equals the paper's dimension for every primitive at all {samples} free-point "
                f"samples ({'yes' if dims_ok else 'NO'}) and on the robots ({'yes' if robots_ok else 'NO'}); "
                f"the blade sets are exact at the unit primitive ({'yes' if unit_ok else 'NO'}). "
                f"We disagree elsewhere: for {', '.join(k.replace('_', ' ') for k in not_exact)} the range leaves "
                f"the listed blades (off-span norm up to {worst['off_span_max']:.2f}), so the column holds only at X_u."
            ),
            "agrees": False,
            "figures": [],
            "tables": ["table1.md"],
        },
    }
    exp.write_json("metrics.json", metrics)
    print(text)
    print(f"wrote {exp.out / 'table1.md'} and {exp.out / 'metrics.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
