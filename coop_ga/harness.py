"""The experiment harness: what every experiment, figure and benchmark script shares.

A script does::

    exp = Experiment(__file__, __doc__, seed=0)           # --out, --seed, --quiet, --help
    exp.add("--duration", type=positive_float, default=4.0, help="simulated time [s]")
    args = exp.parse(argv)                                  # exits 2 with a clear message on bad values
    plt = exp.pyplot()                                      # Agg (headless) + the coop_ga.viz paper style
    with exp.stage("compiling the task"):                   # "compiling the task ... done (1.2 s)" on stderr
        ...
    for q in exp.progress(qs, "evaluating"):                # a tqdm progress bar on stderr
        ...
    exp.write_json("metrics.json", metrics)                 # strict JSON, NaN/inf → null, 6 digits
    exp.write_timing({"solve_s": t})                        # wall-clock times: timing.json, untracked
    exp.write_npz("trajectory.npz", q=Q)
    exp.save(fig, "figure.png")

and uses ``exp.rng`` (``numpy.random.default_rng(--seed)``) for every random draw, so the
same seed gives the same run.

Command line (every script): ``--out DIR`` (default ``results/<script name>``), ``--seed N``
(a non-negative integer), ``--quiet`` (no progress bars or stage timers on stderr; results
still go to stdout and the files), ``--help`` (the script's docstring and every option
with its default).  A script with a short CI mode declares it with :meth:`Experiment.add_fast`
(``--fast`` and the values it gives to other options); **an option given on the command line
always keeps its value**, ``--fast`` only replaces defaults (``--fast --dt 0.01`` runs the
fast presets at Δt = 0.01 s).  Values are checked by the ``type=`` functions below
(:func:`positive_float`, :func:`nonneg_float`, :func:`finite_float`, :func:`positive_int`,
:func:`nonneg_int`, :func:`int_at_least`, :func:`probability`; fixed sets with argparse's
``choices=``): a bad value makes argparse print ``argument --duration: expected a number > 0,
got '-1'`` and exit with status 2.

JSON: :func:`write_json` accepts numpy scalars and arrays, tuples, paths and dataclasses.
JSON has no NaN or infinity, so **every non-finite float is written as ``null``** and the
file is strict JSON (``json.loads(text, parse_constant=...)`` never sees ``NaN``/``Infinity``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from types import ModuleType, TracebackType
from typing import Any

import numpy as np

__all__ = [
    "METRIC_DIGITS",
    "TIMING_FILE",
    "Experiment",
    "HelpFormatter",
    "experiment_parser",
    "explicit_options",
    "finite_float",
    "int_at_least",
    "make_rng",
    "nonneg_float",
    "nonneg_int",
    "positive_float",
    "positive_int",
    "probability",
    "progress",
    "stage",
    "to_jsonable",
    "use_backend",
    "write_json",
    "write_npz",
]


# ---------------------------------------------------------------------- argument types
def _float(text: str) -> float:
    try:
        x = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return x


def _int(text: str) -> int:
    try:
        return int(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def finite_float(text: str) -> float:
    """argparse type: any finite number."""
    return _float(text)


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    x = _float(text)
    if not x > 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return x


def nonneg_float(text: str) -> float:
    """argparse type: a finite number ≥ 0."""
    x = _float(text)
    if x < 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return x


def probability(text: str) -> float:
    """argparse type: a number in [0, 1]."""
    x = _float(text)
    if not 0.0 <= x <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a probability in [0, 1], got {text!r}")
    return x


def int_at_least(k: int) -> Callable[[str], int]:
    """argparse type factory: an integer ≥ ``k``."""

    def check(text: str) -> int:
        n = _int(text)
        if n < k:
            raise argparse.ArgumentTypeError(f"expected an integer >= {k}, got {text!r}")
        return n

    check.__name__ = f"int_at_least_{k}"
    return check


#: argparse type: an integer ≥ 0 (e.g. a seed).
nonneg_int = int_at_least(0)
nonneg_int.__name__ = "nonneg_int"
#: argparse type: an integer ≥ 1 (e.g. a number of runs).
positive_int = int_at_least(1)
positive_int.__name__ = "positive_int"


# ---------------------------------------------------------------------- parser
class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """``--help`` keeps the description's layout (the script's docstring) and shows every default."""


def experiment_parser(
    name: str,
    description: str | None,
    *,
    seed: int | None = 0,
    out: str | Path | None = None,
    prog: str | None = None,
    epilog: str | None = None,
) -> argparse.ArgumentParser:
    """An ``ArgumentParser`` with the options every script has.

    ``--out`` (default ``out`` or ``results/<name>``), ``--seed`` (default ``seed``; with
    ``seed=None`` the option defaults to None, meaning "each sub-script's own seed"), ``--quiet``.
    ``--help`` shows ``description`` as written and the default of every option.
    """
    p = argparse.ArgumentParser(
        prog=prog or f"{name}.py", description=description, epilog=epilog, formatter_class=HelpFormatter
    )
    p.add_argument(
        "--out",
        type=Path,
        default=Path(out) if out is not None else Path("results") / name,
        help="output directory (created if needed)",
    )
    p.add_argument(
        "--seed", type=nonneg_int, default=seed, help="seed of numpy.random.default_rng, used for every random draw"
    )
    p.add_argument("--quiet", action="store_true", help="no progress bars or stage timers on stderr")
    return p


class _Unset:
    """Marks an option that the command line did not give (see :func:`explicit_options`)."""

    def __repr__(self) -> str:
        return "<unset>"


_UNSET = _Unset()


def explicit_options(parser: argparse.ArgumentParser, argv: list[str] | None = None) -> set[str]:
    """The ``dest`` of every option that ``argv`` (default ``sys.argv[1:]``) gives explicitly,
    also when it gives the default value.  ``argv`` must parse (parse it first for the errors)."""
    # argparse fills in a default only where the namespace has no attribute yet: pre-set every
    # destination to a marker, and whatever the command line set is no longer the marker
    probe = argparse.Namespace(**{a.dest: _UNSET for a in parser._actions if a.dest != argparse.SUPPRESS})
    ns = parser.parse_args(argv, namespace=probe)
    return {k for k, v in vars(ns).items() if v is not _UNSET}


def make_rng(seed: int | None) -> np.random.Generator:
    """``numpy.random.default_rng(seed)``: the one source of randomness of a run."""
    return np.random.default_rng(seed)


def _show(v: Any) -> str:
    return " ".join(map(str, v)) if isinstance(v, (list, tuple)) else str(v)


# ---------------------------------------------------------------------- output
#: significant digits of every float an :class:`Experiment` writes to JSON (committed metrics).
METRIC_DIGITS = 6
#: the untracked per-run file of wall-clock times, next to ``metrics.json``.
TIMING_FILE = "timing.json"


def to_jsonable(x: Any, digits: int | None = None) -> Any:
    """``x`` as plain JSON data: numpy scalars/arrays → numbers/lists, tuples/sets → lists,
    paths → strings, dataclasses → dicts, keys → strings, and **NaN/±inf → None** (``null``).

    ``digits``: round every float to that many *significant* digits (``1.234567e-07`` stays
    ``1.23457e-07`` with 6), so that a committed metrics file does not change with the last
    bits of a re-run; ``None`` keeps full precision."""
    if x is None or isinstance(x, str):
        return x
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        v = float(x)
        if not math.isfinite(v):
            return None
        return float(f"{v:.{digits}g}") if digits is not None else v
    if isinstance(x, dict):
        return {str(k): to_jsonable(v, digits) for k, v in x.items()}
    if isinstance(x, (list, tuple, set, frozenset)):
        return [to_jsonable(v, digits) for v in x]
    if isinstance(x, np.ndarray):
        return to_jsonable(x.tolist(), digits)
    if isinstance(x, Path):
        return str(x)
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return to_jsonable(dataclasses.asdict(x), digits)
    raise TypeError(f"write_json cannot encode a {type(x).__name__}: convert it to numbers, strings or lists first")


def write_json(path: str | Path, obj: Any, *, indent: int = 2, digits: int | None = None) -> Path:
    """Write ``obj`` as strict, indented JSON (see :func:`to_jsonable`: NaN/inf → ``null``,
    floats rounded to ``digits`` significant digits if given); parent directories are
    created.  Returns the path."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(to_jsonable(obj, digits), indent=indent, allow_nan=False) + "\n")
    return p


def write_npz(path: str | Path, **arrays: Any) -> Path:
    """Write the arrays to a compressed ``.npz`` (parent directories created).  Returns the path.

    The file is byte-for-byte reproducible: ``numpy.savez_compressed`` stamps each member
    with the current time, so the same arrays gave a different file on every run (and a
    changed tracked file after every figure regeneration).  Here every member gets the
    fixed zip epoch 1980-01-01 and a sorted order; ``numpy.load`` reads it as usual.
    """
    import io
    import zipfile

    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(p, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name in sorted(arrays):
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.asanyarray(arrays[name]), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, buf.getvalue())
    return p


# ---------------------------------------------------------------------- matplotlib
def use_backend(interactive: bool = False) -> str:
    """Select matplotlib's backend before anything draws: ``Agg`` (headless, files only)
    unless ``interactive``, in which case matplotlib's default (a window if there is a
    display) is kept.  Returns the backend's name."""
    import matplotlib

    if not interactive:
        matplotlib.use("Agg", force=True)
    return str(matplotlib.get_backend())


# ---------------------------------------------------------------------- progress
def progress(iterable: Iterable[Any], desc: str, *, total: int | None = None, quiet: bool = False) -> Iterable[Any]:
    """Iterate with a tqdm progress bar on stderr (nothing when ``quiet``).

    On a terminal the bar redraws in place; in a log (stderr not a terminal) it is refreshed
    at most every 10 s so logs stay short.
    """
    from tqdm import tqdm

    if not quiet:
        _end_stage_line()
    tty = hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
    return tqdm(
        iterable,
        desc=desc,
        total=total,
        disable=quiet,
        file=sys.stderr,
        dynamic_ncols=True,
        mininterval=0.1 if tty else 10.0,
        leave=True,
    )


_stage_line_open = False  # a stage printed "label ..." and nothing has ended that line yet


def _end_stage_line() -> None:
    global _stage_line_open
    if _stage_line_open:
        print(file=sys.stderr, flush=True)
        _stage_line_open = False


class stage:
    """``with stage("compiling the task", quiet) as st:`` prints ``compiling the task ... done (1.23 s)``
    (or ``failed``) on stderr, unless ``quiet``; ``st.seconds`` is the wall time [s].

    A progress bar inside the block starts on its own line; the stage then ends with
    ``compiling the task: done (1.23 s)``.
    """

    def __init__(self, label: str, quiet: bool = False):
        self.label, self.quiet, self.seconds = label, quiet, float("nan")

    def __enter__(self) -> stage:
        global _stage_line_open
        self._t0 = time.perf_counter()
        if not self.quiet:
            _end_stage_line()
            print(f"{self.label} ...", end="", flush=True, file=sys.stderr)
            _stage_line_open = True
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        global _stage_line_open
        self.seconds = time.perf_counter() - self._t0
        if not self.quiet:
            result = f"{'done' if exc_type is None else 'failed'} ({self.seconds:.2f} s)"
            print(f" {result}" if _stage_line_open else f"{self.label}: {result}", flush=True, file=sys.stderr)
            _stage_line_open = False


# ---------------------------------------------------------------------- all of it
class Experiment:
    """The harness of one script (module docstring): parser, output directory, seed, quiet flag.

    Args:
        file: the script's ``__file__`` (its stem names the default output ``results/<stem>``).
        description: shown by ``--help`` as written (usually the script's ``__doc__``).
        seed: default of ``--seed`` (``None``: no seed of its own; see :func:`experiment_parser`).
        out: default of ``--out`` instead of ``results/<stem>``.

    After :meth:`parse`: ``args``, ``out`` (created), ``seed``, ``quiet``, ``rng``, ``fast`` (False
    without :meth:`add_fast`) and ``explicit`` (the options the command line gave).
    """

    def __init__(
        self, file: str | Path, description: str | None, *, seed: int | None = 0, out: str | Path | None = None
    ):
        self.name = Path(file).stem
        self.parser = experiment_parser(self.name, description, seed=seed, out=out, prog=Path(file).name)
        self.args: argparse.Namespace | None = None
        self.quiet = False
        self.fast = False
        self.fast_presets: dict[str, Any] = {}
        self.explicit: set[str] = set()

    def add(self, *names: str, **kwargs: Any) -> argparse.Action:
        """``parser.add_argument``: a script's own option (give ``type=`` a checker above)."""
        return self.parser.add_argument(*names, **kwargs)

    def add_fast(self, help: str, **presets: Any) -> argparse.Action:
        """``--fast``: the script's short run (CI), which gives the options named in ``presets``
        (by ``dest``: ``dt=0.04``) those values instead of their defaults.  An option given on the
        command line keeps its own value (an explicit option always wins; :meth:`parse` says so on
        stderr).  Declare the options first; the presets must be values those options accept.
        """
        dests = {a.dest: a for a in self.parser._actions}
        for dest in presets:
            if dest not in dests or dest == "fast":
                raise ValueError(f"add_fast: no option with dest {dest!r} to preset; add it first")
        self.fast_presets = dict(presets)
        shown = ", ".join(f"{dests[d].option_strings[0]} {_show(v)}" for d, v in presets.items())
        note = f" ({shown}; an option given explicitly keeps its value)" if presets else ""
        return self.parser.add_argument("--fast", action="store_true", help=help + note)

    def parse(self, argv: list[str] | None = None) -> argparse.Namespace:
        """Parse ``argv`` (default ``sys.argv[1:]``), apply the ``--fast`` presets to the options not
        given explicitly, create ``--out`` and seed ``rng``."""
        self.args = self.parser.parse_args(argv)
        self.explicit = explicit_options(self.parser, argv)
        self.fast = bool(getattr(self.args, "fast", False))
        self.quiet = bool(self.args.quiet)
        if self.fast:
            kept = []
            for dest, value in self.fast_presets.items():
                if dest in self.explicit:
                    kept.append(f"{dest} = {_show(getattr(self.args, dest))} (fast preset {_show(value)})")
                else:
                    setattr(self.args, dest, value)
            if kept and not self.quiet:
                print(f"--fast: kept the explicit {'; '.join(kept)}", file=sys.stderr, flush=True)
        self.seed = self.args.seed
        self.rng = make_rng(self.seed)
        self.out = Path(self.args.out)
        self.out.mkdir(parents=True, exist_ok=True)
        return self.args

    def pyplot(self, interactive: bool = False) -> ModuleType:
        """``matplotlib.pyplot`` on the Agg backend (or the default one if ``interactive``),
        with the :mod:`coop_ga.viz` paper style applied."""
        use_backend(interactive)
        import matplotlib.pyplot as plt

        from .viz import use_style

        use_style()
        return plt

    def progress(self, iterable: Iterable[Any], desc: str, total: int | None = None) -> Iterable[Any]:
        """:func:`progress`, silent with ``--quiet``."""
        return progress(iterable, desc, total=total, quiet=self.quiet)

    def stage(self, label: str) -> stage:
        """:class:`stage`, silent with ``--quiet``."""
        return stage(label, self.quiet)

    def write_json(self, name: str, obj: Any, digits: int | None = METRIC_DIGITS) -> Path:
        """:func:`write_json` into ``--out``, floats rounded to ``digits`` significant digits
        (default :data:`METRIC_DIGITS`) so that a re-run leaves committed results unchanged.

        Wall-clock times change on every run: write them with :meth:`write_timing` instead."""
        return write_json(self.out / name, obj, digits=digits)

    def write_timing(self, obj: Any) -> Path:
        """Write wall-clock measurements [s] to ``--out/timing.json`` (3 significant digits).
        This file is *not* tracked (``.gitignore``): times differ on every run and machine."""
        return write_json(self.out / TIMING_FILE, obj, digits=3)

    def write_npz(self, name: str, **arrays: Any) -> Path:
        """:func:`write_npz` into ``--out``."""
        return write_npz(self.out / name, **arrays)

    def save(self, fig: Any, name: str) -> Path:
        """Save a figure into ``--out`` at the common DPI (:func:`coop_ga.viz.save`)."""
        from .viz import save

        return save(fig, self.out / name)
