"""How coop_ga warns: once per condition and public call, pointing at the caller's line.

A controller that evaluates a task 500 times near a singularity must not print 500
:class:`~coop_ga.errors.DegeneracyWarning`\\ s.  Every warning inside the library goes
through :func:`warn`; a public function that loops wraps its body in
:class:`collect_warnings`, which

* records every warning raised inside it, keyed by its *condition* (the warning class
  plus an optional key, e.g. the system name), with a count;
* emits each distinct condition **once** when the block ends — the first message, with
  "(occurred N times in this call)" appended when N > 1;
* points the emitted warning at the first stack frame outside the coop_ga package (the
  user's line), whatever the call depth (``stacklevel`` is computed, not guessed);
* exposes the counts (``collector.counts``: ``{"DegeneracyWarning": 104, ...}``) so that
  results can record how often each condition occurred.

Nested collectors forward their records to the outermost one, so a public function
that calls another public function still warns once (a ``silent`` collector swallows
instead).  Collectors are per thread.
Outside any collector, :func:`warn` emits immediately (with the user-facing stacklevel).
"""

from __future__ import annotations

import sys
import threading
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType, TracebackType

__all__ = ["collect_warnings", "user_stacklevel", "warn"]

_PKG_DIR = str(Path(__file__).resolve().parent)
_local = threading.local()


def _stack() -> list[collect_warnings]:
    s = getattr(_local, "stack", None)
    if s is None:
        s = _local.stack = []
    return s


def user_stacklevel() -> int:
    """``stacklevel`` for a ``warnings.warn`` call made by the *caller* of this function that
    attributes the warning to the first frame outside the coop_ga package."""
    frame: FrameType | None = sys._getframe(1)  # the function that will call warnings.warn
    level = 1
    while frame is not None and frame.f_code.co_filename.startswith(_PKG_DIR):
        frame = frame.f_back
        level += 1
    return level


def _emit(message: str, category: type[Warning]) -> None:
    # user_stacklevel() counts from _emit's frame; warnings.warn's stacklevel=1 is _emit itself
    warnings.warn(message, category, stacklevel=user_stacklevel())


def warn(message: str, category: type[Warning], *, key: str = "") -> None:
    """Warn about a condition (``category`` + ``key``): recorded by the active
    :class:`collect_warnings` block of this thread, or emitted now if there is none."""
    stack = _stack()
    if stack:
        for c in reversed(stack):  # innermost first; every collector counts it, the outermost emits
            c._record(message, category, key)
            if c.silent:
                return  # a silent collector swallows: nothing reaches the collectors outside it
    else:
        _emit(message, category)


@dataclass
class _Record:
    message: str
    category: type[Warning]
    count: int = 0


@dataclass
class collect_warnings:
    """Context manager: deduplicate coop_ga warnings raised inside the block (module docstring).

    ``counts`` maps a condition label (the warning class name, plus ``:key`` when a key
    was given) to the number of times it occurred.  With ``emit=False`` nothing is
    emitted at the end (the caller reports the counts itself).  With ``silent=True`` the
    block swallows its warnings: they are counted here but neither emitted nor passed to
    enclosing collectors (e.g. for the trial points of a line search).
    """

    emit: bool = True
    silent: bool = False
    _records: dict[tuple[type[Warning], str], _Record] = field(default_factory=dict, repr=False)
    counts: dict[str, int] = field(default_factory=dict)

    def _record(self, message: str, category: type[Warning], key: str) -> None:
        r = self._records.get((category, key))
        if r is None:
            r = self._records[(category, key)] = _Record(message, category)
        r.count += 1
        label = category.__name__ + (f":{key}" if key else "")
        self.counts[label] = r.count

    def __enter__(self) -> collect_warnings:
        _stack().append(self)
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        stack = _stack()
        stack.remove(self)
        if stack or not self.emit or self.silent:
            return  # nested: the outermost collector holds the same records and emits them
        for r in self._records.values():
            msg = r.message if r.count == 1 else f"{r.message} (occurred {r.count} times in this call)"
            _emit(msg, r.category)
