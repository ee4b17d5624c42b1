"""Summaries of sweep records: success rates and quantiles grouped by any field, a text table, a figure.

Rates follow the robustness study: a ``skipped`` job (the case cannot run, or the target was not certified)
enters no rate; a ``failed`` job (an exception) counts as not converged.  Iterations and times are over the
``ok`` runs (converged or not).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError

__all__ = ["QUANTILES", "format_table", "plot", "summarize"]

QUANTILES = (0.5, 0.9, 1.0)  # median, 90 %, max
FIELDS = ("iterations", "seconds")


def _group_value(v: Any) -> Any:
    """A hashable group key: lists and dicts as canonical JSON (``repr`` if they hold anything else)."""
    if isinstance(v, (list, dict)):
        try:
            return json.dumps(v, sort_keys=True)
        except (TypeError, ValueError):
            return repr(v)
    try:
        hash(v)
    except TypeError:
        return repr(v)
    return v


def _names(x: Any, what: str) -> list[str]:
    """Record field names: one string or a non-empty sequence of strings."""
    names = [x] if isinstance(x, str) else x
    if isinstance(names, (bytes, Mapping)) or not isinstance(names, Sequence) or not names:
        raise InvalidInputError(f"{what} must be a record field name or a non-empty list of them, got {x!r}"[:200])
    for n in names:
        if not isinstance(n, str):
            raise InvalidInputError(f"{what} must hold record field names (strings), got {n!r}"[:200])
    return list(names)


def _q(xs: Sequence[float], q: float) -> float | None:
    """The q-quantile (linear interpolation) of finite values; the nearest value where interpolating overflows."""
    if not len(xs):
        return None
    a = np.asarray(xs, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        v = float(np.quantile(a, q))
    return v if math.isfinite(v) else float(np.quantile(a, q, method="nearest"))


def summarize(
    records: Sequence[Mapping[str, Any]],
    by: Sequence[str] | str = ("controller",),
    quantiles: Sequence[float] = QUANTILES,
    fields: Sequence[str] = FIELDS,
) -> list[dict[str, Any]]:
    """One row per group of ``by`` (record field names, in first-seen order).

    Row: the group's values, ``jobs``, ``runs`` (not skipped), ``skipped``, ``failed`` (not ok: an exception, a
    dead worker or a timeout), ``timeouts``, ``converged``, ``success_rate`` (converged / runs; None without
    runs), ``outside_limits`` (ok runs with ``violation`` > 1e-6), and ``<field>_q<p>`` for each of ``fields``
    (default ``iterations`` and ``seconds`` [s]) and each quantile p in percent (``q50``, ``q90``, ``q100`` = max)
    over the ok runs where the field is a finite number (None if there is none).

    Raises:
        InvalidInputError: ``records`` not a sequence of mappings, ``by``/``fields`` not field names,
            ``quantiles`` not numbers in [0, 1].
    """
    keys = _names(by, "by")
    fields = _names(fields, "fields")
    if isinstance(records, (str, bytes, Mapping)) or not isinstance(records, Sequence):
        raise InvalidInputError(f"records must be a list of record dicts, got {type(records).__name__}")
    for r in records:
        if not isinstance(r, Mapping):
            raise InvalidInputError(f"records must be a list of record dicts, got an element {str(r)[:80]}")
    if isinstance(quantiles, (str, bytes)) or not isinstance(quantiles, Sequence):
        raise InvalidInputError(f"quantiles must be a list of numbers in [0, 1], got {quantiles!r}")
    quantiles = [validation.scalar(q, "quantiles entry", low=0.0, high=1.0) for q in quantiles]
    groups: dict[tuple[Any, ...], list[Mapping[str, Any]]] = {}
    for r in records:
        groups.setdefault(tuple(_group_value(r.get(k)) for k in keys), []).append(r)
    rows = []
    for gk, rs in groups.items():
        runs = [r for r in rs if r.get("status") != "skipped"]
        ok = [r for r in runs if r.get("status") == "ok"]
        conv = [r for r in runs if r.get("converged")]
        row: dict[str, Any] = dict(zip(keys, gk))
        row.update(
            jobs=len(rs),
            runs=len(runs),
            skipped=len(rs) - len(runs),
            failed=len(runs) - len(ok),
            timeouts=sum(r.get("status") == "timeout" for r in runs),
            converged=len(conv),
            success_rate=len(conv) / len(runs) if runs else None,
            outside_limits=sum((r.get("violation") or 0.0) > 1e-6 for r in ok),
        )
        for f in fields:
            xs = [float(r[f]) for r in ok if isinstance(r.get(f), (int, float)) and math.isfinite(r[f])]
            for q in quantiles:
                row[f"{f}_q{round(100 * q)}"] = _q(xs, q)
        rows.append(row)
    return rows


def _fmt(k: str, v: Any) -> str:
    if v is None:
        return "-"
    if k == "success_rate":
        return f"{100 * v:.1f} %"
    if k.startswith("seconds_"):
        return f"{1e3 * v:.1f}"
    if k.startswith("iterations_"):
        return f"{v:.0f}" if float(v).is_integer() else f"{v:.1f}"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def format_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """A plain-text table of :func:`summarize` rows (times in ms).

    Raises:
        InvalidInputError: ``rows`` not a sequence of mappings.
    """
    if (
        isinstance(rows, (str, bytes, Mapping))
        or not isinstance(rows, Sequence)
        or not all(isinstance(r, Mapping) for r in rows)
    ):
        raise InvalidInputError(f"rows must be a list of summarize() rows (dicts), got {str(rows)[:80]}")
    if not rows:
        return "(no records)"
    cols = list(rows[0])
    head = [c.replace("seconds_", "ms_").replace("iterations_", "it_") for c in cols]
    cells = [[_fmt(c, r.get(c)) for c in cols] for r in rows]
    w = [max(len(h), *(len(x[i]) for x in cells)) for i, h in enumerate(head)]
    lines = ["  ".join(h.rjust(w[i]) for i, h in enumerate(head)), "  ".join("-" * x for x in w)]
    lines += ["  ".join(x[i].rjust(w[i]) for i in range(len(cols))) for x in cells]
    return "\n".join(lines)


def plot(
    records: Sequence[Mapping[str, Any]],
    path: str | Path,
    by: Sequence[str] | str = ("controller",),
    title: str = "",
    field: str = "iterations",
) -> Path:
    """Success rate per group (bars, with the runs counted) and histograms of ``field`` (default the iterations)
    per group over the ok runs → a PNG at ``path``.

    Drawn with matplotlib's Agg canvas (headless, no pyplot state).

    Raises:
        InvalidInputError: as :func:`summarize`; ``path`` not a path, ``title``/``field`` not strings.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise InvalidInputError(f"path must be a file path for the PNG, got {type(path).__name__}")
    if not isinstance(title, str) or not isinstance(field, str):
        raise InvalidInputError(f"title and field must be strings, got {title!r}, {field!r}"[:200])
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    keys = _names(by, "by")
    rows = summarize(records, keys)
    labels = [" / ".join(str(r[k]) for k in keys) for r in rows]
    fig = Figure(figsize=(11, 4.2), dpi=110)
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1, 1.3]})
    rates = [100 * (r["success_rate"] or 0.0) for r in rows]
    y = np.arange(len(rows))
    ax1.barh(y, rates, color="#4c72b0")
    for yi, r, rate in zip(y, rows, rates):
        ax1.text(min(rate, 100) + 1, yi, f"{rate:.1f} % of {r['runs']}", va="center", fontsize=8)
    ax1.set_yticks(y, labels, fontsize=8)
    ax1.invert_yaxis()
    ax1.set_xlim(0, 125)
    ax1.set_xlabel("converged [% of runs]")
    ax1.set_title("success rate")
    groups: dict[str, list[float]] = {lab: [] for lab in labels}
    for rec in records:
        if rec.get("status") == "ok" and isinstance(rec.get(field), (int, float)) and math.isfinite(rec[field]):
            lab = " / ".join(str(_group_value(rec.get(k))) for k in keys)
            groups.setdefault(lab, []).append(float(rec[field]))
    allit = [x for v in groups.values() for x in v]
    if allit:
        hi = max(allit)
        integer = all(float(x).is_integer() for x in allit)
        bins = np.arange(-0.5, hi + 1.5, 1.0) if integer and hi <= 60 else np.linspace(min(allit), hi + 1e-12, 41)
        for lab, v in groups.items():
            if v:
                ax2.hist(v, bins=bins, histtype="step", linewidth=1.4, label=f"{lab} (n={len(v)})")
        ax2.legend(fontsize=7)
    ax2.set_xlabel("iterations (controller's count)" if field == "iterations" else field)
    ax2.set_ylabel("runs")
    ax2.set_title(field)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p)
    return p
