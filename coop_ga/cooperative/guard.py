"""The one guard of every compiled entry point of a cooperative task (evaluate, error, J̇q̇, batch).

Each entry point of :class:`~coop_ga.cooperative.graph.TaskGraph` returns
``checks = [ok, w, n2, c2, f]``.  The hot path tests ``ok > warn_below`` only (one float
comparison); otherwise :meth:`TaskGuard.diagnose` says what is wrong, the same way for
every entry point:

1. non-finite or overflowing input → :class:`~coop_ga.errors.NonFiniteError` /
   :class:`~coop_ga.errors.InvalidInputError` naming the argument and the indices;
2. degenerate end points (``w ≤ raise_below``) → :class:`~coop_ga.errors.DegeneratePrimitiveError`;
   nearly degenerate (``w < warn_below``) → :class:`~coop_ga.errors.DegeneracyWarning`;
3. a non-finite result (``f``: overflow or lost precision far from the origin) →
   :class:`~coop_ga.errors.InvalidInputError`, never a NaN;
4. the primitive's axis beyond :data:`~coop_ga.cooperative.graph.CHART_WARN_ANGLE` from the
   chart's reference axis (the half-turn of the minimal-rotation chart) →
   :class:`~coop_ga.errors.ChartWarning`.

Warnings go through :func:`coop_ga.diagnostics.warn` (once per condition and public call,
at the caller's line).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..diagnostics import warn
from ..errors import ChartWarning, DegeneracyWarning, DegeneratePrimitiveError, InvalidInputError, NonFiniteError
from ..geometry.kinds import KIND_SPECS, CooperativeKind
from .graph import CHART_WARN_ANGLE

__all__ = ["TaskGuard"]


@dataclass(frozen=True)
class TaskGuard:
    """Diagnosis of the ``checks`` output of a task's entry points (module docstring)."""

    kind: CooperativeKind
    system_name: str
    end_frames: tuple[str, ...]
    warn_below: float
    raise_below: float
    chart_description: str = "the unit primitive's axis"

    def ok(self, checks: np.ndarray) -> bool:
        """The hot-path test: True when nothing needs a diagnosis."""
        return bool(checks.item(0) > self.warn_below)

    def diagnose(
        self, checks: np.ndarray, points: np.ndarray, inputs: Sequence[tuple[str, np.ndarray]], where: str = ""
    ) -> None:
        """Raise or warn for one evaluation (``checks`` (4,), ``points`` (3n,), the inputs by name)."""
        n2 = checks.item(2)
        if not math.isfinite(n2) or n2 >= 1e300:
            for name, a in inputs:
                a = np.asarray(a, dtype=float).reshape(-1)
                bad = np.flatnonzero(~np.isfinite(a)).tolist()
                if bad:
                    raise NonFiniteError(f"{name}{where} contains NaN or inf at indices {bad}")
            big = max(
                ((name, float(np.max(np.abs(np.asarray(a, dtype=float))))) for name, a in inputs), key=lambda t: t[1]
            )
            raise InvalidInputError(
                f"{big[0]}{where} is too large (max |entry| = {big[1]:.3g}, its squared norm overflows); "
                "joint values must be angles [rad] or lengths [m] of a sensible size"
            )
        w = checks.item(1)
        if not w > self.warn_below:
            self.degeneracy(w, points.reshape(-1, 3), where)
        if not checks.item(4) < 1e300:
            pts = points.reshape(-1, 3)
            raise InvalidInputError(
                f"cooperative {self.kind} of '{self.system_name}'{where}: the result is not finite at this "
                f"configuration (end points up to {float(np.max(np.abs(pts))) if np.all(np.isfinite(pts)) else np.inf:.3g} m "
                "from the origin are beyond what the representation resolves); joint values must be angles [rad] or "
                "lengths [m] of a sensible size"
            )
        c2 = checks.item(3)
        theta = 2.0 * math.acos(min(1.0, math.sqrt(max(c2, 0.0))))
        if theta >= CHART_WARN_ANGLE:
            warn(
                f"cooperative {self.kind} of '{self.system_name}'{where}: its axis is {math.degrees(theta):.1f}° from "
                f"the chart's reference axis ({self.chart_description}), near the antipode where the minimal "
                "rotation of V_Sc jumps by a half-turn; build the task with chart_axis= near the primitive's axis "
                "(task.with_chart(axis)) or reorder the end points (points=...)",
                ChartWarning,
                key=self.system_name,
            )

    def degeneracy(self, w: float, pts: np.ndarray, where: str = "") -> None:
        """Raise (``w ≤ raise_below``) or warn (``w < warn_below``) about degenerate end points (n, 3)."""
        what = KIND_SPECS[self.kind].degeneracy or "degenerate"
        desc = ", ".join(f"{f}={np.round(p, 4).tolist()}" for f, p in zip(self.end_frames, pts))
        if not w > self.raise_below:
            raise DegeneratePrimitiveError(
                f"cooperative {self.kind} of '{self.system_name}'{where} is degenerate: {what} "
                f"(well-definedness {w:.3g} ≤ {self.raise_below:g}); points: {desc}. Move the chains apart "
                "or choose a primitive with fewer points."
            )
        warn(
            f"cooperative {self.kind} of '{self.system_name}'{where} is close to a geometric singularity: {what} "
            f"(well-definedness {w:.3g} < {self.warn_below:g}); the Jacobian is ill-conditioned",
            DegeneracyWarning,
            key=self.system_name,
        )
