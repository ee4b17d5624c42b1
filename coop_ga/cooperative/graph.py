"""The one symbolic graph of a cooperative task: end points → X_c → V_Sc → B_Sc, e = log(Ṽ_Sc V_d), derivatives.

Everything symbolic about a cooperative task is built here, once, and every consumer
uses it: :class:`~coop_ga.cooperative.CooperativeTask` (evaluation, IK error, J̇q̇, batch),
the iLQR's second-order terms (:meth:`TaskGraph.error_hessian_function`) and the OCP
benchmark (:meth:`TaskGraph.error_expression`).  Controllers never build graphs.

Structure (why it is fast)
--------------------------
The graph follows the structure of the problem instead of differentiating end to end:

1. joint angles → end points ``p_i(q)`` and their world Jacobians ``∂p_i/∂q`` from the
   motor kinematics (Eq 7, 16–17), sparse multivector code on CasADi SX;
2. a *small* function of the 3n point coordinates only (:attr:`TaskGraph.pose_function`):
   ``p → X_c = ∧P(p_i) (Eq 14) → V_Sc = V_S(X_u, X_c) (Eq 28) → B_Sc = log V_Sc`` and, by
   CasADi AD of this small graph, ``G(p) = −2 Ṽ ∂V/∂p`` (7 × 3n, body frame);
3. ``J^G = G(p) · ∂p/∂q`` (Eq 30 by the chain rule); each point depends on its own chain.

The error ``e = log(W)``, ``W = Ṽ_Sc V_d`` (Eq 44), and ``J_e = J_log(W) · K(W) · J^G``
(Eq 47, ``K(W) b = ½ b W``) reuse the same pieces; second derivatives
``∇²_q (wᵀe)`` use ``J_pᵀ ∇²_p(wᵀE) J_p + ∇²_q(gᵀp)`` (see :meth:`error_hessian_function`).

Local origin
------------
CGA stores a point x as ``e0 + x + ½|x|² e∞``, so a primitive of size r at distance ρ from
the origin loses relative precision like ε(ρ/r)².  The cooperative primitive is therefore
built from the end points *relative to their centroid* p̄, its centre/radius/axis are read
there, and the centre is shifted back (``c = c' + p̄``; for lines and planes the closest
point to the world origin is recomputed from a point on the flat), then V_Sc is assembled
with :func:`~coop_ga.geometry.similarity.similarity_from_parameters`.  The result is the
same versor as ``similarity_from_unit(X_c)`` (tests compare them), exact to ~1e-15 relative
wherever the points are, instead of wrong far from the origin.

Least-squares kinds
-------------------
``"sphere_fit"`` / ``"plane_fit"`` / ``"line_fit"`` / ``"circle_fit"`` (any k ≥ 4 / 3 / 2 / 3 end points)
replace ``∧P(p_i)`` in step 2 by the least-squares primitive of the points (:mod:`coop_ga.cooperative.primitive`:
for the sphere the smallest non-negative eigenvalue solution of Σ (P_i·S)² with S² = 1), read out about the
centroid as above.  The fit's root (Pratt eigenvalue η, the smallest / largest eigenvalue of the scatter matrix;
for the circle both λ₁ and its in-plane η) comes from a fixed number of Newton iterations evaluated forward
only; the pose function differentiates the closed form *at* that root and adds the root's derivative by the
implicit-function theorem (``dη/dp = −res_η⁻¹ res_p``, res the secular function / characteristic polynomial;
lower triangular for the circle's two roots), which is exact at the
root and smaller than AD through the iterations (six points, sphere_fit: 11 304 against 30 112 SX
instructions of the pose function, 2.9 s against 19 s to build and compile on the 2-core machine).  :attr:`TaskGraph.ad_function` (reference route
(b)) does differentiate through the iterations; the tests compare both and central differences.

Guards
------
Every entry point also returns ``checks = [ok, w, n2, c2, f]``: the well-definedness ``w`` of
the end points (:func:`coop_ga.well_definedness`), ``n2`` = the squared norm of all inputs
(NaN/inf/overflow detection), ``c2 = cos²(θ/2)`` with θ the angle of the primitive's axis from
the chart's reference axis (θ → π is the chart's half-turn), ``f`` = |sum of all outputs| (finite iff every output is: no NaN is ever
returned), and ``ok`` = w if everything is fine, else −1, so the hot path tests a single number
and :class:`~coop_ga.cooperative.guard.TaskGuard` diagnoses the rest.
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any

import casadi as ca
import numpy as np

from ..algebra.multivector import Multivector
from ..geometry.groups import SIMILARITY_BLADES, bivector_to_tangent, tangent_to_bivector
from ..geometry.groups import log as sim_log
from ..geometry.kinds import KIND_SPECS, CooperativeKind, Kind, kind_spec
from ..geometry.primitives import point as conformal_point
from ..geometry.primitives import well_definedness
from ..geometry.similarity import primitive_parameters, similarity_from_parameters, similarity_from_unit
from ..kinematics.chains import KinematicTree, at_zero_velocity
from .primitive import FIT_ROOTS, cooperative_primitive, fit_at, fit_parameters, fit_root, fit_well_definedness

__all__ = ["CHART_WARN_ANGLE", "NB", "TaskGraph", "versor_expr"]

NB = len(SIMILARITY_BLADES)

#: rotation angle of V_Sc [rad] beyond which the chart guard reports (170°)
CHART_WARN_ANGLE = math.radians(170.0)
_COS2_WARN = math.cos(0.5 * CHART_WARN_ANGLE) ** 2  # cos²(θ/2) at the threshold


def versor_expr(v: Any) -> Multivector:
    """Similarity versor (Multivector) from 12 coefficients (SX column or sequence) on SIMILARITY_BLADES."""
    return Multivector(SIMILARITY_BLADES, tuple(v[i] for i in range(NB)))


def _coeffs_expr(V: Multivector) -> ca.SX:
    return ca.vertcat(*[V.get(k) for k in SIMILARITY_BLADES])


def _body_columns(V: Multivector, dV: ca.SX) -> ca.SX:
    """``−2 Ṽ ∂V`` per column of dV (12 × m) as tangent 7-vectors (7 × m)."""
    Vr = V.reverse()
    cols = [
        ca.vertcat(*bivector_to_tangent((Vr * versor_expr(dV[:, c])).grade(2).scale(-2.0))) for c in range(dV.shape[1])
    ]
    return ca.horzcat(*cols)


def _closest_to_origin(kind: Kind, a: list[Any], o: Any) -> list[Any]:
    """The point of the flat ``kind`` through a with axis o (unit) closest to the world origin: a line's
    (direction o) removes the component of a along o, a plane's (normal o) keeps only that component."""
    s = a[0] * o[0] + a[1] * o[1] + a[2] * o[2]
    if KIND_SPECS[kind].axis_role == "direction":
        return [a[j] - s * o[j] for j in range(3)]
    return [s * o[j] for j in range(3)]


def _implicit(re: ca.SX, rp: ca.SX) -> ca.SX:
    """``(∂res/∂e)⁻¹ ∂res/∂p``: the roots' derivative (with a minus) by the implicit-function theorem.  The
    residuals are ordered so that ∂res/∂e is lower triangular (the circle fit: the plane's residual does not
    depend on the in-plane root), solved by forward substitution; a zero pivot (a degenerate fit, which the
    guard reports) is replaced by 1 so that no NaN is produced."""
    m = int(re.shape[0])
    rows: list[ca.SX] = []
    for i in range(m):
        piv = ca.if_else(ca.fabs(re[i, i]) > 0, re[i, i], 1.0)
        acc = rp[i, :]
        for j in range(i):
            acc = acc - re[i, j] * rows[j]
        rows.append(acc / piv)
    return ca.vertcat(*rows)


class TaskGraph:
    """Symbolic graph of the cooperative task ``kind`` on the end frames of ``tree``.

    Args:
        tree: the :class:`~coop_ga.kinematics.KinematicTree` of the task's end frames (in order).
        kind: primitive kind (``'point', 'point_pair', 'line', 'circle', 'plane', 'sphere'``), or a
            least-squares kind ``'sphere_fit'`` / ``'plane_fit'`` / ``'line_fit'`` / ``'circle_fit'`` over all the
            tree's end frames
            (:mod:`coop_ga.cooperative.primitive`: the fit is part of this graph, so its V_Sc, B_Sc and J^G
            come from the same code as every other kind's).
        name: used to name the CasADi functions (and the compiled libraries).
    """

    def __init__(self, tree: KinematicTree, kind: CooperativeKind, name: str, chart_axis: Any = None):
        self.tree = tree
        #: the facts of the kind (:data:`~coop_ga.geometry.kinds.KIND_SPECS`)
        self.spec = kind_spec(kind)
        self.kind = kind
        #: the primitive kind of V_Sc ("sphere" for "sphere_fit", "circle" for "circle_fit", …, else kind)
        self.primitive_kind = self.spec.primitive_kind
        self.name = name
        self.n_points = self.spec.points_used(len(tree.end_frames))
        self.nq = int(tree.model.nq)
        self.nv = int(tree.model.nv)
        unit_axis = self.spec.axis
        # the axis the minimal-rotation chart is measured from (None: the unit primitive's, Eq 26)
        self.chart_axis = (
            None
            if chart_axis is None or unit_axis is None
            else tuple(float(x) for x in np.asarray(chart_axis, float) / np.linalg.norm(np.asarray(chart_axis, float)))
        )
        self._ref_axis = self.chart_axis if self.chart_axis is not None else unit_axis

    # ================================================================== the small pose function of p
    def pose_from_points(self, p: Any, root: Any = None) -> tuple[Multivector, Any, Any]:
        """``(V_Sc, w, c2)`` for point coordinates p (3n SX or list), built about the centroid (module
        docstring); ``c2 = (1 + o·a)/2 = cos²(θ/2)`` with θ the angle of the primitive's axis o from the
        chart's reference axis a (1 for kinds without an axis): the chart flips at θ = π.  For the
        least-squares kinds ``root`` is the fit's root (:func:`~coop_ga.cooperative.primitive.fit_root`;
        None: computed here by its iterations)."""
        return self._pose(p, root)[:3]

    def _pose(self, p: Any, root: Any = None) -> tuple[Multivector, Any, Any, Any]:
        """:meth:`pose_from_points` plus the fit's residual (None for the exact kinds)."""
        n = self.n_points
        pts = [tuple(p[3 * i + j] for j in range(3)) for i in range(n)]
        res = None
        if (fit := self.spec.fit_name) is not None:  # least-squares sphere / plane, read out about the centroid
            w = fit_well_definedness(fit, pts)
            bar_l, c_rel, r, o, res = fit_at(fit, pts, fit_root(fit, pts) if root is None else root)
            bar = tuple(bar_l)
            kind = self.primitive_kind
        else:
            w = well_definedness(self.primitive_kind, pts) if n > 1 else ca.SX(1.0)
            bar = tuple(sum(pt[j] for pt in pts) / n for j in range(3))
            rel = [conformal_point([pt[j] - bar[j] for j in range(3)]) for pt in pts]
            X_rel = cooperative_primitive(self.primitive_kind, rel)
            kind, c_rel, r, o = primitive_parameters(X_rel)
        a = [c_rel[j] + bar[j] for j in range(3)]  # a point of the primitive (its centre for round kinds)
        c = _closest_to_origin(kind, a, o) if KIND_SPECS[kind].flat else a
        if o is None:
            c2: Any = ca.SX(1.0)
        else:
            ra = self._ref_axis
            assert ra is not None  # o is read only for kinds with an axis, and then _ref_axis is set
            c2 = 0.5 * (1.0 + o[0] * ra[0] + o[1] * ra[1] + o[2] * ra[2])
        return similarity_from_parameters(kind, c, r, o, chart_axis=self.chart_axis), w, c2, res

    @cached_property
    def pose_function(self) -> ca.Function:
        """``p (3n) → (V (12), B (7), G = −2 Ṽ ∂V/∂p (7 × 3n), w, c2)``."""
        p = ca.SX.sym("p", 3 * self.n_points)
        fit = self.spec.fit_name
        if fit is None:
            V, w, c2 = self.pose_from_points(p)
            Vv = _coeffs_expr(V)
            G = _body_columns(V, ca.jacobian(Vv, p))
            return ca.Function(f"pose_{self.kind}", [p], [Vv, sim_log(V), G, w, c2], ["p"], ["V", "B", "G", "w", "c2"])
        # least-squares kinds: the fit's root e by its iterations (values only), the fit in closed form at
        # e, and its derivative by the implicit-function theorem, res(p, e) = 0 ⇒ de/dp = −res_p / res_e
        # (exact at the root; AD through the iterations is ~3× larger — ad_function does that).
        m = FIT_ROOTS[fit]
        e = ca.SX.sym("e", m)
        V, w, c2, res = self._pose(p, e[0] if m == 1 else [e[i] for i in range(m)])
        Vv = _coeffs_expr(V)
        res = ca.vertcat(*res) if m > 1 else res
        dV = ca.jacobian(Vv, p) - ca.mtimes(ca.jacobian(Vv, e), _implicit(ca.jacobian(res, e), ca.jacobian(res, p)))
        inner = ca.Function("pose_at_root", [p, e], [Vv, sim_log(V), _body_columns(V, dV), w, c2])
        p2 = ca.SX.sym("p", 3 * self.n_points)
        root = fit_root(fit, [tuple(p2[3 * i + j] for j in range(3)) for i in range(self.n_points)])
        outs = list(inner(p2, ca.vertcat(*root) if m > 1 else root))
        return ca.Function(f"pose_{self.kind}", [p2], outs, ["p"], ["V", "B", "G", "w", "c2"])

    @cached_property
    def error_small_function(self) -> ca.Function:
        """``W (12) → (log W, J_log(W) · K(W))`` with ``K(W) b`` = the coefficients of ½ b W (7 × 7)."""
        wv = ca.SX.sym("W", NB)
        b = ca.SX.sym("b", 7)
        W = versor_expr(wv)
        e = sim_log(W)
        bW = (tangent_to_bivector([b[i] for i in range(7)]) * W).with_blades(SIMILARITY_BLADES).scale(0.5)
        K = ca.jacobian(_coeffs_expr(bW), b)
        return ca.Function("err_small", [wv], [e, ca.mtimes(ca.jacobian(e, wv), K)])

    # ================================================================== symbolic building blocks of q
    def points(self, q: ca.SX) -> tuple[ca.SX, ca.SX]:
        """``(p (3n), J_p (3n × nq))``: end points [m] and their world Jacobians (motor kinematics)."""
        pts = self.tree.end_points(q)
        Jp = self.tree.euclidean_point_jacobians(q)
        return ca.vertcat(*[c for pt in pts for c in pt]), ca.vertcat(*Jp)

    def evaluate(self, q: ca.SX) -> dict[str, ca.SX]:
        """``versor`` (12), ``log`` (7), ``jacobian`` J^G (7 × nq), ``points`` (3n), ``well_definedness``."""
        p, Jp = self.points(q)
        V, B, G, w, c2 = self.pose_function(p)
        return {"versor": V, "log": B, "jacobian": ca.mtimes(G, Jp), "points": p, "well_definedness": w, "chart": c2}

    def error(self, q: ca.SX, vd: ca.SX) -> dict[str, ca.SX]:
        """:meth:`evaluate` plus ``e = log(Ṽ_Sc V_d)`` (7) and ``J_e`` (7 × nq), Eq 44/47."""
        s = self.evaluate(q)
        W = (versor_expr(s["versor"]).reverse() * versor_expr(vd)).with_blades(SIMILARITY_BLADES)
        e, K = self.error_small_function(_coeffs_expr(W))
        return {**s, "e": e, "Je": ca.mtimes(K, s["jacobian"])}

    def error_expression(self, q: Any, vd: Any) -> Any:
        """e(q) = log(Ṽ_Sc(q) V_d) as an expression of q (SX or MX, e.g. CasADi Opti variables)."""
        return self.error_function(q, vd)[0]

    @staticmethod
    def checks(s: dict[str, ca.SX], inputs: tuple[ca.SX, ...], outputs: tuple[ca.SX, ...]) -> ca.SX:
        """``[ok, w, n2, c2, f]`` (module docstring); ``inputs`` are all arguments of the entry point,
        ``f = |Σ outputs|`` is finite iff every output is (NaN and inf propagate through the sum)."""
        n2 = sum((ca.dot(x, x) for x in inputs), ca.SX(0.0))
        c2 = s["chart"]  # cos²(θ/2), θ the angle of the primitive's axis from the chart's reference axis
        w = s["well_definedness"]
        f = ca.fabs(sum((ca.sum1(ca.vec(o)) for o in outputs), ca.SX(0.0)))
        # comparisons with NaN are false, so NaN anywhere (inputs or outputs) lands in the slow path
        ok = ca.if_else(n2 < 1e300, ca.if_else(f < 1e300, ca.if_else(c2 > _COS2_WARN, w, -1.0), -1.0), -1.0)
        return ca.vertcat(ok, w, n2, c2, f)

    # ================================================================== entry points (casadi.Function)
    @cached_property
    def evaluate_function(self) -> ca.Function:
        """``q → (V (12), B (7), J (7 × nq), checks (4), points (3n))``."""
        q = ca.SX.sym("q", self.nq)
        s = self.evaluate(q)
        return ca.Function(
            f"coop_{self.name}",
            [q],
            [
                s["versor"],
                s["log"],
                ca.densify(s["jacobian"]),
                self.checks(s, (q,), (s["versor"], s["log"], s["jacobian"])),
                s["points"],
            ],
            ["q"],
            ["V", "B", "J", "checks", "points"],
        )

    @cached_property
    def error_function(self) -> ca.Function:
        """``(q, V_d) → (e (7), J_e (7 × nq), checks (4), points (3n))``."""
        q = ca.SX.sym("q", self.nq)
        vd = ca.SX.sym("Vd", NB)
        s = self.error(q, vd)
        return ca.Function(
            f"coop_err_{self.name}",
            [q, vd],
            [s["e"], ca.densify(s["Je"]), self.checks(s, (q, vd), (s["e"], s["Je"])), s["points"]],
            ["q", "Vd"],
            ["e", "Je", "checks", "points"],
        )

    @cached_property
    def jdot_function(self) -> ca.Function:
        """``(q, q̇) → (J̇^G q̇ (7), checks (4), points (3n))`` by forward AD of J^G q̇ along q̇."""
        q = ca.SX.sym("q", self.nq)
        qd = ca.SX.sym("qd", self.nv)
        s = self.evaluate(q)
        if self.nq == self.nv:
            jd = ca.jtimes(ca.mtimes(s["jacobian"], qd), q, qd)
        else:  # along the tangent space: J(q ⊕ v) q̇ differentiated in v along q̇ at v = 0
            jd = self._at_zero_velocity(
                lambda qv, v: ca.jtimes(ca.mtimes(self.evaluate(qv)["jacobian"], qd), v, qd), q, qd
            )
        return ca.Function(
            f"coop_jdot_{self.name}",
            [q, qd],
            [ca.densify(jd), self.checks(s, (q, qd), (jd,)), s["points"]],
            ["q", "qd"],
            ["Jdot_qd", "checks", "points"],
        )

    @cached_property
    def error_hessian_function(self) -> ca.Function:
        """``(q (nq), V_d (12), w (7)) → H (nv × nv) = ∇²_q (wᵀ e(q))``, w held constant (with a free flyer,
        ∇²_v (wᵀ e(q ⊕ v)) at v = 0, the Hessian along the tangent space, :func:`integrate_to_second_order`).

        Built with the structure of the task (differentiating the whole graph twice
        generates ~10⁵ instructions and takes minutes to compile): with the end points
        ``p(q)`` (3n) and ``E(p) = e``,

            ∇²_q (wᵀe) = J_pᵀ ∇²_p(wᵀE) J_p + ∇²_q (gᵀ p(q)),   g = ∇_p(wᵀE)  (held constant),

        the first Hessian of a small function of the 3n point coordinates, the second
        block-sparse (each point depends on its own chain).  Evaluated by CasADi's SX
        virtual machine (~0.3 ms for three_franka, no compilation).
        """
        nq = self.nq
        q = ca.SX.sym("q", nq)
        p, Jp = self.points(q)
        m = int(p.shape[0])
        g = ca.SX.sym("g", m)
        if nq == self.nv:
            Hq, _ = ca.hessian(ca.dot(g, p), q)
        else:  # ∇²_v (gᵀ p(q ⊕ v)) at v = 0: the second derivative along the tangent space (nv × nv)
            Hq = self._at_zero_velocity(lambda qv, v: ca.hessian(ca.dot(g, self.points(qv)[0]), v)[0], q, g)
        f_pts = ca.Function("hess_points", [q, g], [p, Jp, Hq])

        ps = ca.SX.sym("p", m)
        vd = ca.SX.sym("Vd", NB)
        w = ca.SX.sym("w", 7)
        V, _, _ = self.pose_from_points(ps)
        W = (V.reverse() * versor_expr(vd)).with_blades(SIMILARITY_BLADES)
        Hp, gp = ca.hessian(ca.dot(w, sim_log(W)), ps)
        f_small = ca.Function("hess_small", [ps, vd, w], [Hp, gp])

        p1, Jp1, _ = f_pts(q, ca.DM.zeros(m))
        Hp1, g1 = f_small(p1, vd, w)
        _, _, Hq1 = f_pts(q, g1)
        H = ca.mtimes([Jp1.T, Hp1, Jp1]) + Hq1
        H = 0.5 * (H + H.T)
        return ca.Function(f"coop_hess_{self.name}", [q, vd, w], [ca.densify(H)], ["q", "Vd", "w"], ["H"])

    @cached_property
    def ad_function(self) -> ca.Function:
        """Reference route (b): plain AD of the unstructured graph q → V_Sc = similarity_from_unit(∧P(p_i(q)))
        (world origin, no centroid shift, no chain rule), ``J^G = −2 Ṽ ∂V/∂q``."""
        q = ca.SX.sym("q", self.nq)
        V = self._ad_versor(q)
        Vv = _coeffs_expr(V)
        if self.nq == self.nv:
            dV = ca.jacobian(Vv, q)
        else:  # a free flyer: J^G = −2 Ṽ ∂V(q ⊕ v)/∂v at v = 0, nv columns
            dV = self._at_zero_velocity(lambda qv, v: ca.jacobian(_coeffs_expr(self._ad_versor(qv)), v), q)
        return ca.Function("coop_ad", [q], [Vv, ca.densify(_body_columns(V, dV))])

    def _at_zero_velocity(self, build: Any, q: ca.SX, *extra: ca.SX) -> ca.SX:
        """:func:`~coop_ga.kinematics.chains.at_zero_velocity` on this graph's model."""
        return at_zero_velocity(self.tree.model, build, q, *extra)

    def _ad_versor(self, q: ca.SX) -> Multivector:
        """V_Sc of :attr:`ad_function` as one expression of q (world origin, no chain rule)."""
        pts = self.tree.end_points(q)
        if (fit := self.spec.fit_name) is not None:  # the fit end to end in world coordinates, no chain rule
            bar, c_rel, r, o = fit_parameters(fit, [tuple(pt) for pt in pts])
            a = [c_rel[j] + bar[j] for j in range(3)]
            if self.spec.flat:  # plane / line: the closest point to the world origin
                a = _closest_to_origin(self.primitive_kind, a, o)
            V = similarity_from_parameters(self.primitive_kind, a, r, o, chart_axis=self.chart_axis)
        else:
            X = cooperative_primitive(self.primitive_kind, [conformal_point(list(pt)) for pt in pts])
            V = similarity_from_unit(X, chart_axis=self.chart_axis)
        return V
