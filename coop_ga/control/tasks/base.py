"""The :class:`Task` protocol: an error e(q), its Jacobian and the QP rows of one control step.

As in mink and pink (``mink/tasks/task.py``, ``pink/tasks/task.py``): a task has an error ``e(q)`` (k,)
that it drives to zero, the Jacobian ``J = ∂e/∂q`` (k, nq), a gain α [1/s] and a weight W (k,), and
asks the step for the first-order task dynamics

    J q̇ = −α e        (in the least-squares sense: the QP cost ½‖W (J q̇ + α e)‖²),

written here on the joint velocity q̇ [rad/s] (mink and pink use Δq = q̇ Δt; the gain is then α Δt).
:meth:`BaseTask.qp_rows` returns ``(A, b) = (W J, −α W e)``; a task may override it (a speed cap on
α e, or a joint-space reference with ``A = None`` meaning the identity).  ``lm_damping`` μ adds the
Levenberg–Marquardt term ``μ ‖W e‖² ‖q̇‖²`` of mink/pink (Sugihara 2011) to the step's damping.
Every task reads the kinematics from the step's :class:`~coop_ga.control.configuration.Configuration`,
so all the tasks and limits of one step share one compiled evaluation.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from ... import validation
from ...errors import InvalidInputError

__all__ = ["BaseTask", "Task"]


@runtime_checkable
class Task(Protocol):
    """What :func:`~coop_ga.control.solve_step` needs of a task (module docstring)."""

    gain: float
    lm_damping: float

    def error(self, configuration: Any) -> np.ndarray:
        """e(q) (k,) at the configuration's q."""
        ...

    def jacobian(self, configuration: Any) -> np.ndarray:
        """∂e/∂q (k, nq) at the configuration's q."""
        ...

    def qp_rows(self, configuration: Any) -> tuple[np.ndarray | None, np.ndarray]:
        """``(A (k, nq) or None for the identity, b (k,))``: the step's cost ½‖A q̇ − b‖²."""
        ...


def check_weight(weight: Any, what: str = "weight") -> np.ndarray | float:
    """A task weight: a positive scalar or a vector of non-negative entries (one per error row)."""
    if weight is None:
        return 1.0
    w = validation.array(weight, what)
    if w.ndim == 0:
        return validation.positive(float(w), what)
    if w.ndim != 1 or np.any(w < 0):
        raise InvalidInputError(f"{what} must be a positive scalar or a vector of non-negative entries, got {weight!r}")
    return w


def row_indices(items: Any, names: tuple[str, ...], noun: str, given: Any) -> tuple[int, ...]:
    """Distinct indices into ``names`` of ``items`` (a sequence of names or indices 0..len(names)−1); ``noun`` names
    one row in the errors (``"line parameter"``, ``"row"``), ``given`` is what the user passed (for the message)."""
    out: list[int] = []
    for c in items:
        if isinstance(c, str):
            if c not in names:
                raise InvalidInputError(f"unknown {noun} {c!r}; the names are {', '.join(names)}")
            out.append(names.index(c))
        else:
            k = validation.integer(c, "component")
            if not 0 <= k < len(names):
                raise InvalidInputError(f"a {noun} index must be in 0..{len(names) - 1} ({', '.join(names)}), got {k}")
            out.append(k)
    if len(set(out)) != len(out):
        raise InvalidInputError(f"components must be distinct, got {list(given)}")
    return tuple(out)


class BaseTask:
    """Shared fields and the default QP rows of the tasks of :mod:`coop_ga.control.tasks`.

    Args:
        gain: α [1/s] (≥ 0) of ``J q̇ = −α e``.
        weight: W, a positive scalar or (k,) non-negative per-row weights (default 1).
        lm_damping: μ ≥ 0 of the Levenberg–Marquardt term (default 0).
        name: for messages (default: the class name).
    """

    labels: tuple[str, ...] = ()

    def __init__(self, gain: float, weight: Any = None, lm_damping: float = 0.0, name: str = ""):
        self.gain = validation.nonnegative(gain, "gain")
        self.weight = check_weight(weight)
        self.lm_damping = validation.nonnegative(lm_damping, "lm_damping")
        self.name = name or type(self).__name__

    def error(self, configuration: Any) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def jacobian(self, configuration: Any) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def velocity(self, configuration: Any) -> np.ndarray:
        """The commanded task velocity ``−α e`` (k,) (a subclass may cap it)."""
        return -self.gain * self.error(configuration)

    def qp_rows(self, configuration: Any) -> tuple[np.ndarray | None, np.ndarray]:
        """``(W J, W (−α e))`` (module docstring)."""
        J = self.jacobian(configuration)
        v = self.velocity(configuration)
        w = self.weight
        if isinstance(w, float) and w == 1.0:
            return J, v
        wv = np.broadcast_to(w, v.shape)
        return wv[:, None] * J, wv * v

    def lm_term(self, configuration: Any) -> float:
        """μ ‖W e‖² (0 without Levenberg–Marquardt damping), added to λ² of the step."""
        if self.lm_damping == 0.0:
            return 0.0
        we = np.broadcast_to(self.weight, (self.error(configuration).shape[0],)) * self.error(configuration)
        return self.lm_damping * float(we @ we)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(gain={self.gain:g}, name={self.name!r})"
