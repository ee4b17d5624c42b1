"""Regenerate every paper figure coop_ga can produce so far, in one command.

    python paper_figures/make_all.py [--out paper_figures] [--only SUBDIR ...] [--seed N] [--quiet]

Runs, headless and deterministically:

=============================  ==========================================  ======================
script                         paper figure                                output
=============================  ==========================================  ======================
paper_figures/systems.py       Figs. 3, 5, 9–13 (the systems at q0)        ``<out>/systems/``
experiments/circle_reaching    Fig. 8 (three Frankas, iLQR circle reach)   ``<out>/fig08_circle_reaching/``
experiments/impedance_…iiwa    Figs. 5–6 (impedance control response)      ``<out>/fig06_impedance/``
experiments/nullspace_…        Figs. 16–17 (secondary task in nullspace)   ``<out>/fig16_17_nullspace/``
experiments/teleop_allegro     Figs. 20–21 (dilation closes/opens hand)    ``<out>/fig20_21_teleop/``
=============================  ==========================================  ======================

``--seed N`` is passed to every script (default: each script keeps its own seed, so the
committed figures are reproduced exactly); ``--quiet`` is passed on too.

Not yet reproduced (see the issue notes): the reaching figures on the other systems
(Figs. 7, 9b–13b), the line tasks (Figs. 14–15) and the singularity figures (18–19).
"""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path

from coop_ga.harness import Experiment

ROOT = Path(__file__).resolve().parents[1]

JOBS = [
    ("paper_figures/systems.py", "systems"),
    ("experiments/circle_reaching.py", "fig08_circle_reaching"),
    ("experiments/impedance_three_iiwa.py", "fig06_impedance"),
    ("experiments/nullspace_secondary.py", "fig16_17_nullspace"),
    ("experiments/teleop_allegro.py", "fig20_21_teleop"),
]


def _load(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=None, out=ROOT / "paper_figures")
    exp.add(
        "--only",
        nargs="*",
        metavar="SUBDIR",
        choices=[sub for _, sub in JOBS],
        help="regenerate only these output folders",
    )
    args = exp.parse(argv)
    jobs = [(script, sub) for script, sub in JOBS if not args.only or sub in args.only]
    extra = (["--seed", str(args.seed)] if args.seed is not None else []) + (["--quiet"] if args.quiet else [])
    t_all = time.perf_counter()
    for i, (script, sub) in enumerate(jobs, 1):
        t0 = time.perf_counter()
        print(f"[{i}/{len(jobs)}] {script} → {args.out / sub}", flush=True)
        rc = _load(ROOT / script).main(["--out", str(args.out / sub), *extra])
        if rc not in (0, None):
            print(f"    {script} failed with exit code {rc}")
            return int(rc)
        print(f"    done in {time.perf_counter() - t0:.1f} s", flush=True)
    print(f"all figures written under {args.out} in {time.perf_counter() - t_all:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
