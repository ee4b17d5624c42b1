"""Tiny timing helper shared by the benchmarks (best-of-repeats, per-call microseconds)."""

from __future__ import annotations

import timeit
from collections.abc import Callable


def per_call_us(fn: Callable[[], object], min_time: float = 0.2, repeat: int = 5) -> float:
    """Best per-call time in µs over ``repeat`` runs of at least ``min_time`` seconds each."""
    timer = timeit.Timer(fn)
    n, _ = timer.autorange()
    n = max(1, int(n * min_time / 0.2))
    return min(timer.repeat(repeat=repeat, number=n)) / n * 1e6


def print_table(title: str, header: list[str], rows: list[list[str]]) -> None:
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    print(f"\n{title}")
    print("  ".join(h.ljust(w) for h, w in zip(header, widths)))
    print("  ".join("-" * w for w in widths))
    for r in rows:
        print("  ".join(str(c).ljust(w) for c, w in zip(r, widths)))
