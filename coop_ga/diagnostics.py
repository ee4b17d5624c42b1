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

A collector leaves the stack by *identity* (two collectors with the same records are still two
collectors), on the stack it joined, wherever it sits: an exit out of order (an outer block
closed before an inner one, e.g. through a suspended generator) neither raises nor leaves a
stale collector behind that would swallow every later warning of the thread.  A collector
emits when no enclosing collector remains; it then emits for the still-open collectors entered
after it too (they hold a subset of its records), so nothing is emitted twice or lost.
"""

from __future__ import annotations

import sys
import threading
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType, TracebackType

from .errors import InvalidInputError

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


@dataclass(eq=False)  # identity equality: a collector is removed from the stack as itself, not as an equal one
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
    _on: list[collect_warnings] | None = field(default=None, init=False, repr=False)  # the stack it joined

    def _record(self, message: str, category: type[Warning], key: str) -> None:
        r = self._records.get((category, key))
        if r is None:
            r = self._records[(category, key)] = _Record(message, category)
        r.count += 1
        label = category.__name__ + (f":{key}" if key else "")
        self.counts[label] = r.count

    def __enter__(self) -> collect_warnings:
        if self._on is not None:
            raise InvalidInputError(
                "collect_warnings: this collector is already active; open a new collect_warnings() for the inner block"
            )
        self._on = _stack()
        self._on.append(self)
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        stack, self._on = self._on, None
        if stack is None:
            return  # never entered, or already exited
        i = next((i for i in range(len(stack) - 1, -1, -1) if stack[i] is self), None)
        if i is None:
            return  # not on its stack any more (nothing to remove, nothing that could still be lost)
        inner = stack[i + 1 :]  # collectors entered after this one and still open (an out-of-order exit)
        del stack[i]
        if i == 0:  # their records are a subset of this block's: emitted (or dropped) here, counts kept
            for c in inner:
                c._records.clear()
        if i > 0 or not self.emit or self.silent:
            return  # nested: an enclosing collector holds the same records and emits them
        for r in self._records.values():
            msg = r.message if r.count == 1 else f"{r.message} (occurred {r.count} times in this call)"
            _emit(msg, r.category)
