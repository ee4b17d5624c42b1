"""The cooperative dual task space of two end frames: relative and absolute motors, their Jacobians, a task.

For two frames with world motors M_1(q), M_2(q) (``oMf``, :meth:`~coop_ga.kinematics.KinematicTree.frame_motors`)
the cooperative dual task space (Adorno, Fraisse & Druon, IROS 2010; DQ Robotics'
``DQ_CooperativeDualTaskSpace``; gafro's ``DualManipulator`` of Löw & Calinon) describes the pair by

* the **relative motor** ``M_r = M̃_2 M_1`` — frame 1 seen from frame 2 (the literature's order: DQ Robotics
  ``conj(x_2) x_1``, gafro ``getRelativeMotor``);
* the **absolute motor** ``M_a = M_2 exp(½ log M_r)`` — half-way from frame 2 to frame 1.

With coop_ga's exp and log (the canonical decomposition ``exp(b) = V_T V_R``, :mod:`coop_ga.geometry.groups`,
as gafro's ``Motor::log``) ``exp(½ log M_r)`` translates by half of M_r's translation and turns by half of its
rotation, so M_a sits at the **midpoint** ``½(p_1 + p_2)`` of the two end points with the geodesic mean
``R_2 (R_2ᵀ R_1)^½`` of their orientations; swapping the frames gives the same motor
(``M_1 exp(½ log(M̃_1 M_2)) = M_a``).  DQ Robotics' ``pow(x_r, 0.5)`` uses the screw logarithm instead,
which has the same rotation but a translation off the midpoint when the frames are turned.  The half-way
rotation is discontinuous where the relative rotation passes π (the shortest rotation changes side):
:attr:`DualState.relative_angle` says how far a configuration is from it.

Jacobians (rows ``[e12, e13, e23, e1∞, e2∞, e3∞]``, the motor slots of :data:`~coop_ga.geometry.groups.TANGENT_BASIS`,
[1/s] per rad/s; the translation rows in [m/s] per rad/s):

* the **body Jacobian** of a motor M(q): column j is ``−2 M̃ ∂M/∂q_j`` (Eq 8, as for one chain); for the
  relative motor it is ``J_1 − Ad(M̃_r) J_2`` with J_i the body Jacobians of the frames;
* the **error** of a target M*: ``e = −log(M̃(q) M*)`` (zero at the target; the step's ``J q̇ = −α e``
  commands the body velocity ``α log(M̃ M*)``, as :class:`~coop_ga.control.tasks.SimilarityTask` does for
  Eq 48) and its exact Jacobian ``∂e/∂q``.

Everything is one CasADi graph of the motor kinematics (:class:`~coop_ga.kinematics.KinematicTree` on SX),
differentiated exactly and compiled once per system, frame pair and motor
(:class:`~coop_ga.codegen.CompiledFunction`).  Its rotation rows hold the relative *orientation* of two grippers,
which a point pair or a line (:class:`~coop_ga.control.tasks.SimilarityTask`) cannot: stack a
:class:`DualTask` with ``components='orientation'`` and a similarity task in one
:func:`~coop_ga.control.solve_step`.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ... import validation
from ...algebra.multivector import Multivector
from ...errors import InvalidInputError
from ...geometry.groups import (
    MOTOR_BLADES,
    Motor,
    VersorGroup,
    bivector_to_tangent,
    exp,
    log,
)
from ...kinematics.chains import KinematicTree, at_zero_velocity, motor_from_se3
from .base import BaseTask, row_indices

__all__ = ["DUAL_COMPONENTS", "DUAL_ROWS", "DualState", "DualTask", "DualTaskSpace"]

#: the rows of a motor error and of a motor's body Jacobian (the motor slots of the similarity tangent)
DUAL_ROWS = ("e12", "e13", "e23", "e1∞", "e2∞", "e3∞")

#: row groups by name: the rotation rows, the translation rows, all six
DUAL_COMPONENTS = {"orientation": (0, 1, 2), "position": (3, 4, 5), "pose": (0, 1, 2, 3, 4, 5)}

_MOTORS = ("relative", "absolute")
_MOTOR_SLOTS = (0, 1, 2, 4, 5, 6)  # of the 7-vector [θ12, θ13, θ23, β, t1, t2, t3]
_NM = len(MOTOR_BLADES)


class DualState(NamedTuple):
    """The dual task space at one q (copies).

    first, second: M_1, M_2, the frames' world motors.  relative: M_r = M̃_2 M_1.  absolute: M_a.
    relative_jacobian, absolute_jacobian: (6, nq) body Jacobians (module docstring).
    relative_angle: the rotation angle of M_r [rad] in [0, π] (the absolute motor jumps at π).
    """

    first: Motor
    second: Motor
    relative: Motor
    absolute: Motor
    relative_jacobian: np.ndarray
    absolute_jacobian: np.ndarray
    relative_angle: float


def _motor_expr(v: Any) -> Multivector:
    return Multivector(MOTOR_BLADES, tuple(v[i] for i in range(_NM)))


def _motor_coeffs(M: Multivector) -> Any:
    import casadi as ca

    return ca.vertcat(*[M.get(k) for k in MOTOR_BLADES])


def _half(M: Multivector) -> Multivector:
    """``exp(½ log M)`` of a motor (module docstring), on the motor blades."""
    b = log(M)
    return exp([0.5 * b[i] for i in range(7)]).project(MOTOR_BLADES)


def _as_motor(x: Any, what: str = "target") -> Motor:
    """A :class:`~coop_ga.Motor` from a Motor, a rigid versor group element or Multivector, a
    ``pinocchio.SE3`` or 8 coefficients on :data:`~coop_ga.geometry.groups.MOTOR_BLADES`."""
    if isinstance(x, Motor):
        return x
    if isinstance(x, VersorGroup):
        x = x.versor
    if isinstance(x, Multivector):
        return Motor(x)
    if hasattr(x, "rotation") and hasattr(x, "translation"):
        return Motor(motor_from_se3(x))
    try:
        return Motor.from_coeffs(x)
    except InvalidInputError as exc:
        raise InvalidInputError(f"{what} must be a Motor, a pinocchio.SE3 or {_NM} motor coefficients: {exc}") from None


class DualTaskSpace:
    """Relative and absolute motors of two frames of a system, with their Jacobians (module docstring).

    Args:
        model: a :class:`~coop_ga.CooperativeTask` (its system, and the configuration's model when the
            tasks are stacked with its similarity task) or a :class:`~coop_ga.systems.System`.
        frames: the two frames: indices into ``model.end_frames`` or frame names of the system's Pinocchio
            model (default: the first two end frames).
        codegen: compile to C (``'auto'``: when gcc is available; default: the model's setting).

    Raises:
        InvalidInputError: not two distinct frames; UnknownNameError: a frame the model does not have.
    """

    def __init__(self, model: Any, frames: Sequence[Any] = (0, 1), *, codegen: bool | str | None = None):
        system = getattr(model, "system", model)
        end_frames = tuple(getattr(model, "end_frames", ()))
        if isinstance(frames, (str, bytes)) or not isinstance(frames, Sequence) or len(frames) != 2:
            raise InvalidInputError(f"frames must be two frames (indices into end_frames or names), got {frames!r}")
        names = tuple(self._frame_name(f, end_frames) for f in frames)
        if names[0] == names[1]:
            raise InvalidInputError(f"the two frames of a dual task space must differ, got {names[0]!r} twice")
        self.system = system
        self.frames = names
        self.tree = KinematicTree(system.model, names)
        self.nq = int(system.model.nq)
        #: number of velocities (Jacobian columns): nq, or nq − 1 per free flyer
        self.nv = int(system.model.nv)
        self.codegen = getattr(model, "codegen", "auto") if codegen is None else codegen
        self.name = f"{getattr(system, 'name', 'custom')}_dual_{names[0]}_{names[1]}"
        self._functions: dict[str, Any] = {}  # the compiled motors, built on first use

    @staticmethod
    def _frame_name(f: Any, end_frames: tuple[str, ...]) -> str:
        if isinstance(f, str):
            return f
        i = validation.integer(f, "frame index")
        if not 0 <= i < len(end_frames):
            raise InvalidInputError(
                f"frame index {i} is not an end frame of the model (0 ≤ index < {len(end_frames)}: "
                f"{', '.join(end_frames) or 'none'}); give the frame's name instead"
            )
        return end_frames[i]

    def __repr__(self) -> str:
        return f"DualTaskSpace({self.frames[0]!r}, {self.frames[1]!r}, nq={self.nq})"

    # ------------------------------------------------------------------ symbolic graph
    def symbolic(self, q: Any) -> dict[str, Multivector]:
        """``{'first', 'second', 'relative', 'absolute'}`` motors of a CasADi SX q (nq,)."""
        M1, M2 = self.tree.frame_motors(q)
        Mr = (M2.reverse() * M1).project(MOTOR_BLADES)
        Ma = (M2 * _half(Mr)).project(MOTOR_BLADES)
        return {"first": M1, "second": M2, "relative": Mr, "absolute": Ma}

    def _function(self, which: str) -> Any:
        """Compiled ``(q, M*) → (M_1, M_2, M, J_body, e, ∂e/∂q)`` for the ``which`` motor (built once)."""
        cache = self._functions
        key = f"{which}:{self.name}:{self.frames[0]}:{self.frames[1]}:{self.codegen}"
        cf = cache.get(key)
        if cf is None:
            import casadi as ca

            from ...codegen import CompiledFunction

            q = ca.SX.sym("q", self.nq)
            target = ca.SX.sym("M", _NM)
            m = self.symbolic(q)
            M = m[which]
            c = _motor_coeffs(M)
            dM = self._tangent_jacobian(lambda qq: _motor_coeffs(self.symbolic(qq)[which]), q)
            Mrev = M.reverse()
            cols = []
            for j in range(self.nv):
                b = bivector_to_tangent((Mrev * _motor_expr(dM[:, j])).grade(2).scale(-2.0))
                cols.append(ca.vertcat(*[b[i] for i in _MOTOR_SLOTS]))
            J = ca.horzcat(*cols)
            lg = log((Mrev * _motor_expr(target)).project(MOTOR_BLADES))
            e = -ca.vertcat(*[lg[i] for i in _MOTOR_SLOTS])
            E = self._tangent_jacobian(lambda qq: self._error_expr(self.symbolic(qq)[which], target), q, target)
            f = ca.Function(
                f"coop_dual_{which}_{hashlib.sha1(key.encode()).hexdigest()[:12]}",
                [q, target],
                [
                    _motor_coeffs(m["first"]),
                    _motor_coeffs(m["second"]),
                    c,
                    ca.densify(J),
                    e,
                    ca.densify(E),
                ],
                ["q", "target"],
                ["M1", "M2", "M", "J", "e", "E"],
            )
            cf = cache[key] = CompiledFunction(f, codegen=self.codegen)
        return cf

    @staticmethod
    def _error_expr(M: Multivector, target: Any) -> Any:
        """e = −log(M̃ M*) on the six motor slots (module docstring), an SX of the motor M and the target."""
        import casadi as ca

        lg = log((M.reverse() * _motor_expr(target)).project(MOTOR_BLADES))
        return -ca.vertcat(*[lg[i] for i in _MOTOR_SLOTS])

    def _tangent_jacobian(self, f: Any, q: Any, *extra: Any) -> Any:
        """∂f(q)/∂q (nq columns) when nq = nv, else ∂f(q ⊕ v)/∂v at v = 0 (nv columns, a free flyer's LOCAL
        velocities; :func:`~coop_ga.kinematics.chains.at_zero_velocity`)."""
        import casadi as ca

        if self.nq == self.nv:
            return ca.jacobian(f(q), q)
        return at_zero_velocity(self.system.model, lambda qv, v: ca.jacobian(f(qv), v), q, *extra)

    # ------------------------------------------------------------------ numeric read-outs
    def evaluate(self, q: Any) -> DualState:
        """The motors and body Jacobians at q (nq,) [rad or m]."""
        qv = validation.configuration(q, self.nq, "q", owner=self.name)
        ident = Motor.identity().coeffs
        M1, M2, Mr, Jr, _, _ = self._function("relative")(qv, ident)
        _, _, Ma, Ja, _, _ = self._function("absolute")(qv, ident)
        rel = Motor(Multivector(MOTOR_BLADES, tuple(Mr.ravel())), check=False)
        return DualState(
            _numeric_motor(M1),
            _numeric_motor(M2),
            rel,
            _numeric_motor(Ma),
            Jr,
            Ja,
            float(np.linalg.norm(np.asarray(rel.log())[:3])),
        )

    def error_and_jacobian(self, q: Any, which: str, target: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(e (6,), ∂e/∂q (6, nq), J_body (6, nq))`` of the ``which`` (``'relative'``/``'absolute'``) motor
        against ``target`` (a Motor; module docstring)."""
        which = validation.choice(which, _MOTORS, "which")
        qv = validation.configuration(q, self.nq, "q", owner=self.name)
        _, _, _, J, e, E = self._function(which)(qv, _as_motor(target).coeffs)
        return e.ravel(), E, J

    def relative(self, q: Any) -> Motor:
        """M_r(q) = M̃_2 M_1."""
        return self.evaluate(q).relative

    def absolute(self, q: Any) -> Motor:
        """M_a(q) = M_2 exp(½ log M_r)."""
        return self.evaluate(q).absolute


def _numeric_motor(c: np.ndarray) -> Motor:
    return Motor(Multivector(MOTOR_BLADES, tuple(float(x) for x in c.ravel())), check=False)


def _components(components: Any) -> tuple[int, ...]:
    """Row indices 0..5 of ``components``: a group name of :data:`DUAL_COMPONENTS`, row names, or indices."""
    if isinstance(components, str) and components in DUAL_COMPONENTS:
        return DUAL_COMPONENTS[components]
    items = (components,) if isinstance(components, (str, int, np.integer)) else components
    if not isinstance(items, Sequence) or not items:
        raise InvalidInputError(
            f"components must be one of {sorted(DUAL_COMPONENTS)} or a non-empty sequence of {DUAL_ROWS} names "
            f"or indices 0..5, got {components!r}"
        )
    return row_indices(items, DUAL_ROWS, "row", items)


class DualTask(BaseTask):
    """The relative or absolute motor of two frames → a target motor (module docstring).

    Args:
        space: the :class:`DualTaskSpace` (on the configuration's system).
        motor: ``'relative'`` (M_r = M̃_2 M_1) or ``'absolute'`` (M_a).
        target: M*, a :class:`~coop_ga.Motor` (or a ``pinocchio.SE3``, or 8 coefficients).
        components: ``'pose'`` (6 rows), ``'orientation'`` (the rotation rows), ``'position'`` (the translation
            rows), or row names of :data:`DUAL_ROWS` / indices.
        gain: α [1/s].  weight: per-row weights (k,) or a scalar.
        jacobian: ``'body'`` (the body Jacobian: the first-order map of q̇ to the body velocity; ∂e/∂q at the
            target) or ``'exact'`` (∂e/∂q everywhere).
        lm_damping: μ of the Levenberg–Marquardt term.

    Raises:
        InvalidInputError: an unknown motor, component or Jacobian mode; a target that is not a motor.
    """

    def __init__(
        self,
        space: DualTaskSpace,
        motor: str,
        target: Any,
        *,
        components: Any = "pose",
        gain: float = 10.0,
        weight: Any = None,
        jacobian: str = "body",
        lm_damping: float = 0.0,
    ):
        if not isinstance(space, DualTaskSpace):
            raise InvalidInputError(f"space must be a DualTaskSpace, got {type(space).__name__}")
        self.motor = validation.choice(motor, _MOTORS, "motor")
        super().__init__(gain, weight, lm_damping, f"{self.motor} motor")
        self.space = space
        self.rows = _components(components)
        self.mode = validation.choice(jacobian, ("body", "exact"), "jacobian")
        self.target = _as_motor(target)
        self.labels = tuple(f"{self.name} {DUAL_ROWS[k]}" for k in self.rows)

    def set_target(self, target: Any) -> None:
        """Move the target M* (a Motor, ``pinocchio.SE3`` or coefficients)."""
        self.target = _as_motor(target)

    def _evaluate(self, configuration: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        model = configuration.model
        if getattr(model, "system", model) is not self.space.system:
            raise InvalidInputError(
                f"the configuration is of system {getattr(model.system, 'name', '?')!r}, the dual task space "
                f"of {getattr(self.space.system, 'name', '?')!r}: build the DualTaskSpace on the configuration's model"
            )
        target = self.target

        def compute(c: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            return self.space.error_and_jacobian(c.q, self.motor, target)

        return configuration.cached(("dual", id(self), id(target)), compute)

    def full_error(self, configuration: Any) -> np.ndarray:
        """``e = −log(M̃(q) M*)`` (6,), all rows."""
        return self._evaluate(configuration)[0]

    def error(self, configuration: Any) -> np.ndarray:
        """The selected rows of ``−log(M̃(q) M*)`` (k,)."""
        return self.full_error(configuration)[list(self.rows)]

    def jacobian(self, configuration: Any) -> np.ndarray:
        """The selected rows (k, nq) of the body Jacobian (``'body'``) or of ∂e/∂q (``'exact'``)."""
        _, E, J = self._evaluate(configuration)
        return (J if self.mode == "body" else E)[list(self.rows)]
