"""The reaching problem of Eq 53–57: double-integrator dynamics, costs, bounds (:class:`ReachingOCP`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import validation
from ...errors import InvalidInputError
from ...geometry.groups import SimilarityLike
from ..base import check_problem, check_q

__all__ = ["DEFAULT_Q", "DEFAULT_QV", "DEFAULT_R", "ClearanceRows", "ReachingOCP", "check_clearance"]

#: Default control weight R (scalar → R · I) [1/(rad/s²)²].
DEFAULT_R = 1e-3
#: Default precision Q of the terminal similarity error (scalar → Q · I_7): the penalty of the
#: terminal constraint (``terminal="constraint"``) or the weight of Eq 57 (``"soft"``).
DEFAULT_Q = 1e5
#: Default weight of the terminal rest term q̇_nᵀ Q_v q̇_n [1/(rad/s)²] (scalar → Q_v · I).
DEFAULT_QV = 1e2


def check_clearance(c: Any) -> Any:
    """None or a clearance cost (``evaluate(q)`` and ``value(q)``, :class:`coop_ga.control.avoidance.ClearanceCost`)."""
    if c is None or (callable(getattr(c, "evaluate", None)) and callable(getattr(c, "value", None))):
        return c
    raise InvalidInputError(
        f"clearance must be None or a coop_ga.control.avoidance.ClearanceCost, got {type(c).__name__}"
    )


@dataclass(frozen=True)
class ClearanceRows:
    """The rows of a clearance cost near activation along a trajectory, as the LQ model sees them: row r at knot
    ``knots[r]`` (1 … n) with ``v_r = d_a − d_r`` [m] (> 0: active) and ``J[r] = ∂d_r/∂q`` (m, nq) contributes
    ``½ w max(0, v_r − J_r δq_k)²`` to the model (w: the weight [1/m²]); rows with v_r ≤ 0 (within the
    model's look-ahead margin of activation) cost nothing now but enter once a step brings them within d_a."""

    knots: np.ndarray
    J: np.ndarray
    v: np.ndarray
    w: float

    def active(self) -> ClearanceRows:
        """The rows with v > 0 (the cost's own terms at the trajectory)."""
        a = self.v > 0
        return ClearanceRows(self.knots[a], self.J[a], self.v[a], self.w)

    def gradient(self, T: int, nq: int) -> np.ndarray:
        """(T+1, nq): the cost's gradient w.r.t. q_k at every knot, ``−w Σ_{r at k, v_r > 0} v_r J_r`` (row 0 zero)."""
        g = np.zeros((T + 1, nq))
        np.add.at(g, self.knots, (-self.w * np.maximum(self.v, 0.0))[:, None] * self.J)
        return g

    def hessians(self, T: int, nq: int) -> np.ndarray:
        """(T+1, nq, nq): the Gauss–Newton Hessians ``w Σ_{r at k, v_r > 0} J_rᵀ J_r`` at every knot."""
        H = np.zeros((T + 1, nq, nq))
        a = self.active()
        np.add.at(H, a.knots, self.w * a.J[:, :, None] * a.J[:, None, :])
        return H


class ReachingOCP:
    """The reaching problem of Eq 53–57 for a cooperative task (:mod:`coop_ga.control.ilqr`).

    Args:
        task: a :class:`coop_ga.CooperativeTask` (V_Sc(q), e and J_e, Eq 28, 44, 47).
        q_init: (nq,) initial joint configuration q_0 [rad].
        target: V_Sd, a :class:`~coop_ga.Similarity`.  It must describe a primitive of the
            task's kind (e.g. from :func:`displaced_target`); otherwise the terminal error cannot
            reach zero.
        qd_init: (nq,) initial joint velocity [rad/s] (default 0).
        horizon: number of control knots n (states x_0 … x_n).
        dt: time step Δt [s].
        R: control weight (scalar, (nq,) or (nq, nq); positive definite).
        Q: precision of the terminal similarity error (scalar, (7,) or (7, 7); PSD).
        Qv: terminal velocity weight (scalar, (nq,) or (nq, nq); PSD; 0 = paper's Eq 57 only).
        limit_mode: ``"enforce"`` (default: the bounds of ``task.system.limits``) or ``"none"``.
        clearance: a :class:`coop_ga.control.avoidance.ClearanceCost` (a running cost on the
            clearances at the knots 1 … n, :mod:`coop_ga.control.ilqr`) or None (default).

    The total cost is ``J(u) = Σ_k u_kᵀ R u_k + e(q_n)ᵀ Q e(q_n) + q̇_nᵀ Q_v q̇_n`` (+ ``Σ_{k≥1} c(q_k)``
    with a clearance cost).
    """

    def __init__(
        self,
        task: Any,
        q_init: Any,
        target: SimilarityLike,
        *,
        qd_init: Any = None,
        horizon: int = 250,
        dt: float = 0.01,
        R: Any = DEFAULT_R,
        Q: Any = DEFAULT_Q,
        Qv: Any = DEFAULT_QV,
        limit_mode: str = "enforce",
        clearance: Any = None,
    ):
        self.task = task
        self.clearance = check_clearance(clearance)
        self.nq = n = int(task.nq)
        self.q_init, self.target = check_problem(task, q_init, target, "q_init")
        self.qd_init = np.zeros(n) if qd_init is None else check_q(task, qd_init, "qd_init")
        self.horizon = validation.integer(horizon, "horizon", minimum=2)  # ≥ 2: x_n must be controllable
        self.dt = validation.positive(dt, "dt")
        self.R = validation.weight(R, n, "R", definite=True)
        self.Q = validation.weight(Q, 7, "Q", definite=False)
        self.Qv = validation.weight(Qv, n, "Qv", definite=False)
        self.limit_mode = validation.choice(limit_mode, ("enforce", "none"), "limit_mode")
        self.R2 = 2.0 * self.R
        self.h = 0.5 * self.dt * self.dt
        # Dense A, B for reference and for other solvers (benchmarks); the iLQR uses blocks.
        eye = np.eye(n)
        self.A = np.block([[eye, self.dt * eye], [np.zeros((n, n)), eye]])
        self.B = np.vstack([self.h * eye, self.dt * eye])
        lim = task.system.limits
        inf = np.full(n, np.inf)
        if self.limit_mode == "enforce":
            self.q_lower, self.q_upper = lim.lower.copy(), lim.upper.copy()
            self.v_max, self.a_max = lim.velocity.copy(), lim.acceleration.copy()
        else:
            self.q_lower, self.q_upper, self.v_max, self.a_max = -inf, inf.copy(), inf.copy(), inf.copy()
        self.joint_names = tuple(lim.joint_names)

    # ------------------------------------------------------------------ dynamics
    @property
    def times(self) -> np.ndarray:
        """(n+1,) knot times [s]."""
        return self.dt * np.arange(self.horizon + 1)

    def rollout(self, u: Any) -> tuple[np.ndarray, np.ndarray]:
        """Integrate the double integrator: ``u`` (n, nq) → ``q, q̇`` (n+1, nq) (Eq 54, exact ZOH)."""
        u = self.check_controls(u)
        qd = np.empty((self.horizon + 1, self.nq))
        qd[0] = self.qd_init
        np.cumsum(self.dt * u, axis=0, out=qd[1:])
        qd[1:] += self.qd_init
        q = np.empty_like(qd)
        q[0] = self.q_init
        np.cumsum(self.dt * qd[:-1] + self.h * u, axis=0, out=q[1:])
        q[1:] += self.q_init
        return q, qd

    def check_controls(self, u: Any) -> np.ndarray:
        """Controls (n, nq) [rad/s²] as a checked float array."""
        return validation.array(u, "controls", shape=(self.horizon, self.nq))

    # ------------------------------------------------------------------ costs
    def running_cost(self, u: np.ndarray) -> float:
        """Σ_k u_kᵀ R u_k (Eq 56)."""
        return float(np.einsum("ki,ij,kj->", u, self.R, u))

    def terminal(self, q_n: np.ndarray, qd_n: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """``(l_f, e (7,), J_e (7, nq))`` at the terminal state (Eq 57 + rest term)."""
        e, Je = self.task.error_and_jacobian(q_n, self.target)
        lf = float(e @ self.Q @ e + qd_n @ self.Qv @ qd_n)
        return lf, e, Je

    def cost(self, u: Any) -> float:
        """Total cost J(u) (Eq 53 with Eq 56–57, plus the clearance cost if any)."""
        u = self.check_controls(u)
        q, qd = self.rollout(u)
        return self.running_cost(u) + self.terminal(q[-1], qd[-1])[0] + self.clearance_cost(q)

    def clearance_cost(self, q: np.ndarray, lookahead: float = 0.0) -> float:
        """``Σ_{k=1}^{n} c(q_k)`` of the clearance cost (0 without one); q (n+1, nq).  ``lookahead`` [m]: passed to
        a batched cost (``trajectory_value``: it then keeps the rows within that distance of activation for a
        following :meth:`clearance_rows` of the same q; the value is the same)."""
        if self.clearance is None:
            return 0.0
        batch = getattr(self.clearance, "trajectory_value", None)
        if callable(batch):
            return float(batch(q[1:], lookahead) if lookahead > 0 else batch(q[1:]))
        return float(sum(self.clearance.value(qk) for qk in q[1:]))

    def min_clearance(self, q: np.ndarray, cutoff: float = np.inf) -> float:
        """The smallest clearance [m] of the collision model over the configurations q (K, nq) (``inf`` without a
        clearance cost): one batched evaluation where the cost has one (``trajectory_min``), else knot by knot.
        A finite ``cutoff`` [m]: the smallest clearance below it, or ``inf`` (only the pairs below it computed)."""
        if self.clearance is None:
            return float(np.inf)
        batch = getattr(self.clearance, "trajectory_min", None)
        if callable(batch):
            return float(batch(q) if cutoff == np.inf else batch(q, cutoff))
        d_min = float(min(self.clearance.evaluate(qk, hessian=False)[3] for qk in q))
        return d_min if d_min < cutoff else float(np.inf)

    def clearance_rows(self, q: np.ndarray, lookahead: float = 0.0) -> ClearanceRows | None:
        """The rows of the clearance cost within ``lookahead`` [m] of activation at the knots 1 … n of q (n+1, nq)
        (:class:`ClearanceRows`), or None when the clearance cost cannot list them (then :meth:`clearance_terms`
        evaluates it knot by knot)."""
        rows = getattr(self.clearance, "trajectory_rows", None)
        if not callable(rows):
            return None
        k, v, J = rows(q[1:], lookahead)
        return ClearanceRows(knots=np.asarray(k, int) + 1, J=J, v=v, w=float(self.clearance.weight))

    def clearance_terms(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        """Gradients (n+1, nq) and Gauss–Newton Hessians (n+1, nq, nq) of the clearance cost at the
        knots (row 0 zero), and whether any pair is within the activation distance."""
        T, n = self.horizon, self.nq
        if self.clearance is None:
            return np.zeros((T + 1, n)), np.zeros((T + 1, n, n)), False
        rows = self.clearance_rows(q)
        if rows is not None:
            return rows.gradient(T, n), rows.hessians(T, n), bool(np.any(rows.v > 0))
        g = np.zeros((T + 1, n))
        H = np.zeros((T + 1, n, n))
        for k in range(1, T + 1):
            _, g[k], Hk, _ = self.clearance.evaluate(q[k])
            assert Hk is not None  # hessian=True
            H[k] = Hk
        return g, H, bool(np.any(g))

    def gradient(self, u: Any) -> np.ndarray:
        """∂J/∂u (n, nq) by the adjoint recursion ``λ_n = ∇l_f``, ``λ_k = Aᵀ λ_{k+1}``,
        ``∂J/∂u_k = 2R u_k + Bᵀ λ_{k+1}`` (exact, with the exact J_e of Eq 47)."""
        u = self.check_controls(u)
        q, qd = self.rollout(u)
        _, e, Je = self.terminal(q[-1], qd[-1])
        lq = 2.0 * Je.T @ (self.Q @ e)
        lv = 2.0 * self.Qv @ qd[-1]
        # λ_{k+1} = (A^T)^{n-1-k} λ_n: the q-part stays lq, the v-part is lv + (n-1-k) Δt lq
        m = np.arange(self.horizon - 1, -1, -1, dtype=float)[:, None]  # n-1-k
        lam_v = lv[None, :] + (m * self.dt) * lq[None, :]
        grad = u @ self.R2.T + self.h * lq[None, :] + self.dt * lam_v
        if self.clearance is not None:
            # ∂q_k/∂u_j = (h + (k−1−j) Δt²) I for k > j: with A_m = Σ_{k≥m} g_k and B_m = Σ_{k≥m} k g_k,
            # Σ_{k>j} (h + (k−1−j)Δt²) g_k = h A_{j+1} + Δt² (B_{j+1} − (j+1) A_{j+1})
            g, _, _ = self.clearance_terms(q)
            kk = np.arange(self.horizon + 1, dtype=float)[:, None]
            A = np.cumsum(g[::-1], axis=0)[::-1]
            B = np.cumsum((kk * g)[::-1], axis=0)[::-1]
            j1 = kk[1:]
            grad = grad + self.h * A[1:] + self.dt**2 * (B[1:] - j1 * A[1:])
        return grad

    # ------------------------------------------------------------------ constraints
    def constraint_values(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Inequalities c ≤ 0 at the knots 1…n, shape (n, 4, nq): ``q − upper, lower − q, q̇ − v, −v − q̇``
        (−inf where a bound is infinite)."""
        with np.errstate(invalid="ignore"):
            c = np.stack(
                [q[1:] - self.q_upper, self.q_lower - q[1:], qd[1:] - self.v_max, -self.v_max - qd[1:]], axis=1
            )
        return np.where(np.isnan(c), -np.inf, c)

    def violation(self, q: np.ndarray, qd: np.ndarray, u: np.ndarray | None = None) -> float:
        """Largest bound violation of a trajectory [rad, rad/s or rad/s²] (0: feasible)."""
        c = self.constraint_values(q, qd)
        v = float(np.max(c, initial=0.0))
        if u is not None:
            v = max(v, float(np.max(np.abs(u) - self.a_max, initial=0.0)))
        return max(v, 0.0)

    @property
    def u_bounded(self) -> bool:
        return bool(np.any(np.isfinite(self.a_max)))
