"""The cooperative task: V_Sc(q), B_Sc(q), J^G(q) for a system and a primitive kind (§3.4).

:func:`cooperative_task` returns a :class:`CooperativeTask`, the single object every
controller consumes (in the style of a pink/mink ``Task``: a target, an error, a
Jacobian).  Controllers never touch the algebra.

The task is a thin numeric front end of three pieces, each in one place:

* :class:`~coop_ga.cooperative.graph.TaskGraph` — the one symbolic graph (end points → X_c →
  V_Sc → B_Sc, the error e = log(Ṽ_Sc V_d), its first and second derivatives), built with
  the structure of the problem (see that module);
* :class:`~coop_ga.codegen.CompiledFunction` — each entry point compiled to C with gcc
  (``codegen="auto"``), cached on disk, bound to per-thread numpy buffers;
* :class:`~coop_ga.cooperative.guard.TaskGuard` — the one guard (finite input, degeneracy,
  chart) that every entry point runs: :meth:`~CooperativeTask.evaluate` and its read-outs,
  :meth:`~CooperativeTask.error_and_jacobian`, :meth:`~CooperativeTask.jdot_qdot`,
  :meth:`~CooperativeTask.evaluate_batch`.

Geometric singularities (§5.3): every evaluation computes the
:func:`coop_ga.well_definedness` of the end points (1 = best conditioned, 0 = degenerate:
coincident points for a pair, collinear for a circle/plane, coplanar for a sphere).  Below
``warn_below`` a :class:`~coop_ga.errors.DegeneracyWarning` is emitted; at or below
``raise_below`` a :class:`~coop_ga.errors.DegeneratePrimitiveError` is raised — so no NaN or
huge radius is ever returned as an answer.

Threads: a task may be shared between threads (``cooperative_task`` returns one cached
object per process); each thread evaluates with its own buffers.
"""

from __future__ import annotations

import hashlib
import math
import threading
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from .. import validation
from ..codegen import CompiledFunction
from ..diagnostics import collect_warnings
from ..errors import ChartError, InvalidInputError
from ..geometry.groups import Similarity, SimilarityLike, log_jacobian, tangent_to_bivector
from ..geometry.kinds import CooperativeKind, KindSpec, kind_spec
from ..geometry.primitives import Primitive, well_definedness
from ..geometry.primitives import point as conformal_point
from ..geometry.similarity import (
    primitive_parameters,
    similarity_from_parameters,
    similarity_from_unit,
    unit_primitive,
)
from ..kinematics.chains import KinematicTree
from .graph import CHART_WARN_ANGLE, TaskGraph, _closest_to_origin, versor_expr
from .guard import TaskGuard
from .primitive import cooperative_primitive, fit_parameters, fit_primitive, fit_well_definedness

__all__ = ["CHART_WARN_ANGLE", "TASK_CACHE_SIZE", "CooperativeTask", "TaskState", "cooperative_task"]

_F64 = np.dtype(np.float64)


@dataclass(frozen=True)
class TaskState:
    """Everything one evaluation returns (arrays are copies).

    Attributes:
        similarity: V_Sc (Eq 28), a :class:`~coop_ga.Similarity`.
        log: (7,) B_Sc on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``.
        jacobian: (7, nq) J^G, body frame (Eq 30).
        points: (n, 3) end points [m], world frame.
        well_definedness: scalar in [0, 1] (see module docstring).
    """

    similarity: Similarity
    log: np.ndarray
    jacobian: np.ndarray
    points: np.ndarray
    well_definedness: float

    @property
    def coeffs(self) -> np.ndarray:
        """V_Sc's 12 coefficients on :data:`~coop_ga.geometry.groups.SIMILARITY_BLADES` (read-only)."""
        return self.similarity.coeffs


def _binding(cf: CompiledFunction) -> Any:
    """The calling thread's buffers of ``cf`` (inputs, flat_inputs, outputs, eval)."""
    return cf.binding()


class CooperativeTask:
    """Cooperative task space of ``system`` with primitive ``kind`` (§3.1–3.4).

    Args:
        system:
            A :class:`coop_ga.systems.System` (or anything with ``model``, ``end_frames``,
            ``name``, ``q0``).
        kind:
            ``'point', 'point_pair', 'line', 'circle', 'plane', 'sphere'``, or a least-squares kind
            ``'sphere_fit'`` (≥ 4 points) / ``'plane_fit'`` (≥ 3) / ``'line_fit'`` (≥ 2) / ``'circle_fit'`` (≥ 3):
            the least-squares sphere / plane / line / circle of any number of end points
            (:mod:`coop_ga.cooperative.primitive`); V_Sc is then the similarity of that primitive
            (:attr:`primitive_kind`), built in the same task graph.
        points:
            Indices into ``system.end_frames`` giving the end points and their order
            (default: the first :attr:`KindSpec.n_points <coop_ga.geometry.kinds.KindSpec.n_points>`; for the least-squares kinds all end frames).  The
            order fixes the orientation (see :mod:`coop_ga.cooperative.primitive`; for ``plane_fit`` the
            normal follows the points' Newell normal, counter-clockwise seen from its tip).
        codegen:
            ``"auto"`` (C via gcc when available), ``True`` or ``False`` (CasADi VM).
        warn_below:
            Well-definedness threshold (dimensionless) of a :class:`~coop_ga.errors.DegeneracyWarning`.
        raise_below:
            Well-definedness threshold (dimensionless) of a :class:`~coop_ga.errors.DegeneratePrimitiveError`.
        chart_axis:
            The axis the minimal rotation of V_Sc is measured from (:func:`coop_ga.geometry.similarity_from_unit`):
            ``None`` — the unit primitive's (+e2 for point pairs/lines, +e3 for circles/planes; Eq 26);
            a 3-vector; or ``"auto"`` (default) — the unit primitive's, unless the primitive at
            ``system.q0`` points more than 90° away from it, then its axis at q0.  The chart jumps by a
            half-turn where the primitive's axis is opposite the reference, so "auto" keeps that as far
            as possible from the nominal configuration.  Targets must be expressed in the same chart:
            :meth:`target_from_primitive` and :func:`~coop_ga.control.displaced_target` do so.
    """

    def __init__(
        self,
        system: Any,
        kind: CooperativeKind,
        points: Sequence[int] | None = None,
        *,
        codegen: bool | str = "auto",
        warn_below: float = 1e-2,
        raise_below: float = 1e-6,
        chart_axis: Any = "auto",
    ):
        #: the facts of the task's kind (:data:`~coop_ga.geometry.kinds.KIND_SPECS`)
        self.spec: KindSpec = kind_spec(kind)
        self.kind: CooperativeKind = self.spec.name
        #: the kind of the primitive X_c and of V_Sc's unit primitive ("sphere" for "sphere_fit", …)
        self.primitive_kind = self.spec.primitive_kind
        self.system = system
        frames = tuple(system.end_frames)
        if self.spec.least_squares and points is None:
            points = tuple(range(len(frames)))
        n = self.spec.points_used(_count(points) if self.spec.least_squares else None)
        if points is None:
            if len(frames) < n:
                raise InvalidInputError(
                    f"a cooperative {self.kind} needs {n} end points; system '{system.name}' has {len(frames)} "
                    f"({', '.join(frames)}). Choose a kind with at most {len(frames)} points."
                )
            points = tuple(range(n))
        self.point_indices = validation.indices(points, n, len(frames), "points", labels=frames)
        self.end_frames = tuple(frames[i] for i in self.point_indices)
        self.tree = KinematicTree(system.model, self.end_frames)
        self.nq = int(system.model.nq)
        #: number of velocities (Jacobian columns): nq, or nq − 1 with a free flyer
        self.nv = int(system.model.nv)
        if codegen not in ("auto", True, False):
            raise InvalidInputError(f"codegen must be 'auto', True or False, got {codegen!r}")
        self.codegen = codegen
        self.warn_below = validation.nonnegative(warn_below, "warn_below")
        self.raise_below = validation.nonnegative(raise_below, "raise_below")
        self.unit = unit_primitive(self.primitive_kind)
        self.name = f"{getattr(system, 'name', 'custom')}_{self.kind}_{'_'.join(map(str, self.point_indices))}"
        self.chart_axis = self._resolve_chart(chart_axis)
        if self.chart_axis is not None:
            # a valid CasADi function name that identifies the chart
            self.name += "_chart" + hashlib.sha1(repr(self.chart_axis).encode()).hexdigest()[:8]
        self.graph = TaskGraph(self.tree, self.kind, self.name, chart_axis=self.chart_axis)
        chart = (
            "the unit primitive's axis"
            if self.chart_axis is None
            else f"chart_axis {np.round(self.chart_axis, 3).tolist()}"
        )
        self.guard = TaskGuard(
            self.kind, str(getattr(system, "name", "custom")), self.end_frames, self.warn_below, self.raise_below, chart
        )
        self._tls = threading.local()  # per-thread buffers of the compiled entry points

    def __repr__(self) -> str:
        return f"CooperativeTask({self.name!r}, nq={self.nq}, end_frames={list(self.end_frames)})"

    # ================================================================== the chart of V_Sc
    def _resolve_chart(self, chart_axis: Any) -> tuple[float, float, float] | None:
        unit_axis = self.spec.axis
        if unit_axis is None or chart_axis is None:
            return None
        if isinstance(chart_axis, str):
            validation.choice(chart_axis, ("auto",), "chart_axis")
            q0 = validation.configuration(self.system.q0, self.nq, "system.q0")
            pts = self.tree.end_points_array(q0)
            if (fit := self.spec.fit_name) is not None:
                if not fit_well_definedness(fit, pts) > self.raise_below:
                    return None
                o = fit_parameters(fit, [tuple(p) for p in pts.tolist()])[3]
            elif self.spec.n_points > 1 and not well_definedness(self.primitive_kind, pts) > self.raise_below:
                return None  # degenerate at q0: no nominal axis (the guard reports it on use)
            else:
                X = cooperative_primitive(self.primitive_kind, [conformal_point(p) for p in pts])
                _, _, _, o = primitive_parameters(X)
            o = np.asarray(o, dtype=float).reshape(3)
            if float(o @ np.asarray(unit_axis)) >= 0.0:
                return None  # within 90° of the unit axis: the canonical chart (Eq 26) is far from its flip
            return (float(o[0]), float(o[1]), float(o[2]))
        a = validation.vector(chart_axis, 3, "chart_axis")
        n = float(np.linalg.norm(a))
        if not n > 0:
            raise InvalidInputError("chart_axis must be a non-zero 3-vector (or None, or 'auto')")
        return (float(a[0] / n), float(a[1] / n), float(a[2] / n))

    def with_chart(self, chart_axis: Any) -> CooperativeTask:
        """The same task with its chart measured from ``chart_axis`` (see the class docstring)."""
        return cooperative_task(
            self.system,
            self.kind,
            self.point_indices,
            codegen=self.codegen,
            warn_below=self.warn_below,
            raise_below=self.raise_below,
            chart_axis=chart_axis,
        )

    def target_from_primitive(self, X: Any) -> Similarity:
        """The target V_Sd = V_S(X_u, X) of a primitive X of the task's kind, in the task's chart (Eq 28)."""
        if not isinstance(X, Primitive) or X.kind != self.primitive_kind:
            raise InvalidInputError(
                f"target_from_primitive needs a {self.primitive_kind} Primitive, got {type(X).__name__}"
                + (f" ({X.kind})" if isinstance(X, Primitive) else "")
            )
        return Similarity(similarity_from_unit(X, chart_axis=self.chart_axis))

    def check_target(self, target: SimilarityLike, what: str = "target") -> Similarity:
        """``target`` as a Similarity, refused with a :class:`~coop_ga.errors.ChartError` when its primitive's
        axis is beyond the chart warning angle (170°) from the chart's reference axis: the path to it would
        cross the chart's half-turn and the error e = log(Ṽ_Sc V_Sd) would jump on the way."""
        V = validation.target(target, what)
        unit_axis = self.spec.axis
        if unit_axis is None:
            return V
        ref = np.asarray(self.chart_axis if self.chart_axis is not None else unit_axis)
        o = V.rotation_matrix @ np.asarray(unit_axis)
        theta = float(np.arccos(np.clip(o @ ref, -1.0, 1.0)))
        if theta >= CHART_WARN_ANGLE:
            raise ChartError(
                f"{what}: its {self.kind}'s axis {np.round(o, 3).tolist()} is {np.degrees(theta):.1f}° from the chart "
                f"axis of task '{self.name}' ({np.round(ref, 3).tolist()}); a path to it crosses the chart's half-turn. "
                "Use a task whose chart is between the two: task.with_chart(axis), e.g. the sum of the current and "
                "the target axes (then rebuild the target with that task's target_from_primitive)"
            )
        return V

    # ================================================================== symbolic access
    def symbolic(self, q: Any) -> dict[str, Any]:
        """The task's expressions for a CasADi SX ``q`` (:meth:`TaskGraph.evaluate`):
        ``versor`` (12), ``log`` (7), ``jacobian`` (7×nq), ``points`` (3n), ``well_definedness``."""
        return self.graph.evaluate(q)

    @property
    def casadi_function(self) -> Any:
        """``q → (V, B, J^G, checks, points)`` as a casadi.Function (SX)."""
        return self.graph.evaluate_function

    # ================================================================== compiled entry points
    @cached_property
    def compiled(self) -> CompiledFunction:
        """Entry point ``evaluate``: generated C (or the VM) bound to per-thread buffers; built on first use."""
        return CompiledFunction(self.graph.evaluate_function, codegen=self.codegen, check_finite=False)

    @cached_property
    def _error_compiled(self) -> CompiledFunction:
        return CompiledFunction(self.graph.error_function, codegen=self.codegen, check_finite=False)

    @cached_property
    def _jdot_compiled(self) -> CompiledFunction:
        return CompiledFunction(self.graph.jdot_function, codegen=self.codegen, check_finite=False)

    @cached_property
    def _batch(self) -> dict[int, CompiledFunction]:
        return {}

    def _load_q(self, buf: np.ndarray, q: Any, what: str = "q") -> None:
        if type(q) is np.ndarray and q.dtype is _F64 and q.shape == buf.shape:  # hot path
            buf[...] = q
        else:
            np.copyto(buf, validation.configuration(q, self.nq, what, owner=f"task '{self.name}'"))

    def _eval_context(self) -> tuple[np.ndarray, Any, list[np.ndarray]]:
        """This thread's ``(q buffer, eval, outputs)`` of the evaluate entry point (cached per thread)."""
        try:
            return self._tls.eval_ctx
        except AttributeError:
            b = _binding(self.compiled)
            self._tls.eval_ctx = ctx = (b.flat_inputs[0], b.eval, b.outputs)
            return ctx

    def _run(self, q: Any) -> list[np.ndarray]:
        # the hot path of every evaluation: one thread-local lookup, one copy, the C call, one comparison
        try:
            qb, ev, out = self._tls.eval_ctx
        except AttributeError:
            qb, ev, out = self._eval_context()
        if type(q) is np.ndarray and q.dtype is _F64 and q.shape == qb.shape:
            qb[...] = q  # 70 ns, a third of np.copyto's
        else:
            self._load_q(qb, q)
        ev()
        if not out[3].item(0) > self.warn_below:
            self.guard.diagnose(out[3], out[4], (("q", qb),))
        return out

    # ================================================================== evaluation
    def evaluate(self, q: Any) -> TaskState:
        """V_Sc, B_Sc, J^G, end points and well-definedness at q (nq,) in one compiled call (copies)."""
        out = self._run(q)
        return TaskState(
            Similarity(versor_expr(out[0].reshape(-1).copy()), check=False),
            out[1].reshape(-1).copy(),
            out[2].copy(),
            out[4].reshape(-1, 3).copy(),
            out[3].item(1),
        )

    def evaluate_views(self, q: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Hot-loop variant: ``(V (12,1), B (7,1), J (7,nq))`` as this thread's internal buffers,
        overwritten by its next call."""
        out = self._run(q)
        return out[0], out[1], out[2]

    def similarity(self, q: Any) -> Similarity:
        """V_Sc(q) (Eq 28) as a :class:`~coop_ga.Similarity`."""
        return Similarity(versor_expr(self._run(q)[0].reshape(-1).copy()), check=False)

    def log(self, q: Any) -> np.ndarray:
        """B_Sc(q) = log V_Sc(q) as a 7-vector ``[θ12, θ13, θ23, β, t1, t2, t3]``."""
        return self._run(q)[1].reshape(-1).copy()

    def jacobian(self, q: Any) -> np.ndarray:
        """J^G(q), 7×nq, body frame (Eq 30): column i = lim log(Ṽ_Sc(q) V_Sc(q + h e_i))/h.

        The body frame of V_Sc includes its dilation: a body translation t (rows e1∞..e3∞)
        moves the primitive by ``r · R t`` in the world (r its radius, R its rotation), so
        translation rows are in radii per unit joint motion for point pairs, circles and
        spheres (metres for points, lines and planes, which have no scale).
        """
        return self._run(q)[2].copy()

    def points(self, q: Any) -> np.ndarray:
        """The task's end points [m], shape (n, 3), world frame."""
        return self._run(q)[4].reshape(-1, 3).copy()

    def chart_angle(self, q: Any) -> float:
        """Angle [rad] of the primitive's axis at q from the chart's reference axis (0 for kinds without
        an axis); the chart of V_Sc jumps by a half-turn at π."""
        c2 = self._run(q)[3].item(3)
        return 2.0 * math.acos(min(1.0, math.sqrt(max(c2, 0.0))))

    def well_definedness(self, q: Any) -> float:
        """:func:`coop_ga.well_definedness` of the end points (1 best, 0 degenerate)."""
        return self._run(q)[3].item(1)

    def primitive(self, q: Any) -> Primitive:
        """X_c(q) = ∧ P_i(q) (∧ e∞) (Eq 14), from the compiled end points (for the least-squares kinds the
        fitted sphere / plane, :func:`~coop_ga.cooperative.primitive.fit_primitive`)."""
        if (fit := self.spec.fit_name) is not None:
            return fit_primitive(fit, self.points(q), raise_below=self.raise_below)
        return cooperative_primitive(self.primitive_kind, [conformal_point(p) for p in self.points(q)])

    # ------------------------------------------------------------------ other Jacobians
    def analytic_jacobian(self, q: Any) -> np.ndarray:
        """J^A = ∂V_Sc/∂q, 12×nq (Eq 29), rows on SIMILARITY_BLADES: ``∂V/∂q_i = −½ V b_i``."""
        st = self.evaluate(q)
        return _versor_times_tangents(st.similarity.versor, st.jacobian, -0.5)

    def bivector_jacobian(self, q: Any) -> np.ndarray:
        """J^B = ∂B_Sc/∂q = J_{S→B}(V_Sc) J^A, 7×nq (Eq 31)."""
        st = self.evaluate(q)
        V = st.similarity.versor
        return log_jacobian(V) @ _versor_times_tangents(V, st.jacobian, -0.5)

    # ------------------------------------------------------------------ IK error
    def error(self, q: Any, target: SimilarityLike) -> np.ndarray:
        """e(q) = log(Ṽ_Sc(q) V_Sd) (Eq 44): the target (a :class:`~coop_ga.Similarity`) seen from
        the current pose, 7-vector on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``."""
        return self.error_and_jacobian(q, target)[0]

    def error_jacobian(self, q: Any, target: SimilarityLike) -> np.ndarray:
        """J_e = ∂e/∂q (Eq 47), 7×nq: ``J_{S→B}(W) · [½ b_i W]`` with ``W = Ṽ_Sc V_Sd`` and b_i
        the columns of J^G (near e = 0, J_e → −J^G)."""
        return self.error_and_jacobian(q, target)[1]

    def error_and_jacobian(self, q: Any, target: SimilarityLike) -> tuple[np.ndarray, np.ndarray]:
        """``(e (7,), J_e (7, nq))`` in one compiled call (copies); ``target`` a :class:`~coop_ga.Similarity`."""
        vd = target.coeffs if type(target) is Similarity else validation.target(target).coeffs
        b = _binding(self._error_compiled)
        qb = b.flat_inputs[0]
        self._load_q(qb, q)
        np.copyto(b.flat_inputs[1], vd)
        b.eval()
        out = b.outputs
        if not out[2].item(0) > self.warn_below:
            self.guard.diagnose(out[2], out[3], (("q", qb), ("target", vd)))
        return out[0].reshape(-1).copy(), out[1].copy()

    def error_hessian(self, q: Any, target: SimilarityLike, w: Any) -> np.ndarray:
        """``∇²_q (wᵀ e(q))`` (nv, nv) with w (7,) held constant (for Newton-type solvers; CasADi VM); with a
        free flyer ``∇²_v (wᵀ e(q ⊕ v))`` at v = 0 (the Hessian along ``pinocchio.integrate``).

        Built by :meth:`TaskGraph.error_hessian_function` (structured second derivatives);
        the inputs are checked like every entry point (the degeneracy guard runs through
        :meth:`error_and_jacobian` at the same q).
        """
        tgt = validation.target(target)
        self.error_and_jacobian(q, tgt)  # the guard (finite q, degeneracy, chart)
        wv = validation.vector(w, 7, "w")
        qv = validation.configuration(q, self.nq, owner=f"task '{self.name}'")
        return np.asarray(self.graph.error_hessian_function(qv, tgt.coeffs, wv))

    # ------------------------------------------------------------------ derivatives of J
    def jdot_qdot(self, q: Any, qd: Any) -> np.ndarray:
        """J̇^G q̇ (7,): the directional derivative of J^G(q) q̇ along q̇ (CasADi AD), for Eq 34–38.  With a
        free flyer, q̇ is a velocity (nv,) and the derivative is along ``q ⊕ t q̇`` (``pinocchio.integrate``)."""
        b = _binding(self._jdot_compiled)
        qb, qdb = b.flat_inputs[0], b.flat_inputs[1]
        self._load_q(qb, q)
        if self.nq == self.nv:
            self._load_q(qdb, qd, "qd")
        else:  # a velocity (nv,), not a configuration
            np.copyto(qdb, validation.vector(qd, self.nv, "qd"))
        b.eval()
        out = b.outputs
        if not out[1].item(0) > self.warn_below:
            self.guard.diagnose(out[1], out[2], (("q", qb), ("qd", qdb)))
        return out[0].reshape(-1).copy()

    # ------------------------------------------------------------------ batch
    def evaluate_batch(self, Q: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Evaluate N configurations Q (N, nq) in one call: returns V (N, 12), B (N, 7), J (N, 7, nq).

        Uses ``casadi.Function.map`` over the compiled function, bound to buffers per N, so
        the Python overhead is paid once per batch.  The guard runs on every configuration:
        the first one that raises is named; warnings are issued once with their count.
        """
        Qa = validation.array(Q, "Q", finite=False)
        if Qa.ndim != 2 or Qa.shape[1] != self.nq or Qa.shape[0] < 1:
            raise InvalidInputError(f"Q must have shape (N, {self.nq}) with N ≥ 1, got {Qa.shape}")
        N = Qa.shape[0]
        cf = self._batch.get(N)
        if cf is None:
            cf = CompiledFunction(self.compiled.function.map(N, "serial"), codegen=False, check_finite=False)
            self._batch[N] = cf
        b = _binding(cf)
        b.inputs[0][...] = Qa.T
        b.eval()
        V, B, J, C, P = b.outputs
        bad = np.flatnonzero(~(C[0] > self.warn_below))
        if bad.size:
            with collect_warnings():
                for i in bad:
                    self.guard.diagnose(C[:, i], P[:, i], ((f"Q[{i}]", Qa[i]),), where=f" (configuration {i})")
        J = J.reshape(7, N, self.nv).transpose(1, 0, 2)  # map concatenates horizontally
        return V.T.copy(), B.T.copy(), J.copy()

    # ------------------------------------------------------------------ reference routes (tests)
    def jacobian_ad(self, q: Any) -> np.ndarray:
        """J^G (7, nv) by CasADi AD of the unstructured graph (reference route (b); VM, slow); with a free
        flyer, of V_Sc(q ⊕ v) in v at v = 0."""
        self._run(q)  # same input checks and guard
        return np.array(self.graph.ad_function(np.asarray(q, float))[1])

    def jacobian_closed_form(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """Reference route (a): ``(J^A (12×nq), J^G (7×nq))`` from the closed forms of
        :mod:`coop_ga.cooperative.analytic` (Eq 15–17, 29–30), numpy only, no AD."""
        from .analytic import analytic_similarity_jacobian
        from .primitive import primitive_jacobian

        if self.chart_axis is not None:
            raise InvalidInputError(
                "the closed forms of Appendix B are for the canonical chart; build the task "
                "with chart_axis=None to use them"
            )
        if self.spec.least_squares:
            raise InvalidInputError(
                f"the closed forms of Appendix B are for primitives spanned by their points; a {self.kind} task has "
                "none (use jacobian() or jacobian_ad())"
            )
        self._run(q)  # same input checks and guard as every route
        P, dP = self.tree.point_jacobians(np.asarray(q, dtype=float))
        X = cooperative_primitive(self.primitive_kind, P)
        cols = primitive_jacobian(self.primitive_kind, P, dP)
        _, JA, JG = analytic_similarity_jacobian(self.primitive_kind, X, _stack_columns(cols))
        return JA, JG

    def similarity_numpy(self, q: Any) -> Similarity:
        """V_Sc from the numpy multivector code (no CasADi, world origin), for cross-checks."""
        qv = validation.configuration(q, self.nq, owner=f"task '{self.name}'")
        pts = self.tree.end_points_array(qv)
        if (fit := self.spec.fit_name) is not None:
            w = fit_well_definedness(fit, pts)
            if not w > self.warn_below:
                self.guard.degeneracy(float(w), pts)
            bar, c, r, o = fit_parameters(fit, [tuple(p) for p in pts.tolist()])
            a = np.array(bar) + np.array([float(v) for v in c])
            if o is not None:
                o = np.array([float(v) for v in o])
            if self.spec.flat:  # the flat's point closest to the world origin (as the task graph)
                a = np.array(_closest_to_origin(self.primitive_kind, a.tolist(), o.tolist()))
            return Similarity(
                similarity_from_parameters(self.primitive_kind, a, r, o, chart_axis=self.chart_axis), check=False
            )
        w = well_definedness(self.primitive_kind, pts) if self.spec.n_points > 1 else 1.0
        if not w > self.warn_below:
            self.guard.degeneracy(float(w), pts)
        V = similarity_from_unit(
            cooperative_primitive(self.primitive_kind, [conformal_point(p) for p in pts]), chart_axis=self.chart_axis
        )
        return Similarity(V, check=False)


def _count(points: Any) -> int:
    """How many indices ``points`` holds (0 if it is not a sequence: validation.indices then says why)."""
    return len(points) if isinstance(points, Sequence | np.ndarray) and not isinstance(points, (str, bytes)) else 0


def _stack_columns(cols: Sequence[Any]) -> Any:
    """Columns (multivectors) → one multivector with (m,)-array coefficients."""
    from ..algebra.multivector import Multivector

    blades = sorted({k for c in cols for k in c.blades})
    m = len(cols)
    data = np.zeros((len(blades), m))
    for j, c in enumerate(cols):
        for k, v in zip(c.blades, c.coeffs):
            data[blades.index(k), j] = float(v)
    return Multivector(tuple(blades), tuple(data[i] for i in range(len(blades))))


def _versor_times_tangents(V: Any, J: np.ndarray, s: float) -> np.ndarray:
    """Columns ``s · V b_i`` (b_i = bivector of column i of J) as 12×m coefficients."""
    from ..geometry.groups import SIMILARITY_BLADES

    Bm = tangent_to_bivector([J[r, :] for r in range(7)])
    P = (V * Bm).with_blades(SIMILARITY_BLADES)
    return s * np.array([np.broadcast_to(np.asarray(P.get(k), float), (J.shape[1],)) for k in SIMILARITY_BLADES])


#: how many tasks :func:`cooperative_task` keeps (least recently used first out): each holds its system, its
#: symbolic graph and its loaded compiled functions, so a sweep over many systems must not keep them all
TASK_CACHE_SIZE = 64
_TASK_CACHE: OrderedDict[tuple[Any, ...], CooperativeTask] = OrderedDict()
_TASK_CACHE_LOCK = threading.Lock()


def cooperative_task(
    system: Any, kind: CooperativeKind, points: Sequence[int] | None = None, **options: Any
) -> CooperativeTask:
    """The cooperative task of ``system`` (a System or a registered name) with primitive ``kind``.

    Tasks are cached per (system, kind, points, options), so the compiled functions are
    built once per process (and the generated C once per machine).  The cached task is
    shared by every caller and safe to use from several threads.  The cache keeps the
    :data:`TASK_CACHE_SIZE` most recently used tasks (a task dropped from it stays valid for
    whoever holds it; asking again builds a new one, whose compiled C comes from the disk cache).
    """
    if isinstance(system, str):
        from .. import systems

        system = systems.load(system)
    spec = kind_spec(kind)
    pts = (
        None
        if points is None
        else validation.indices(
            points,
            spec.points_used(_count(points) if spec.least_squares else None),
            len(system.end_frames),
            "points",
            labels=tuple(system.end_frames),
        )
    )
    # array-valued options (chart_axis) become tuples so that the cache key is hashable
    options = {
        k: tuple(np.asarray(v, dtype=float).ravel().tolist()) if isinstance(v, (np.ndarray, list)) else v
        for k, v in options.items()
    }
    try:
        key = (id(system), kind, pts, tuple(sorted(options.items())))
        hash(key)
    except TypeError:
        raise InvalidInputError(f"task options must be plain values, got {options!r}") from None
    with _TASK_CACHE_LOCK:
        t = _TASK_CACHE.get(key)
        if t is not None and t.system is system:  # (an id may be reused by a new system once the old one is gone)
            _TASK_CACHE.move_to_end(key)
            return t
    t = CooperativeTask(system, kind, pts, **options)  # outside the lock: building takes up to seconds
    with _TASK_CACHE_LOCK:
        other = _TASK_CACHE.get(key)
        if other is not None and other.system is system:  # another thread built it meanwhile: one task per key
            t = other
        _TASK_CACHE[key] = t
        _TASK_CACHE.move_to_end(key)
        while len(_TASK_CACHE) > max(int(TASK_CACHE_SIZE), 1):
            _TASK_CACHE.popitem(last=False)
    return t
