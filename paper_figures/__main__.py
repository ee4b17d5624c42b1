"""Regenerate every figure of the paper, and the gallery that shows them, in one command.

    python -m paper_figures [--out DIR] [--only fig12 ...] [--fast] [--jobs N (default: the CPU count, ≤ 4)]

Runs each figure's experiment script (``paper_figures.FIGURES``: Figs. 5–21, Table 1 and
the drawings of the systems) into ``DIR/figNN_<name>/`` — its PNGs, ``metrics.json`` and,
untracked, ``timing.json`` and ``log.txt`` (the script's own output) — and writes the
gallery ``DIR/README.md``: per figure the paper's claim, the measured numbers that support
or contradict it, and the command that made it.

A figure is regenerated into a fresh folder next to its own (``DIR/.figNN_<name>.new``) and
swapped in only when it succeeded: the earlier PNG/JSON/NPZ/MD/TXT files then disappear (no
stale figure survives; other files in the folder are kept), and a failed or interrupted run
leaves the folder exactly as it was (the failed run's files stay in
``DIR/.figNN_<name>.failed`` for inspection).

Deterministic: every script draws from its own fixed seed (``--seed`` overrides all of
them), metrics are rounded to 6 significant digits and NPZ files carry no timestamps, so
a re-run without code changes leaves the committed files unchanged.  Each figure runs in a
fresh process (a worker that runs one figure and exits, forked from a server that has imported
``PRELOAD`` where the platform can): a library's process-wide
state — OMPL's random generator is seeded once per process and every planner draws its seed
from that one sequence — would otherwise make a figure depend on which figures its worker ran
before it.  Only ``--verbose`` runs the figures in this process, one after the other.

A figure fails if its script raises or returns non-zero, if a figure its gallery block
lists is missing, or if a published trajectory leaves the joint limits
(``max_limit_violation`` > 0 anywhere in its metrics).  The other figures still run; the
exit status is 1 and the failures are listed.

``--fast`` uses each script's short horizons (for CI): the numbers are not the published
ones, and the gallery says so.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from coop_ga.harness import experiment_parser, positive_int, write_json

from . import FIGURES, ROOT, Figure, load_script, select

LOG_FILE = "log.txt"
#: metrics keys that must be 0 in every published figure (a trajectory outside the joint limits)
VIOLATION_KEYS = ("max_limit_violation", "max_velocity_violation", "max_acceleration_violation")
#: the files a figure's run writes: those of the previous run are dropped when the new one is swapped in
OUTPUT_SUFFIXES = (".png", ".gif", ".mp4", ".json", ".npz", ".xml", ".md", ".txt")


def _limit_violations(obj: Any, path: str = "") -> list[tuple[str, float]]:
    """Every ``max_limit_violation`` (position, [rad]), ``max_velocity_violation`` ([rad/s]) or
    ``max_acceleration_violation`` ([rad/s²]) value > 0 in a metrics tree, with its key path."""
    out: list[tuple[str, float]] = []
    if isinstance(obj, dict):
        for k, v in obj.items():
            p = f"{path}.{k}" if path else str(k)
            if k in VIOLATION_KEYS and isinstance(v, (int, float)) and v > 0:
                out.append((p, float(v)))
            else:
                out += _limit_violations(v, p)
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            out += _limit_violations(v, f"{path}[{i}]")
    return out


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


def _staging(out: Path, fig: Figure) -> tuple[Path, Path, Path, Path]:
    """``(folder, new, failed, previous)``: the figure's folder and its hidden siblings (same file system,
    so every move below is a rename)."""
    return out / fig.folder, out / f".{fig.folder}.new", out / f".{fig.folder}.failed", out / f".{fig.folder}.previous"


def _swap_in(new: Path, folder: Path, previous: Path) -> None:
    """Make ``new`` the figure's folder.  Files of ``folder`` that are no run's output (notes, sub-folders)
    are copied over first; its outputs are not (a figure the script no longer makes must not survive).
    ``folder`` is renamed aside before ``new`` takes its name: an interruption between the two renames
    leaves ``previous`` complete, and :func:`_recover` puts it back."""
    if folder.exists():
        for entry in folder.iterdir():
            if (entry.is_file() and entry.suffix in OUTPUT_SUFFIXES) or (new / entry.name).exists():
                continue
            if entry.is_dir():
                shutil.copytree(entry, new / entry.name, symlinks=True)
            else:
                shutil.copy2(entry, new / entry.name, follow_symlinks=False)
        _remove(previous)
        folder.rename(previous)
    new.rename(folder)
    _remove(previous)


def _recover(folder: Path, previous: Path) -> None:
    """Undo a swap that was interrupted after the old folder was renamed aside."""
    if previous.exists() and not folder.exists():
        previous.rename(folder)


def run_one(fig: Figure, out: Path, extra: list[str], verbose: bool) -> dict[str, Any]:
    """Run one figure's script into a fresh folder, check what it wrote and, if all is well, swap it in
    as ``out/fig.folder`` (module docstring); otherwise ``out/fig.folder`` is left untouched.

    Returns ``{"key", "ok", "seconds", "cpu_seconds", "problems": [...]}`` (wall and CPU time [s]).  The script's stdout/stderr go
    to ``log.txt`` in its folder (and to the terminal too with ``verbose``)."""
    folder, new, failed, previous = _staging(out, fig)
    _recover(folder, previous)
    _remove(new)  # left over by a run that was killed
    new.mkdir(parents=True)
    try:
        problems, seconds, cpu = _run_checked(fig, new, extra, verbose)
        if problems:
            _remove(failed)
            new.rename(failed)
            problems.append(f"{folder} is unchanged; this run's files and log are in {failed}")
        else:
            _swap_in(new, folder, previous)
            _remove(failed)
    finally:
        _remove(new)  # an interrupted run (KeyboardInterrupt) leaves nothing behind
    return {"key": fig.key, "ok": not problems, "seconds": seconds, "cpu_seconds": cpu, "problems": problems}


def _run_checked(fig: Figure, folder: Path, extra: list[str], verbose: bool) -> tuple[list[str], float, float]:
    """Run the script into ``folder`` and check its outputs: ``(problems, wall seconds, CPU seconds)``."""
    argv = [*fig.args, "--out", str(folder), *extra]
    problems: list[str] = []
    t0, c0 = time.perf_counter(), _cpu_seconds()
    log = io.StringIO()
    try:
        main = load_script(fig.script)
        if verbose:
            rc = main(argv)
        else:
            with contextlib.redirect_stdout(log), contextlib.redirect_stderr(log):
                rc = main(argv)
        if rc not in (0, None):
            problems.append(f"{fig.script} returned exit status {rc}")
    except SystemExit as e:  # argparse errors
        if e.code not in (0, None):
            problems.append(f"{fig.script} exited with status {e.code}")
    except Exception:
        problems.append(f"{fig.script} raised:\n{traceback.format_exc()}")
    seconds, cpu = time.perf_counter() - t0, _cpu_seconds() - c0
    (folder / LOG_FILE).write_text(log.getvalue())
    return problems or _output_problems(folder), seconds, cpu


def _cpu_seconds() -> float:
    """User + system CPU time [s] of this process and its waited-for children (a script's own worker processes)."""
    import resource

    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _output_problems(folder: Path) -> list[str]:
    """What is wrong with a run's outputs: no metrics or gallery block, a listed figure missing, a
    trajectory outside the joint limits."""
    metrics_path = folder / "metrics.json"
    if not metrics_path.exists():
        return ["no metrics.json written"]
    problems = []
    metrics = json.loads(metrics_path.read_text())
    gallery = metrics.get("gallery")
    if not isinstance(gallery, dict) or not {"title", "claim", "evidence", "agrees"} <= set(gallery):
        problems.append("metrics.json has no complete 'gallery' block (title, claim, evidence, agrees)")
    else:
        for name in [*gallery.get("figures", []), *gallery.get("tables", [])]:
            if not (folder / name).exists():
                problems.append(f"the gallery lists {name}, which was not written")
    for where, v in _limit_violations(metrics):
        problems.append(f"a trajectory leaves the joint limits: {where} = {v:g} rad")
    return problems


def _worker(args: tuple[Figure, str, list[str]]) -> dict[str, Any]:
    fig, out, extra = args  # the Figure itself: a spawned process re-imports FIGURES, not the caller's list
    os.environ.setdefault("MPLBACKEND", "Agg")
    return run_one(fig, Path(out), extra, verbose=False)


def _numbers(fig: Figure) -> str:
    if fig.addition:
        return "Ours"
    if fig.key.startswith("table"):
        return f"Table {int(fig.key[5:])}"
    if not fig.numbers:
        return "Systems"
    n = fig.numbers
    return f"Fig. {n[0]}" if len(n) == 1 else f"Figs. {n[0]}–{n[-1]}"


def write_gallery(out: Path, fast: bool, failures: dict[str, list[str]]) -> Path:
    """Write ``out/README.md`` from the ``gallery`` block of every folder present in ``out``."""
    lines = [
        "# Paper figures",
        "",
        "Every figure of Löw, Bilaloglu and Calinon, *Cooperative Task Spaces for Multi-Arm Manipulation "
        "Control based on Similarity Transformations* (§4, Figs. 5–21, Table 1), reproduced by coop_ga.",
        "Regenerate all of them with",
        "",
        "```bash",
        "python -m paper_figures" + ("" if out.resolve() == (ROOT / "paper_figures").resolve() else f" --out {out}"),
        "```",
        "",
        "or one with `python -m paper_figures --only fig12`. Each folder holds the PNGs and a `metrics.json`; "
        "every number quoted below is read from it. *Agrees* means the measurement supports the paper's claim; "
        "where it does not, the text says what we measured instead. Rows marked *Ours* are our own additions "
        "beyond the paper (its claims are then those of the seed named in the title).",
        "",
    ]
    if fast:
        lines += [
            "> **Fast mode** (`--fast`, short horizons for CI): these numbers are not the published ones.",
            "",
        ]
    entries = []
    for fig in FIGURES:
        mpath = out / fig.folder / "metrics.json"
        if fig.key in failures:
            entries.append((fig, None))
        elif mpath.exists():
            entries.append((fig, json.loads(mpath.read_text()).get("gallery")))
    lines += ["| | figure | agrees |", "|---|---|---|"]
    for fig, g in entries:
        title = g["title"] if g else "(failed)"
        mark = "—" if not g else ("yes" if g.get("agrees") else "**no**, see below")
        anchor = fig.folder.replace("_", "-")
        lines.append(f"| {_numbers(fig)} | [{title}](#{anchor}) | {mark} |")
    lines.append("")
    for fig, g in entries:
        title = g["title"] if g else fig.key
        # "Table 1: …" or "The systems" already say what they are; "Fig. 7: <title>" otherwise
        heading = (
            title
            if title.startswith(("Fig", "Table")) or fig.key == "systems" or fig.addition
            else f"{_numbers(fig)}: {title}"
        )
        lines += [f'<a id="{fig.folder.replace("_", "-")}"></a>', "", f"## {heading}", ""]
        if g is None:
            lines += ["**This figure failed in the last run:**", "", "```", *failures[fig.key], "```", ""]
            continue
        lines += [
            f"**{'Claim' if fig.addition else 'Paper'}.** {g['claim']}",
            "",
            f"**Measured.** {g['evidence']}",
            "",
            f"**Agrees:** {'yes' if g.get('agrees') else 'no'}.",
            "",
        ]
        for name in g.get("figures", []):
            lines += [f"![{fig.folder}/{name}]({fig.folder}/{name})", ""]
        for name in g.get("tables", []):
            table = (out / fig.folder / name).read_text()
            body = [ln for ln in table.splitlines() if not ln.startswith("# ") and "do not edit" not in ln]
            lines += [*body, ""]
        lines += [
            f"Command: `{fig.command}` (or `{fig.script_command(f'DIR/{fig.folder}')}`); "
            f"numbers: [`metrics.json`]({fig.folder}/metrics.json).",
            "",
        ]
    path = out / "README.md"
    tmp = out / ".README.md.new"  # written whole, then renamed: an interrupted run keeps the old gallery
    tmp.write_text("\n".join(lines).rstrip() + "\n")
    os.replace(tmp, path)
    return path


def _parser() -> Any:
    """The command line (module docstring)."""
    p = experiment_parser(
        "paper_figures", __doc__, seed=None, out=ROOT / "paper_figures", prog="python -m paper_figures"
    )
    p.add_argument("--only", nargs="+", metavar="FIG", help="run only these figures (fig12, fig16_17, table01, ...)")
    p.add_argument("--fast", action="store_true", help="short horizons in every script (CI); not the published numbers")
    p.add_argument(
        "--jobs",
        type=positive_int,
        default=None,
        help="figures run in parallel, each in its own process (default: the CPU count, at most 4)",
    )
    p.add_argument(
        "--verbose",
        action="store_true",
        help="run the figures in this process, one after the other, showing each script's own output (not with --jobs > 1)",
    )
    p.add_argument("--list", action="store_true", help="list the figures and their scripts, then exit")
    return p


def _list_figures() -> None:
    """``--list``: every figure's key, numbers, folder and command line."""
    kw = max(len(g.key) for g in FIGURES)
    fw = max(len(g.folder) for g in FIGURES)
    for f in FIGURES:
        print(f"{f.key:{kw}s}  {_numbers(f):14s} {f.folder:{fw}s}  {' '.join([f.script, *f.args])}")


#: modules a figure's process starts with (forked from a server that imported them once, where the platform can):
#: ~1 s of imports per figure saved; none of them holds process-wide state a figure changes (MuJoCo and matplotlib
#: are left out: they pick their GL / plotting backend from the environment at import)
PRELOAD = ["numpy", "scipy.linalg", "scipy.optimize", "pinocchio", "casadi", "coop_ga", "coop_ga.control",
           "coop_ga.cooperative", "paper_figures.__main__"]  # fmt: skip


def _context(mp: Any) -> Any:
    """The multiprocessing context of the figures' processes: ``forkserver`` with :data:`PRELOAD` where the
    platform has it (Linux, macOS), else ``spawn``; each figure still gets a process of its own."""
    if "forkserver" not in mp.get_all_start_methods():
        return mp.get_context("spawn")
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(PRELOAD)
    return ctx


def _run_figures(figs: list[Figure], out: Path, extra: list[str], args: Any, say: Any) -> dict[str, dict[str, Any]]:
    """Run ``figs`` in this process (``--verbose``) or each in its own spawned process, ``args.jobs`` at a time;
    reports each as it ends."""
    results: dict[str, dict[str, Any]] = {}

    def report(i: int, r: dict[str, Any]) -> None:
        fig = next(f for f in figs if f.key == r["key"])
        status = "done" if r["ok"] else "FAILED"
        say(f"[{i}/{len(figs)}] {_numbers(fig):14s} {fig.folder:34s} {status} in {r['seconds']:.1f} s")
        for prob in r["problems"]:
            say("    " + prob.replace("\n", "\n    "))

    if args.verbose:
        from coop_ga.harness import use_backend

        use_backend()
        for i, fig in enumerate(figs, 1):
            say(f"[{i}/{len(figs)}] {_numbers(fig):14s} {fig.folder:34s} running ...")
            results[fig.key] = r = run_one(fig, out, extra, args.verbose)
            report(i, r)
    else:
        import importlib
        import multiprocessing as mp

        # by its importable name: under `python -m paper_figures` this module is __main__, which a spawned
        # worker cannot unpickle a function from
        worker = importlib.import_module("paper_figures.__main__")._worker
        # one figure per process (module docstring): a figure's numbers must not depend on its worker's history
        ctx = _context(mp)
        with ProcessPoolExecutor(max_workers=args.jobs, mp_context=ctx, max_tasks_per_child=1) as pool:
            futures = [pool.submit(worker, (f, str(out), extra)) for f in figs]
            for i, fut in enumerate(as_completed(futures), 1):
                r = fut.result()
                results[r["key"]] = r
                report(i, r)
    return results


def main(argv: list[str] | None = None) -> int:
    p = _parser()
    args = p.parse_args(argv)
    if args.jobs is None:
        args.jobs = 1 if args.verbose else min(os.cpu_count() or 1, 4)
    if args.verbose and args.jobs > 1:
        p.error("--verbose runs the figures in this process, one after the other: use --jobs 1 or drop --jobs")
    if args.list:
        _list_figures()
        return 0
    try:
        figs = select(args.only)
    except ValueError as e:
        p.error(str(e))
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    extra = (
        ["--quiet"] + (["--fast"] if args.fast else []) + (["--seed", str(args.seed)] if args.seed is not None else [])
    )
    say = (lambda *a: None) if args.quiet else (lambda *a: print(*a, flush=True))
    say(f"paper_figures: {len(figs)} figure(s) into {out}" + (" (fast mode)" if args.fast else ""))
    t_all = time.perf_counter()
    results = _run_figures(figs, out, extra, args, say)
    failures = {k: r["problems"] for k, r in results.items() if not r["ok"]}
    gallery = write_gallery(out, args.fast, failures)
    total = time.perf_counter() - t_all
    write_json(
        out / "timing.json",
        {
            "total_s": total,
            "jobs": args.jobs,
            "fast": args.fast,
            "figures_s": {k: r["seconds"] for k, r in results.items()},
            "figures_cpu_s": {k: r["cpu_seconds"] for k, r in results.items()},
        },
        digits=3,
    )
    say(f"gallery: {gallery}  ({total:.1f} s in all)")
    if failures:
        say(f"{len(failures)} figure(s) failed: {', '.join(failures)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
