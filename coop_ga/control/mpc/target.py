"""The time-varying target V_d(t) of the receding-horizon controller: a callable or a sampled reference."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ...errors import InvalidInputError, InvalidVersorError, NonFiniteError
from ...geometry.groups import Similarity

__all__ = ["TargetSchedule"]


class TargetSchedule:
    """V_d(t): ``target(t) -> Similarity`` (a callable), or a reference ``(times (m,) [s], poses (m,))`` such as
    the first two outputs of :func:`coop_ga.geometry.reference_trajectory` (screw interpolation between the
    samples, held before the first and after the last).

    Every value is checked: anything that is not a :class:`~coop_ga.Similarity` (or a Motor) raises
    :class:`~coop_ga.errors.InvalidInputError`, a non-finite one :class:`~coop_ga.errors.NonFiniteError`, a pose
    the task's chart cannot take :class:`~coop_ga.errors.ChartError` — each naming the time.
    """

    def __init__(self, target: Any, task: Any):
        self.task = task
        self._fn: Callable[[float], Any]
        if callable(target):
            self._fn = target
        elif isinstance(target, (tuple, list)) and len(target) >= 2:
            self._times = np.asarray(target[0], dtype=float).reshape(-1)
            self._poses: Sequence[Any] = list(target[1])
            if self._times.size < 1 or self._times.size != len(self._poses):
                raise InvalidInputError("a reference target needs as many times as poses (times (m,), poses (m,))")
            if np.any(np.diff(self._times) <= 0) or not np.all(np.isfinite(self._times)):
                raise InvalidInputError("the reference's times must be finite and increasing")
            self._fn = self._sampled
        else:
            raise InvalidInputError(
                "target must be a callable t -> Similarity or a reference (times, poses), e.g. the first two outputs "
                "of coop_ga.geometry.reference_trajectory"
            )

    def _sampled(self, t: float) -> Any:
        from ...geometry.interpolation import interpolate

        ts = self._times
        if t <= ts[0]:
            return self._poses[0]
        if t >= ts[-1]:
            return self._poses[-1]
        k = int(np.searchsorted(ts, t, side="right")) - 1
        return interpolate(self._poses[k], self._poses[k + 1], float((t - ts[k]) / (ts[k + 1] - ts[k])))

    def __call__(self, t: float) -> Similarity:
        """The checked V_d(t)."""
        V = self._fn(float(t))
        where = f"the target at t = {t:.4f} s"
        if hasattr(V, "as_similarity") and not isinstance(V, Similarity):
            V = V.as_similarity()  # a Motor is a rigid similarity
        if not isinstance(V, Similarity):
            raise InvalidInputError(
                f"{where} is a {type(V).__name__}, not a coop_ga.Similarity; return e.g. "
                "task.target_from_primitive(X) or coop_ga.sim.circle_target(centre, radius)"
            )
        if not np.all(np.isfinite(V.coeffs)):
            raise NonFiniteError(f"{where} has NaN/inf coefficients {np.round(V.coeffs, 4).tolist()}")
        try:
            return self.task.check_target(V, where)
        except InvalidVersorError as exc:  # a Similarity built unchecked around numbers that are no versor
            raise InvalidVersorError(f"{where} is not a similarity versor: {exc}") from None
