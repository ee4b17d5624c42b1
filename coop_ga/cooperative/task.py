"""The cooperative task: V_Sc(q), B_Sc(q), J^G(q) for a system and a primitive kind (§3.4).

:func:`cooperative_task` returns a :class:`CooperativeTask`, the single object every
controller consumes (in the style of a pink/mink ``Task``: a target, an error, a
Jacobian).  Controllers never touch the algebra.

How the fast path is built (once per system, kind and end-point order)
----------------------------------------------------------------------
The symbolic graph follows the structure of the problem instead of differentiating
everything end to end:

1. joint angles → end points ``p_i(q)`` and their world Jacobians ``∂p_i/∂q`` from the
   motor kinematics (Eq 7, 16–17), written with the sparse multivector code on CasADi SX;
2. a *small* function of the 3n point coordinates only:
   ``p → X_c = ∧P(p_i) (Eq 14) → V_Sc = V_S(X_u, X_c) (Eq 28) → B_Sc = log V_Sc`` and,
   by CasADi AD of this small graph, ``G(p) = −2 Ṽ ∂V/∂p`` (7 × 3n, body frame);
3. ``J^G = G(p) · ∂p/∂q`` (Eq 30 by the chain rule), exploiting that each point depends
   only on its own chain.

The combined function is compiled to C with gcc (``codegen="auto"``), cached on disk,
and bound to preallocated numpy buffers (``casadi.FunctionBuffer``), so a call costs a
copy of q plus the generated code (see ``benchmarks/cooperative.py``).

Geometric singularities (§5.3)
------------------------------
Every evaluation also returns the :func:`coop_ga.well_definedness` measure of the end
points (1 = best conditioned, 0 = degenerate: coincident points for a pair, collinear
for a circle/plane, coplanar for a sphere).  Below ``warn_below`` a
:class:`~coop_ga.errors.DegeneracyWarning` is emitted; at or below ``raise_below`` a
:class:`~coop_ga.errors.DegeneratePrimitiveError` is raised — on every route (numpy,
symbolic and compiled), so no NaN or huge radius is ever returned as an answer.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Sequence

import numpy as np

from ..algebra.multivector import Multivector
from ..codegen import CompiledFunction
from ..errors import ChartWarning, DegeneracyWarning, DegeneratePrimitiveError, InvalidInputError, NonFiniteError
from ..geometry.groups import (
    SIMILARITY_BLADES,
    bivector_to_tangent,
    log as sim_log,
    tangent_to_bivector,
)
from ..geometry.primitives import N_POINTS, Primitive, _check_kind, point as conformal_point, well_definedness
from ..geometry.similarity import similarity_from_unit, unit_primitive
from ..kinematics.chains import KinematicTree
from .primitive import cooperative_primitive

__all__ = ["CooperativeTask", "TaskState", "cooperative_task", "versor_from_coeffs", "versor_coeffs"]

_NB = len(SIMILARITY_BLADES)

#: rotation angle of V_Sc [rad] beyond which a :class:`ChartWarning` is emitted (170°)
CHART_WARN_ANGLE = math.radians(170.0)


def versor_from_coeffs(v: Any) -> Multivector:
    """Similarity versor from its 12 coefficients on :data:`SIMILARITY_BLADES`."""
    return Multivector(SIMILARITY_BLADES, tuple(v[i] for i in range(_NB)))


def versor_coeffs(V: Any) -> np.ndarray:
    """The 12 coefficients of a similarity versor (Multivector or group element) as numpy."""
    V = getattr(V, "versor", V)
    if not isinstance(V, Multivector):
        a = np.asarray(V, dtype=float).reshape(-1)
        if a.shape != (_NB,):
            raise InvalidInputError(f"a similarity versor has {_NB} coefficients (SIMILARITY_BLADES), got shape {a.shape}")
        return a
    return np.array([float(V.get(k)) for k in SIMILARITY_BLADES])


@dataclass(frozen=True)
class TaskState:
    """Everything one evaluation returns (arrays are copies).

    Attributes
    ----------
    versor: (12,) V_Sc coefficients on :data:`SIMILARITY_BLADES`.
    log: (7,) B_Sc on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``.
    jacobian: (7, nq) J^G, body frame (Eq 30).
    points: (n, 3) end points [m], world frame.
    well_definedness: scalar in [0, 1] (see module docstring).
    """

    versor: np.ndarray
    log: np.ndarray
    jacobian: np.ndarray
    points: np.ndarray
    well_definedness: float

    @property
    def similarity(self) -> Multivector:
        return versor_from_coeffs(self.versor)


def _sx():
    import casadi as ca

    return ca


class CooperativeTask:
    """Cooperative task space of ``system`` with primitive ``kind`` (§3.1–3.4).

    Parameters
    ----------
    system:
        A :class:`coop_ga.systems.System` (or anything with ``model``, ``end_frames``,
        ``name``, ``q0``).
    kind:
        ``'point', 'point_pair', 'line', 'circle', 'plane', 'sphere'``.
    points:
        Indices into ``system.end_frames`` giving the end points and their order
        (default: the first ``N_POINTS[kind]``).  The order fixes the orientation (see
        :mod:`coop_ga.cooperative.primitive`).
    codegen:
        ``"auto"`` (C via gcc when available), ``True`` or ``False`` (CasADi VM).
    warn_below, raise_below:
        Well-definedness thresholds for :class:`DegeneracyWarning` and
        :class:`DegeneratePrimitiveError` (dimensionless; metres for point pairs/lines).
    """

    def __init__(self, system: Any, kind: str, points: Sequence[int] | None = None, *,
                 codegen: bool | str = "auto", warn_below: float = 1e-2, raise_below: float = 1e-6):
        self.kind = _check_kind(kind)
        self.system = system
        n = N_POINTS[self.kind]
        k = len(system.end_frames)
        if points is None:
            if k < n:
                raise InvalidInputError(
                    f"a cooperative {self.kind} needs {n} end points; system '{system.name}' has {k} "
                    f"({', '.join(system.end_frames)}). Choose a kind with at most {k} points."
                )
            points = tuple(range(n))
        points = tuple(int(i) for i in points)
        if len(points) != n or any(not 0 <= i < k for i in points) or len(set(points)) != n:
            raise InvalidInputError(
                f"points must be {n} distinct indices into the system's {k} end frames "
                f"({', '.join(f'{i}: {f}' for i, f in enumerate(system.end_frames))}); got {points}"
            )
        self.point_indices = points
        self.end_frames = tuple(system.end_frames[i] for i in points)
        self.tree = KinematicTree(system.model, self.end_frames)
        self.nq = int(system.model.nq)
        self.codegen = codegen
        self.warn_below = float(warn_below)
        self.raise_below = float(raise_below)
        self.unit = unit_primitive(self.kind)
        self.name = f"{getattr(system, 'name', 'custom')}_{self.kind}_{'_'.join(map(str, points))}"

    def __repr__(self) -> str:
        return f"CooperativeTask({self.name!r}, nq={self.nq}, end_frames={list(self.end_frames)})"

    # ================================================================== symbolic graph
    def symbolic(self, q: Any) -> dict[str, Any]:
        """The task's expressions for a CasADi SX ``q`` (structured route, see module docstring).

        Returns a dict with ``versor`` (12×1), ``log`` (7×1), ``jacobian`` (7×nq),
        ``points`` (3n×1), ``well_definedness`` (1×1).
        """
        ca = _sx()
        pts = self.tree.end_points(q)
        Jp = self.tree.euclidean_point_jacobians(q)
        V, B, G, w = self._small_function(ca.vertcat(*[c for p in pts for c in p]))
        return {
            "versor": V,
            "log": B,
            "jacobian": ca.mtimes(G, ca.vertcat(*Jp)),
            "points": ca.vertcat(*[c for p in pts for c in p]),
            "well_definedness": w,
        }

    @cached_property
    def _small_function(self):
        """p (3n) → (V (12), B (7), G = −2 Ṽ ∂V/∂p as 7×3n, well-definedness)."""
        ca = _sx()
        n = N_POINTS[self.kind]
        p = ca.SX.sym("p", 3 * n)
        pts = [(p[3 * i], p[3 * i + 1], p[3 * i + 2]) for i in range(n)]
        X = cooperative_primitive(self.kind, [conformal_point(list(t)) for t in pts])
        V = similarity_from_unit(X)
        Vv = ca.vertcat(*[V.get(k) for k in SIMILARITY_BLADES])
        Bv = sim_log(V)
        dV = ca.jacobian(Vv, p)
        Vr = V.reverse()
        cols = []
        for c in range(3 * n):
            body = (Vr * versor_from_coeffs(dV[:, c])).grade(2).scale(-2.0)
            cols.append(ca.vertcat(*bivector_to_tangent(body)))
        G = ca.horzcat(*cols)
        w = well_definedness(self.kind, pts) if n > 1 else ca.SX(1.0)
        return ca.Function(f"small_{self.kind}", [p], [Vv, Bv, G, w], ["p"], ["V", "B", "G", "w"])

    @cached_property
    def casadi_function(self):
        """``q → (V, B, J^G, [w, q·q], points)`` as a casadi.Function (SX)."""
        ca = _sx()
        q = ca.SX.sym("q", self.nq)
        s = self.symbolic(q)
        qq = ca.dot(q, q)
        th2 = ca.sumsqr(s["log"][:3])
        # one scalar for the hot path: the measure if q is finite and the rotation is away from the
        # half-turn of the chart, else −1 (slow path sorts out which)
        ok = ca.if_else(qq < 1e300, ca.if_else(th2 < CHART_WARN_ANGLE**2, s["well_definedness"], -1.0), -1.0)
        checks = ca.vertcat(ok, s["well_definedness"], qq, th2)
        return ca.Function(
            f"coop_{self.name}", [q], [s["versor"], s["log"], ca.densify(s["jacobian"]), checks, s["points"]],
            ["q"], ["V", "B", "J", "checks", "points"],
        )

    @cached_property
    def compiled(self) -> CompiledFunction:
        """The fast path: generated C (or the VM) bound to numpy buffers; built on first use."""
        cf = CompiledFunction(self.casadi_function, codegen=self.codegen, check_finite=False)
        self._qbuf = cf.inputs[0].reshape(-1)  # a view: q is copied straight into the bound buffer
        self._eval = cf.eval
        self._outputs = cf.outputs
        return cf

    # ================================================================== evaluation
    def _run(self, q: Any) -> list[np.ndarray]:
        self.compiled  # noqa: B018  (built on first use; afterwards a dict lookup)
        if type(q) is np.ndarray and q.shape == self._qbuf.shape:  # hot path
            np.copyto(self._qbuf, q, casting="unsafe")
        else:
            a = np.asarray(q, dtype=float) if not isinstance(q, str) else np.asarray([])
            if a.shape != self._qbuf.shape:
                raise InvalidInputError(
                    f"task '{self.name}' expects q with {self.nq} entries (system '{self.system.name}'), "
                    f"got shape {a.shape}"
                )
            np.copyto(self._qbuf, a)
        self._eval()
        out = self._outputs
        if not out[3].item(0) > self.warn_below:
            self._check(out[3], q, out[4])
        return out

    def _check(self, checks: np.ndarray, q: Any, pts: np.ndarray) -> None:
        w, qq = checks.item(1), checks.item(2)
        if not math.isfinite(qq):
            bad = np.flatnonzero(~np.isfinite(np.asarray(q, dtype=float))).tolist()
            if not bad:
                raise InvalidInputError(f"q is too large (|q|² overflows: max |q_i| = {np.abs(q).max():.3g}); "
                                        "joint values must be finite angles [rad] or lengths [m]")
            raise NonFiniteError(f"q contains NaN or inf at indices {bad}")
        if not w > self.warn_below:
            self._degeneracy(float(w), pts.reshape(-1, 3))
        th = math.sqrt(checks.item(3))
        if th >= CHART_WARN_ANGLE:
            axis = "−e2" if self.kind in ("point_pair", "line") else "−e3"
            warnings.warn(
                f"cooperative {self.kind} of '{self.system.name}': its axis is {math.degrees(th):.1f}° from the unit "
                f"primitive's, near {axis}, where the minimal rotation of V_Sc jumps by a half-turn; reorder the end "
                "points (points=...) so the nominal axis is far from the antipode",
                ChartWarning,
                stacklevel=3,
            )

    def _degeneracy(self, w: float, pts: np.ndarray) -> None:
        what = {
            "point_pair": "the two end points coincide",
            "line": "the two end points coincide",
            "circle": "the three end points are (nearly) collinear",
            "plane": "the three end points are (nearly) collinear",
            "sphere": "the four end points are (nearly) coplanar",
        }.get(self.kind, "degenerate")
        desc = ", ".join(f"{f}={np.round(p, 4).tolist()}" for f, p in zip(self.end_frames, pts))
        if not w > self.raise_below:
            raise DegeneratePrimitiveError(
                f"cooperative {self.kind} of '{self.system.name}' is degenerate: {what} "
                f"(well-definedness {w:.3g} ≤ {self.raise_below:g}); points: {desc}. Move the chains apart "
                "or choose a primitive with fewer points."
            )
        warnings.warn(
            f"cooperative {self.kind} of '{self.system.name}' is close to a geometric singularity: {what} "
            f"(well-definedness {w:.3g} < {self.warn_below:g}); the Jacobian is ill-conditioned",
            DegeneracyWarning,
            stacklevel=3,
        )

    def evaluate(self, q: Any) -> TaskState:
        """V_Sc, B_Sc, J^G, end points and well-definedness in one compiled call (copies)."""
        out = self._run(q)
        return TaskState(out[0].reshape(-1).copy(), out[1].reshape(-1).copy(), out[2].copy(),
                         out[4].reshape(-1, 3).copy(), out[3].item(1))

    def evaluate_views(self, q: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Hot-loop variant: ``(V (12,1), B (7,1), J (7,nq))`` as internal buffers, overwritten by the next call."""
        out = self._run(q)
        return out[0], out[1], out[2]

    def similarity(self, q: Any) -> Multivector:
        """V_Sc(q) (Eq 28), a unit similarity versor on :data:`SIMILARITY_BLADES`."""
        return versor_from_coeffs(self._run(q)[0].reshape(-1).copy())

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

    def well_definedness(self, q: Any) -> float:
        """:func:`coop_ga.well_definedness` of the end points (1 best, 0 degenerate)."""
        return self._run(q)[3].item(1)

    def primitive(self, q: Any) -> Primitive:
        """X_c(q) = ∧ P_i(q) (∧ e∞) (Eq 14), from the compiled end points."""
        return cooperative_primitive(self.kind, [conformal_point(p) for p in self.points(q)])

    # ------------------------------------------------------------------ other Jacobians
    def analytic_jacobian(self, q: Any) -> np.ndarray:
        """J^A = ∂V_Sc/∂q, 12×nq (Eq 29), rows on :data:`SIMILARITY_BLADES`: ``∂V/∂q_i = −½ V b_i``."""
        st = self.evaluate(q)
        V = versor_from_coeffs(st.versor)
        return _versor_times_tangents(V, st.jacobian, -0.5)

    def bivector_jacobian(self, q: Any) -> np.ndarray:
        """J^B = ∂B_Sc/∂q = J_{S→B}(V_Sc) J^A, 7×nq (Eq 31)."""
        from ..geometry.groups import log_jacobian

        st = self.evaluate(q)
        V = versor_from_coeffs(st.versor)
        return log_jacobian(V) @ _versor_times_tangents(V, st.jacobian, -0.5)

    # ------------------------------------------------------------------ IK error
    @cached_property
    def _error_compiled(self) -> CompiledFunction:
        ca = _sx()
        q = ca.SX.sym("q", self.nq)
        vd = ca.SX.sym("Vd", _NB)
        s = self.symbolic(q)
        W = versor_from_coeffs(s["versor"]).reverse() * versor_from_coeffs(vd)
        W = W.with_blades(SIMILARITY_BLADES)
        e, K = self._error_small(ca.vertcat(*[W.get(k) for k in SIMILARITY_BLADES]))
        Je = ca.mtimes(K, s["jacobian"])
        checks = ca.vertcat(s["well_definedness"], ca.dot(q, q) + ca.dot(vd, vd))
        f = ca.Function(f"coop_err_{self.name}", [q, vd], [e, ca.densify(Je), checks, s["points"]],
                        ["q", "Vd"], ["e", "Je", "checks", "points"])
        return CompiledFunction(f, codegen=self.codegen, check_finite=False)

    @cached_property
    def _error_small(self):
        """W (12) → (log W, J_log(W) · K(W)) with K(W) b = coefficients of ½ b W (7×7)."""
        ca = _sx()
        w = ca.SX.sym("W", _NB)
        b = ca.SX.sym("b", 7)
        W = versor_from_coeffs(w)
        e = sim_log(W)
        Jlog = ca.jacobian(e, w)
        bW = (tangent_to_bivector([b[i] for i in range(7)]) * W).with_blades(SIMILARITY_BLADES).scale(0.5)
        K = ca.jacobian(ca.vertcat(*[bW.get(k) for k in SIMILARITY_BLADES]), b)
        return ca.Function("err_small", [w], [e, ca.mtimes(Jlog, K)])

    def error(self, q: Any, target: Any) -> np.ndarray:
        """e(q) = log(Ṽ_Sc(q) V_Sd) (Eq 44): the target seen from the current pose, 7-vector."""
        return self.error_and_jacobian(q, target)[0]

    def error_jacobian(self, q: Any, target: Any) -> np.ndarray:
        """J_Be = ∂e/∂q (Eq 47), 7×nq.  Note ``J_Be ≈ −½·J^G``-like near e = 0 … exactly
        ``J_{S→B}(W) · [½ b_i W]`` with ``W = Ṽ_Sc V_Sd`` and b_i the columns of J^G."""
        return self.error_and_jacobian(q, target)[1]

    def error_and_jacobian(self, q: Any, target: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(e (7,), J_Be (7, nq))`` in one compiled call (copies)."""
        cf = self._error_compiled
        try:
            np.copyto(cf.inputs[0].reshape(-1), q, casting="unsafe")
        except (ValueError, TypeError):
            raise InvalidInputError(f"task '{self.name}' expects q with {self.nq} entries, got shape {np.shape(q)}") from None
        cf.inputs[1][:, 0] = versor_coeffs(target)
        cf.eval()
        out = cf.outputs
        if not math.isfinite(out[2].item(1)):
            raise NonFiniteError("q or the target versor contains NaN or inf")
        if not out[2].item(0) > self.warn_below:
            self._degeneracy(out[2].item(0), out[3].reshape(-1, 3))
        return out[0].reshape(-1).copy(), out[1].copy()

    # ------------------------------------------------------------------ derivatives of J
    @cached_property
    def _jdot_compiled(self) -> CompiledFunction:
        ca = _sx()
        q = ca.SX.sym("q", self.nq)
        qd = ca.SX.sym("qd", self.nq)
        J = self.symbolic(q)["jacobian"]
        Jqd = ca.mtimes(J, qd)
        f = ca.Function(f"coop_jdot_{self.name}", [q, qd], [ca.densify(ca.jtimes(Jqd, q, qd))], ["q", "qd"], ["Jdot_qd"])
        return CompiledFunction(f, codegen=self.codegen, check_finite=True)

    def jdot_qdot(self, q: Any, qd: Any) -> np.ndarray:
        """J̇^G q̇ (7,): the directional derivative of J^G(q) q̇ along q̇ (CasADi AD), for Eq 34–38."""
        return self._jdot_compiled(np.asarray(q, float), np.asarray(qd, float)).reshape(-1)

    # ------------------------------------------------------------------ batch
    @cached_property
    def _batch_fn(self):
        return {}

    def evaluate_batch(self, Q: Any, *, parallel: str = "serial", threads: int = 2
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Evaluate N configurations in one call: returns V (N, 12), B (N, 7), J (N, 7, nq).

        Uses ``casadi.Function.map`` over the compiled function, bound to preallocated
        buffers per N, so the Python overhead is paid once per batch.  ``parallel`` is
        ``"serial"`` (default: fastest on 2 cores, see ``benchmarks/cooperative.py``) or
        ``"thread"`` (``threads`` workers).  Degenerate or NaN configurations raise
        as in :meth:`evaluate` (the first offending one is named).
        """
        Q = np.asarray(Q, dtype=float)
        if Q.ndim != 2 or Q.shape[1] != self.nq:
            raise InvalidInputError(f"Q must have shape (N, {self.nq}), got {Q.shape}")
        if not np.all(np.isfinite(Q)):
            bad = np.argwhere(~np.isfinite(Q))[0]
            raise NonFiniteError(f"Q contains NaN or inf (first at configuration {bad[0]}, joint {bad[1]})")
        N = Q.shape[0]
        key = (N, parallel, threads)
        cf = self._batch_fn.get(key)
        if cf is None:
            F = self.compiled.function.map(N, parallel, threads) if parallel == "thread" else self.compiled.function.map(N, "serial")
            cf = CompiledFunction(F, codegen=False, check_finite=False)
            self._batch_fn[key] = cf
        cf.inputs[0][...] = Q.T
        cf.eval()
        V, B, J, C, P = cf.outputs
        bad = np.flatnonzero(~(C[1] > self.warn_below))
        if bad.size:
            self._degeneracy(float(C[1, bad[0]]), P[:, bad[0]].reshape(-1, 3))
        J = J.reshape(7, N, self.nq).transpose(1, 0, 2)  # map concatenates horizontally
        return V.T.copy(), B.T.copy(), J.copy()

    # ------------------------------------------------------------------ reference routes (tests)
    @cached_property
    def _ad_function(self):
        """Route (b): plain CasADi AD of the whole graph q → V_Sc (no structure), J^G = −2 Ṽ ∂V/∂q."""
        ca = _sx()
        q = ca.SX.sym("q", self.nq)
        pts = self.tree.end_points(q)
        X = cooperative_primitive(self.kind, [conformal_point(list(p)) for p in pts])
        V = similarity_from_unit(X)
        Vv = ca.vertcat(*[V.get(k) for k in SIMILARITY_BLADES])
        dV = ca.jacobian(Vv, q)
        Vr = V.reverse()
        cols = [ca.vertcat(*bivector_to_tangent((Vr * versor_from_coeffs(dV[:, c])).grade(2).scale(-2.0)))
                for c in range(self.nq)]
        return ca.Function("coop_ad", [q], [Vv, ca.densify(ca.horzcat(*cols))])

    def jacobian_ad(self, q: Any) -> np.ndarray:
        """J^G by CasADi AD of the unstructured graph (reference route (b); VM, slow)."""
        self._run(q)  # same input checks and degeneracy guard
        return np.array(self._ad_function(np.asarray(q, float))[1])

    def jacobian_analytic(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """Route (a): ``(J^A (12×nq), J^G (7×nq))`` from the closed forms of
        :mod:`coop_ga.cooperative.analytic` (Eq 15–17, 29–30), numpy only, no AD."""
        from .analytic import analytic_similarity_jacobian
        from .primitive import primitive_jacobian

        self._run(q)  # same input checks and degeneracy guard as every route
        P, dP = self.tree.point_jacobians(np.asarray(q, dtype=float))
        X = cooperative_primitive(self.kind, P)
        cols = primitive_jacobian(self.kind, P, dP)
        _, JA, JG = analytic_similarity_jacobian(self.kind, X, _stack_columns(cols))
        return JA, JG

    def similarity_numpy(self, q: Any) -> Multivector:
        """V_Sc from the numpy multivector code (no CasADi), for cross-checks."""
        pts = self.tree.end_points_array(np.asarray(q, dtype=float))
        w = well_definedness(self.kind, pts) if N_POINTS[self.kind] > 1 else 1.0
        if not w > self.warn_below:
            self._degeneracy(float(w), pts)
        return similarity_from_unit(cooperative_primitive(self.kind, [conformal_point(p) for p in pts]))


def _stack_columns(cols: Sequence[Multivector]) -> Multivector:
    """Columns (multivectors) → one multivector with (m,)-array coefficients."""
    blades = sorted({k for c in cols for k in c.blades})
    m = len(cols)
    data = np.zeros((len(blades), m))
    for j, c in enumerate(cols):
        for k, v in zip(c.blades, c.coeffs):
            data[blades.index(k), j] = float(v)
    return Multivector(tuple(blades), tuple(data[i] for i in range(len(blades))))


def _versor_times_tangents(V: Multivector, J: np.ndarray, s: float) -> np.ndarray:
    """Columns ``s · V b_i`` (b_i = bivector of column i of J) as 12×m coefficients."""
    Bm = tangent_to_bivector([J[r, :] for r in range(7)])
    P = (V * Bm).with_blades(SIMILARITY_BLADES)
    return s * np.array([np.broadcast_to(np.asarray(P.get(k), float), (J.shape[1],)) for k in SIMILARITY_BLADES])


_TASK_CACHE: dict[tuple, CooperativeTask] = {}


def cooperative_task(system: Any, kind: str, points: Sequence[int] | None = None, **options: Any) -> CooperativeTask:
    """The cooperative task of ``system`` (a System or a registered name) with primitive ``kind``.

    Tasks are cached per (system, kind, points, options), so the compiled function is
    built once per process (and the generated C once per machine).
    """
    if isinstance(system, str):
        from .. import systems

        system = systems.load(system)
    key = (id(system), kind, None if points is None else tuple(points), tuple(sorted(options.items())))
    t = _TASK_CACHE.get(key)
    if t is None or t.system is not system:
        t = CooperativeTask(system, kind, points, **options)
        _TASK_CACHE[key] = t
    return t
