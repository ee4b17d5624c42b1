"""End-point tasks: a position, and the parameters of the line through two end points (§4.2.5, §4.3).

* :class:`PositionTask` — end point i at p* [m] (world frame): ``e = p_i(q) − p*`` (3,),
  ``J = J_{p,i}`` (3, nq) [m/rad] (the Euclidean part of Eq 17).  ``form='task'`` gives the QP rows
  ``(J_{p,i}, v)`` with ``v = −α e`` capped at ``max_speed`` [m/s]; ``form='joint'`` the joint-space
  reference ``(I, J_{p,i}⁺ v)`` (damped pseudo-inverse, only the chain's own columns are non-zero): the
  secondary velocity ``q̇_{i,d}`` of Eq 60 and Figs. 16–17, tracked as ``½‖q̇ − q̇_{i,d}‖²``.
* :class:`LineParameterTask` — components of the unit line parameters of the first two end points
  (:func:`line_from_points`): direction ``d = (p_2 − p_1)/ℓ`` and moment ``m = p_1 × d`` (Plücker
  coordinates), the coefficients of X_c = P_1 ∧ P_2 ∧ e∞ (Eq 14) over ℓ; ``d_z = 0`` keeps the
  line horizontal (Fig. 15).  Used as an equality (``solve_step(..., equality=[...])``).

Both read the end points and their Jacobians from the step's one compiled evaluation.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ... import validation
from ...cooperative.manipulability import damped_pinv
from ...errors import DegeneratePrimitiveError, InvalidInputError
from ...geometry.kinds import KIND_SPECS
from .base import BaseTask, row_indices

__all__ = ["LINE_PARAMETERS", "LineParameterTask", "PositionTask", "line_from_points"]

#: names of the six unit line parameters: direction d, moment m = p_1 × d
LINE_PARAMETERS = ("d_x", "d_y", "d_z", "m_x", "m_y", "m_z")


def end_index(model: Any, index: Any) -> int:
    """``index`` checked as an end point of the model (0 ≤ index < n)."""
    n = len(model.end_frames)
    i = validation.integer(index, "index")
    if not 0 <= i < n:
        raise InvalidInputError(
            f"index must be an end point of the task, 0 ≤ index < {n} ({', '.join(model.end_frames)}); got {index!r}"
        )
    return i


def capped(v: np.ndarray, max_speed: float | None) -> np.ndarray:
    """v scaled down to the norm ``max_speed`` when it is longer (None: no cap)."""
    if max_speed is not None:
        s = float(np.linalg.norm(v))
        if s > max_speed:
            v = v * (max_speed / s)
    return v


class PositionTask(BaseTask):
    """End point ``index`` of the model reaches ``point`` (3,) [m] (module docstring).

    Args:
        index: the end point (0 ≤ index < n).  point: p* (3,) [m], world frame.
        gain: α [1/s].  max_speed: cap on ‖α e‖ [m/s] (None: none).
        form: ``'task'`` (rows J_p, v) or ``'joint'`` (rows I, J_p⁺ v: Eq 60's secondary velocity).
        damping: λ of the pseudo-inverse of the ``'joint'`` form.
        weight: as :class:`~coop_ga.control.tasks.BaseTask`.
        lm_damping: as :class:`~coop_ga.control.tasks.BaseTask`.
    """

    def __init__(
        self,
        index: int,
        point: Any,
        *,
        gain: float = 5.0,
        max_speed: float | None = 0.2,
        form: str = "task",
        damping: float = 1e-3,
        weight: Any = None,
        lm_damping: float = 0.0,
    ):
        super().__init__(gain, weight, lm_damping, f"end point {index} position")
        self.index = validation.integer(index, "index", minimum=0)
        self.target = validation.vector(point, 3, "point [m]")
        self.max_speed = None if max_speed is None else validation.positive(max_speed, "max_speed", allow_inf=True)
        self.form = validation.choice(form, ("task", "joint"), "form")
        self.damping = validation.nonnegative(damping, "damping")
        self.labels = tuple(f"{self.name} {a}" for a in "xyz")

    def value(self, configuration: Any) -> np.ndarray:
        """p_i(q) (3,) [m]."""
        return configuration.kinematics().points[self.index]

    def error(self, configuration: Any) -> np.ndarray:
        return self.value(configuration) - self.target

    def jacobian(self, configuration: Any) -> np.ndarray:
        i = self.index
        return configuration.kinematics().point_jacobians[3 * i : 3 * i + 3]

    def velocity(self, configuration: Any) -> np.ndarray:
        """``α (p* − p_i)`` capped at max_speed (3,) [m/s]."""
        return capped(self.gain * (self.target - self.value(configuration)), self.max_speed)

    def qp_rows(self, configuration: Any) -> tuple[np.ndarray | None, np.ndarray]:
        if self.form == "joint":
            return None, damped_pinv(self.jacobian(configuration), self.damping) @ self.velocity(configuration)
        return super().qp_rows(configuration)


def _cross_matrix(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def line_from_points(
    P: np.ndarray, J: np.ndarray, frames: Sequence[str] = ("p1", "p2"), name: str = ""
) -> tuple[np.ndarray, np.ndarray]:
    """Unit line parameters ``[d; m]`` (6,) of the line through P[0], P[1] (3,) [m] and their Jacobian (6, nq).

    ``J`` holds the two world point Jacobians (2, 3, nq) [m/rad].  Rows: ``∂d/∂q = (I − d dᵀ)(J_2 − J_1)/ℓ``
    [1/rad], ``∂m/∂q = −[d]_× J_1 + [p_1]_× ∂d/∂q`` [m/rad].  Coincident points (ℓ ≤ 1e-9 m) raise
    :class:`~coop_ga.errors.DegeneratePrimitiveError`.
    """
    delta = P[1] - P[0]
    ell = float(np.linalg.norm(delta))
    if not ell > 1e-9:
        raise DegeneratePrimitiveError(
            f"the end points {frames[0]} and {frames[1]}{f' of task {name!r}' if name else ''} coincide "
            f"(distance {ell:.3g} m): the line has no direction"
        )
    d = delta / ell
    m = np.cross(P[0], d)
    Jd = (np.eye(3) - np.outer(d, d)) @ (J[1] - J[0]) / ell
    Jm = -_cross_matrix(d) @ J[0] + _cross_matrix(P[0]) @ Jd
    return np.concatenate([d, m]), np.vstack([Jd, Jm])


def check_line_model(model: Any) -> None:
    """Line parameters need a model whose primitive has a direction and is spanned by its two end points (a
    ``'line'`` or ``'point_pair'``; not a ``'line_fit'``, whose line is not the one through its first two points)."""
    spec = KIND_SPECS.get(model.kind)
    if spec is None or spec.axis_role != "direction" or spec.least_squares:
        raise InvalidInputError(
            f"line parameters are defined for tasks of kind 'line' or 'point_pair', got a '{model.kind}' task "
            f"({model.name})"
        )


def line_components(components: Any) -> tuple[int, ...]:
    """Indices 0..5 of the named or numbered line parameters (distinct, non-empty)."""
    if isinstance(components, (str, int, np.integer)):
        components = (components,)
    if not isinstance(components, Sequence) or not components:
        raise InvalidInputError(f"components must be a non-empty sequence of {LINE_PARAMETERS} names or indices")
    return row_indices(components, LINE_PARAMETERS, "line parameter", components)


class LineParameterTask(BaseTask):
    """Components of the unit line parameters held at ``value`` (module docstring; Fig. 15: ``d_z = 0``).

    Args:
        model: the :class:`~coop_ga.CooperativeTask` (a ``'line'`` or ``'point_pair'``; its first two end points).
        components: names from :data:`LINE_PARAMETERS` or indices 0..5.
        value: (k,) or a scalar for one component [1 for d, m for m].
        gain: α [1/s] (the constraint feedback k_c when used as an equality).  name: label.
    """

    def __init__(self, model: Any, components: Any, value: Any, *, gain: float = 10.0, name: str | None = None):
        check_line_model(model)
        self.rows = list(line_components(components))
        target = np.atleast_1d(validation.array(value, "value"))
        if target.shape != (len(self.rows),):
            raise InvalidInputError(
                f"value must have one entry per component ({len(self.rows)}), got shape {target.shape}"
            )
        names = tuple(LINE_PARAMETERS[k] for k in self.rows)
        super().__init__(gain, None, 0.0, name or f"line {', '.join(names)}")
        self.model = model
        self.target = target
        self.labels = names

    def parameters(self, configuration: Any) -> tuple[np.ndarray, np.ndarray]:
        """All six parameters (6,) and their Jacobian (6, nq) at the configuration (cached per q)."""

        def compute(c: Any) -> tuple[np.ndarray, np.ndarray]:
            k = c.kinematics()
            J = k.point_jacobians[:6].reshape(2, 3, -1)
            return line_from_points(k.points[:2], J, self.model.end_frames, self.model.name)

        return configuration.cached(("line parameters", id(self.model)), compute)

    def value(self, configuration: Any) -> np.ndarray:
        return self.parameters(configuration)[0][self.rows]

    def error(self, configuration: Any) -> np.ndarray:
        return self.value(configuration) - self.target

    def jacobian(self, configuration: Any) -> np.ndarray:
        return self.parameters(configuration)[1][self.rows]
