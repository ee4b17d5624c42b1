"""A free flyer in the iLQR: the reach solved in a local chart of the configuration manifold.

Why a chart (and not the state (q, v) on the manifold)
------------------------------------------------------
A system with a free flyer has nq ≠ nv (q = [p; quaternion x y z w; joints], a velocity is the LOCAL twist
[v; ω] and the joint speeds).  Two designs carry the iLQR's double integrator (Eq 54) over:

(a) the state (q, v) on the manifold, ``q⁺ = q ⊕ (v Δt + ½ a Δt²)``, linearised in the tangent space
    (``pinocchio.dIntegrate``) at every knot — the dynamics become time-varying, so the closed-form condensed
    steps (the Gramian of the double integrator), the roll-out by cumulative sums and the exact feasibility blend
    (the bounds affine in u) would all have to be rewritten;
(b) **a local chart** (used here): the iLQR runs unchanged on x ∈ R^nv with

        q(x) = q_ref ⊕ (x − c),      c = ``system.limit_coordinates(q_ref)``,

    q_ref the start (the MPC re-centres it at the measured state every tick), ⊕ ``pinocchio.integrate``.  A 1-DOF
    joint's chart coordinate *is* its joint coordinate (⊕ adds there), so its position, velocity and acceleration
    bounds are the system's own; a free flyer's six chart coordinates are the exponential coordinates of its
    displacement from q_ref (the rotation vector and the se(3) translation part) and have **no position bound**
    (the flyer's position is free; its quaternion has no bound to violate).  Its velocity and acceleration bounds
    apply to the chart rates ẋ, ẍ (equal to the twist and its rate at x = c; they stay bounds of the chart
    rates away from it).  The task's error and Jacobian are composed with the chart: ``J_x = J(q(x)) D(x)``,
    ``D = ∂(q_ref ⊕ ξ)/∂ξ`` (``pinocchio.dIntegrate``: the SE(3) right Jacobian on the flyer's block, the
    identity on the joints; :func:`flyer_jacobian`); the Newton model's Hessian is exact: ``Dᵀ ∇²_v(wᵀe) D`` plus the chart's own
    curvature on the flyer's block, ``Σ_i g_i ∇²_δ m_i``, g = J_eᵀ w along the tangent and
    ``m(δ) = log6(exp6(ξ)⁻¹ exp6(ξ + δ))`` (:func:`flyer_curvature`).

(b) leaves every solve on a system with nq = nv untouched (bit-identical: the chart is never built there), needs
no change of the solver, and its dynamics stay the exact double integrator of the chart; what it gives up: the
flyer's speed bounds are on the chart rates, and a chart far from q_ref (a flyer rotating by ~π) is distorted —
the MPC's re-centring keeps it near.  :class:`ChartTask` and :class:`ChartClearance` are the task and the
clearance cost seen in the chart; :func:`chart_reach` is :func:`~coop_ga.control.ilqr.ilqr_reach` on a free flyer
(it dispatches there) and :func:`to_manifold` maps the chart's result back to q.
"""

from __future__ import annotations

import dataclasses
from functools import lru_cache
from typing import Any

import numpy as np

from ... import validation
from ...geometry.groups import SimilarityLike
from .options import ILQROptions
from .results import ILQRResult

__all__ = [
    "ChartClearance",
    "ChartTask",
    "FlyerChart",
    "chart_problem",
    "chart_reach",
    "flyer_curvature",
    "to_manifold",
]


@lru_cache(maxsize=1)
def _chart_function() -> Any:
    """``(ξ (6), g (6)) → (∂m/∂δ, ∇²_δ gᵀm)`` at δ = 0 (6 × 6 each), m(δ) = log6(exp6(ξ)⁻¹ exp6(ξ + δ)) (CasADi VM).

    exp6 is :func:`~coop_ga.kinematics.chains.integrate_symbolic` of a lone free flyer (``pinocchio.integrate``
    exactly); log6 to second order: with Y = exp6(ξ)⁻¹ exp6(ξ + δ) = I + X (X = O(δ)), ``log Y = X − ½X² + O(δ³)``,
    whose top-right block is m's translation part ν and whose skew-symmetric 3 × 3 block is ω^.  ∂m/∂δ is the SE(3)
    right Jacobian (``pinocchio.Jexp6``), here exact at every angle (Pinocchio's loses ~1e-7 near 1e-3 rad, which
    differences of it magnify), so the chart's gradient and Hessian come from one expression."""
    import casadi as ca
    import pinocchio as pin

    from ...kinematics.chains import integrate_symbolic

    m = pin.Model()
    m.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "flyer")
    xi, d, g = ca.SX.sym("xi", 6), ca.SX.sym("d", 6), ca.SX.sym("g", 6)
    origin = ca.DM([0, 0, 0, 0, 0, 0, 1])

    def pose(v: Any) -> tuple[Any, Any]:
        q = integrate_symbolic(m, origin, v)
        x, y, z, w = q[3], q[4], q[5], q[6]
        R = ca.vertcat(
            ca.horzcat(1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
            ca.horzcat(2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
            ca.horzcat(2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)),
        )
        return R, q[:3]

    R0, t0 = pose(xi)
    R1, t1 = pose(xi + d)
    A = ca.mtimes(R0.T, R1) - ca.SX.eye(3)  # Y − I: rotation block
    b = ca.mtimes(R0.T, t1 - t0)  # Y − I: translation block
    L = A - 0.5 * ca.mtimes(A, A)  # log Y to second order (rotation block)
    mv = ca.vertcat(
        b - 0.5 * ca.mtimes(A, b), 0.5 * ca.vertcat(L[2, 1] - L[1, 2], L[0, 2] - L[2, 0], L[1, 0] - L[0, 1])
    )
    H, _ = ca.hessian(ca.dot(g, mv), d)
    f = ca.Function("flyer_chart_at", [xi, g, d], [ca.jacobian(mv, d), H])
    zero = ca.DM.zeros(6)
    return ca.Function("flyer_chart", [xi, g], list(f(xi, g, zero)))


def flyer_jacobian(xi: Any) -> np.ndarray:
    """(6, 6): ``∂m/∂δ`` at δ = 0, m(δ) = log6(exp6(ξ)⁻¹ exp6(ξ + δ)) — the derivative of one free flyer's chart
    ``ξ ↦ q_ref ⊕ ξ`` in the tangent space at q_ref ⊕ ξ (the SE(3) right Jacobian, ``pinocchio.Jexp6``; the
    identity at ξ = 0); ξ (6,) [m, rad] in LOCAL [v; ω] order."""
    return np.asarray(_chart_function()(validation.vector(xi, 6, "xi"), np.zeros(6))[0], dtype=float)


def flyer_curvature(xi: Any, g: Any) -> np.ndarray:
    """(6, 6): ``∇²_δ gᵀ m(δ)`` at δ = 0 with ``m(δ) = log6(exp6(ξ)⁻¹ exp6(ξ + δ))`` — the second derivative of the
    chart ``ξ ↦ q_ref ⊕ ξ`` of one free flyer seen in the tangent space at q_ref ⊕ ξ, weighted by the tangent
    gradient g (6,) (LOCAL [v; ω] order); ξ (6,) [m, rad] its chart coordinates.  Zero at ξ = 0 (m(δ) = δ
    there): the chart's curvature shows only away from its centre."""
    xv = validation.vector(xi, 6, "xi")
    gv = validation.vector(g, 6, "g")
    return np.asarray(_chart_function()(xv, gv)[1], dtype=float)


class FlyerChart:
    """The chart ``q(x) = q_ref ⊕ (x − c)`` of a system with a free flyer (module docstring).

    Args:
        system: a :class:`coop_ga.systems.System` (nq ≠ nv).
        q_ref: (nq,) the chart's centre (unit quaternions, checked).
    """

    def __init__(self, system: Any, q_ref: Any):
        import pinocchio as pin

        self.system = system
        self.model = system.model
        self._pin = pin
        m = self.model
        #: the velocity index of each free flyer's six velocities
        self.flyers = tuple(
            int(m.idx_vs[j]) for j in range(1, m.njoints) if m.joints[j].shortname() == "JointModelFreeFlyer"
        )
        self.recentre(q_ref)

    def recentre(self, q_ref: Any, what: str = "q_init") -> None:
        """Move the chart's centre to q_ref (nq,) (its quaternions checked: ``what`` names it in the error)."""
        s = self.system
        q = validation.configuration(q_ref, s.nq, what, owner=f"system '{s.name}'", joint_names=s.joint_names)
        s.check_quaternions(q, what)
        self.q_ref = q
        self.c = self.system.limit_coordinates(q)

    def to_q(self, x: np.ndarray) -> np.ndarray:
        """q(x) (nq,) of chart coordinates x (nv,)."""
        return np.asarray(self._pin.integrate(self.model, self.q_ref, np.asarray(x, float) - self.c))

    def to_q_trajectory(self, X: np.ndarray) -> np.ndarray:
        """q(x_k) (K, nq) of chart coordinates X (K, nv)."""
        return np.array([self.to_q(x) for x in X]).reshape(len(X), self.model.nq)

    def from_q(self, q: Any) -> np.ndarray:
        """The chart coordinates x (nv,) of q (nq,): ``c + difference(q_ref, q)``."""
        return self.c + self.system.difference(self.q_ref, q)

    def dq(self, x: np.ndarray) -> np.ndarray:
        """D(x) = ∂(q_ref ⊕ ξ)/∂ξ (nv, nv) at ξ = x − c (what ``pinocchio.dIntegrate`` gives, computed by
        :func:`flyer_jacobian` on each flyer's block): a chart velocity ẋ moves q(x) by the tangent velocity D ẋ (the identity at x = c and on the
        1-DOF joints)."""
        D = np.eye(self.model.nv)
        xi = np.asarray(x, float) - self.c
        for i in self.flyers:
            D[i : i + 6, i : i + 6] = flyer_jacobian(xi[i : i + 6])
        return D

    def curvature(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """(nv, nv): :func:`flyer_curvature` of every free flyer on its block (zero elsewhere: ⊕ is linear on the
        1-DOF joints), for the tangent gradient g (nv,) at q(x)."""
        out = np.zeros((self.model.nv, self.model.nv))
        xi = np.asarray(x, float) - self.c
        for i in self.flyers:
            out[i : i + 6, i : i + 6] = flyer_curvature(xi[i : i + 6], g[i : i + 6])
        return out


@dataclasses.dataclass(frozen=True)
class _ChartSystem:
    """What the iLQR reads of a system, in the chart: nq = nv coordinates bounded by the system's limits."""

    name: str
    limits: Any

    @property
    def nq(self) -> int:
        return len(self.limits.joint_names)

    nv = nq

    def limit_coordinates(self, x: Any) -> np.ndarray:
        return np.asarray(x, dtype=float)


class ChartTask:
    """A cooperative task seen in a :class:`FlyerChart`: the same error, its Jacobian and Hessian in the chart
    coordinates x (nv,) — what :func:`~coop_ga.control.ilqr.ilqr_reach` reads of a task (module docstring).

    ``nq = nv``; ``system`` carries the name and the limits (one per velocity, a free flyer's unbounded); no
    ``tree``, so the unreachability certificate is off (a free flyer's reach has no bound).
    """

    def __init__(self, task: Any, chart: FlyerChart):
        self.base, self.chart = task, chart
        self.nq = self.nv = int(task.nv)
        self.kind, self.name, self.graph = task.kind, task.name, task.graph
        self.system = _ChartSystem(str(task.system.name), task.system.limits)

    def check_target(self, target: SimilarityLike, what: str = "target") -> Any:
        return self.base.check_target(target, what)

    def chart_angle(self, x: Any) -> float:
        return float(self.base.chart_angle(self.chart.to_q(x)))

    def error(self, x: Any, target: SimilarityLike) -> np.ndarray:
        """e(q(x)) (7,)."""
        return self.base.error(self.chart.to_q(x), target)

    def error_and_jacobian(self, x: Any, target: SimilarityLike) -> tuple[np.ndarray, np.ndarray]:
        """``(e (7,), ∂e/∂x (7, nv))`` at q(x): the task's tangent Jacobian times D(x)."""
        e, J = self.base.error_and_jacobian(self.chart.to_q(x), target)
        return e, J @ self.chart.dq(x)

    def error_hessian(self, x: Any, target: SimilarityLike, w: Any) -> np.ndarray:
        """``∇²_x (wᵀ e(q(x)))`` (nv, nv), w (7,) held constant: ``Dᵀ H D`` + the chart's curvature (module
        docstring), H the task's Hessian along the tangent space at q(x)."""
        q = self.chart.to_q(x)
        H = self.base.error_hessian(q, target, w)
        _, J = self.base.error_and_jacobian(q, target)
        D = self.chart.dq(x)
        return D.T @ H @ D + self.chart.curvature(x, J.T @ np.asarray(w, float))


class ChartClearance:
    """A :class:`~coop_ga.control.avoidance.ClearanceCost` seen in a :class:`FlyerChart`: the same values at q(x),
    gradients and Jacobian rows times D(x) (what the iLQR's :class:`~coop_ga.control.ilqr.ReachingOCP` reads)."""

    def __init__(self, cost: Any, chart: FlyerChart):
        self.base, self.chart = cost, chart
        self.weight, self.activation, self.model = cost.weight, cost.activation, cost.model

    def evaluate(self, x: np.ndarray, hessian: bool = True) -> tuple[float, np.ndarray, np.ndarray | None, float]:
        """``(c, ∇_x c (nv,), Gauss–Newton Hessian (nv, nv) or None, min clearance [m])`` at q(x)."""
        c, g, H, d = self.base.evaluate(self.chart.to_q(x), hessian)
        D = self.chart.dq(x)
        return c, D.T @ g, (None if H is None else D.T @ H @ D), d

    def value(self, x: np.ndarray) -> float:
        return float(self.base.value(self.chart.to_q(x)))

    def trajectory_value(self, X: np.ndarray, lookahead: float = 0.0) -> float:
        return float(self.base.trajectory_value(self.chart.to_q_trajectory(X), lookahead))

    def trajectory_min(self, X: np.ndarray, cutoff: float = np.inf) -> float:
        return float(self.base.trajectory_min(self.chart.to_q_trajectory(X), cutoff))

    def trajectory_pairs(self, X: np.ndarray, lookahead: float = 0.0) -> np.ndarray | None:
        """The collision model's pair of each row along q(X) (:meth:`~coop_ga.control.avoidance.ClearanceCost.trajectory_pairs`)."""
        return self.base.trajectory_pairs(self.chart.to_q_trajectory(X), lookahead)

    def trajectory_rows(self, X: np.ndarray, lookahead: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The cost's rows along q(X) (:meth:`~coop_ga.control.avoidance.ClearanceCost.trajectory_rows`), each
        Jacobian row times D at its knot."""
        k, v, J = self.base.trajectory_rows(self.chart.to_q_trajectory(X), lookahead)
        J = np.array(J, dtype=float)
        for kk in np.unique(k):
            sel = k == kk
            J[sel] = J[sel] @ self.chart.dq(X[kk])
        return k, v, J


def to_manifold(res: ILQRResult, chart: FlyerChart) -> ILQRResult:
    """The chart's result with its states on the manifold: ``trajectory`` (n+1, nq) = q(x_k), ``q`` its last row,
    ``qd`` (n+1, nv) the tangent velocities D(x_k) ẋ_k (LOCAL twist for a free flyer); ``u`` (n, nv) stays the
    chart's accelerations ẍ_k (the joints' accelerations; the flyer's equals its twist rate at x = c, i.e. u_0)."""
    X, Xd = np.asarray(res.trajectory), np.asarray(res.qd)
    Q = chart.to_q_trajectory(X)
    V = np.array([chart.dq(x) @ xd for x, xd in zip(X, Xd)])
    return dataclasses.replace(res, q=Q[-1].copy(), trajectory=Q, qd=V)


def chart_problem(task: Any, q_ref: Any, o: ILQROptions) -> tuple[FlyerChart, ChartTask, ILQROptions]:
    """The chart centred at q_ref (nq,) of a task on a free flyer, the task in it, and the options with the
    clearance cost (if any) seen in it: everything the iLQR reads, in chart coordinates."""
    chart = FlyerChart(task.system, q_ref)
    if o.clearance is not None:
        o = dataclasses.replace(o, clearance=ChartClearance(o.clearance, chart))
    return chart, ChartTask(task, chart), o


def chart_reach(
    task: Any, q_init: Any, target: SimilarityLike, o: ILQROptions, qd_init: Any = None, u_init: Any = None
) -> ILQRResult:
    """:func:`~coop_ga.control.ilqr.ilqr_reach` on a task whose system has a free flyer: the same solve in the chart
    centred at q_init (module docstring), mapped back by :func:`to_manifold`.  ``qd_init`` (nv,): the tangent
    velocity at q_init (= the chart velocity there); ``u_init`` (n, nv): chart accelerations.  A quaternion of
    q_init that is not unit raises :class:`~coop_ga.errors.InvalidInputError`."""
    from .solver import ilqr_reach

    chart, ctask, oc = chart_problem(task, q_init, o)
    return to_manifold(ilqr_reach(ctask, chart.c, target, oc, qd_init=qd_init, u_init=u_init), chart)
