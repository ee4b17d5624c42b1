"""The augmented merit of a control sequence and the terminal models built from its evaluation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...diagnostics import collect_warnings
from ...errors import DegeneratePrimitiveError
from .lq import add_state_hessian
from .problem import ClearanceRows, ReachingOCP

__all__ = [
    "CLEARANCE_LOOKAHEAD",
    "Evaluation",
    "Merit",
    "StateTerms",
    "gauss_newton_hessian",
    "multiplier_estimate",
    "terminal_model",
]


#: The LQ model of a clearance cost holds the rows within this many activation distances beyond activation
#: (:class:`~coop_ga.control.ilqr.problem.ClearanceRows`): a step that brings them within d_a pays for them in the
#: model (its active set, :func:`~coop_ga.control.ilqr.lq.condensed_rows_step`), not only in the line search.
#: Measured (iterations on the obstacle scene of benchmarks/ocp.py / of tests/control/test_avoidance.py): 0.3: 12 / 14,
#: 0.5: 15 / 23, 1.0: 12 / 22 — and more rows cost more Jacobians per iteration.
CLEARANCE_LOOKAHEAD = 0.3


@dataclass(frozen=True)
class Evaluation:
    """Everything the solver needs at one control sequence u (:meth:`Merit.evaluate`).

    u (n, nq) [rad/s²]; q, qd (n+1, nq) its trajectory [rad, rad/s]; e (7,) the terminal error e(q_n) (Eq 44) and
    es = e + s the shifted one; Je (7, nq) = ∂e/∂q at q_n (Eq 47); cost: J(u) (Eq 53, plus the clearance cost);
    merit: the augmented merit (running + shifted terminal + AL terms); c (n, 4, nq) the inequalities c ≤ 0 at the
    knots 1 … n (:meth:`ReachingOCP.constraint_values`); z (n, 4, nq) = max(0, λ + μc); violation: the largest
    c, or 0; clearance: the clearance cost's part of cost (0 without one).
    """

    u: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    e: np.ndarray
    es: np.ndarray
    Je: np.ndarray
    cost: float
    merit: float
    c: np.ndarray
    z: np.ndarray
    violation: float
    clearance: float = 0.0

    @property
    def error(self) -> float:
        """‖e(q_n)‖."""
        return float(np.linalg.norm(self.e))


@dataclass(frozen=True)
class StateTerms:
    """Gradients lx (n+1, 2nq) and Hessians lxx of the state costs at the knots (row 0 unused): diagonal
    (n+1, 2nq) (the AL terms) or full (n+1, 2nq, 2nq) (with a clearance cost within its activation distance);
    ``active``: whether any term is nonzero; ``al``: whether an AL term is (then the closed-form step, which
    knows no AL terms, is not used); ``rows``: the clearance cost's active rows (None: none, or a clearance cost
    that cannot list them — then ``active`` alone sends the step to the Riccati pass); ``clearance_gradient``
    (n+1, nq): the clearance cost's gradient w.r.t. q_k (zero without one); ``row_pairs`` (m,): the collision
    model's pair (row of its labels) of each of ``rows``, where the model can say (:meth:`Merit.rows_with_pairs`)."""

    lx: np.ndarray
    lxx: np.ndarray
    active: bool
    al: bool = False
    rows: ClearanceRows | None = None
    clearance_gradient: np.ndarray | None = None
    row_pairs: np.ndarray | None = None


class Merit:
    """Running + terminal (shifted) + augmented-Lagrangian terms of a control sequence.

    Each inequality c ≤ 0 (position and velocity bounds at the knots) enters as
    ``(1/2μ)(max(0, λ + μc)² − λ²)`` (Powell–Hestenes–Rockafellar), with multiplier λ ≥ 0 and
    penalty μ: exactly zero while the trajectory is inside (and λ = 0), so the unconstrained fast
    path solves every problem whose optimum does not touch a bound.
    """

    def __init__(self, ocp: ReachingOCP, mu: float):
        self.ocp = ocp
        self.shift = np.zeros(7)  # s: terminal multiplier / (2Q)  (terminal="constraint")
        T, n = ocp.horizon, ocp.nq
        self.lam = np.zeros((T, 4, n))
        self.mu = mu
        self.lookahead = CLEARANCE_LOOKAHEAD * float(getattr(ocp.clearance, "activation", 0.0))

    def evaluate(self, u: np.ndarray) -> Evaluation | None:
        """Everything at u: trajectory, e, J_e, cost, merit, AL terms; None if degenerate."""
        ocp = self.ocp
        q, qd = ocp.rollout(u)
        try:
            with collect_warnings(silent=True):  # trial points: degeneracy is a rejection, not news
                e, Je = ocp.task.error_and_jacobian(q[-1], ocp.target)
        except DegeneratePrimitiveError:
            return None
        # the clearance cost is a running (state) cost; its pairs within the LQ model's look-ahead are computed now,
        # so that the next iteration's rows at an accepted point reuse them (state_terms)
        clearance = ocp.clearance_cost(q, self.lookahead)
        run = ocp.running_cost(u) + clearance
        es = e + self.shift
        lf = float(es @ ocp.Q @ es + qd[-1] @ ocp.Qv @ qd[-1])
        cost = run + float(e @ ocp.Q @ e + qd[-1] @ ocp.Qv @ qd[-1])
        c = ocp.constraint_values(q, qd)
        al = 0.0
        if self.mu > 0:
            z = np.maximum(0.0, self.lam + self.mu * c)
            al = float(np.sum(z * z - self.lam * self.lam)) / (2.0 * self.mu)
        else:
            z = np.zeros_like(c)
        return Evaluation(
            u=u,
            q=q,
            qd=qd,
            e=e,
            es=es,
            Je=Je,
            cost=cost,
            merit=run + lf + al,
            c=c,
            z=z,
            violation=float(max(np.max(c, initial=0.0), 0.0)),
            clearance=clearance,
        )

    def rows_with_pairs(self, q: np.ndarray, lookahead: float) -> tuple[ClearanceRows | None, np.ndarray | None]:
        """The clearance rows of the trajectory q (n+1, nq) within ``lookahead`` [m] of activation
        (:meth:`ReachingOCP.clearance_rows`) and the collision model's pair (m,) of each of them (None where the
        clearance cost cannot list its rows or their pairs (``trajectory_pairs``): from the pair list that computed
        the rows, so no distance is computed twice)."""
        ocp = self.ocp
        rows = ocp.clearance_rows(q, lookahead)
        pairs_of = getattr(ocp.clearance, "trajectory_pairs", None)
        pairs = pairs_of(q[1:], lookahead) if rows is not None and callable(pairs_of) else None
        if rows is None or pairs is None:
            return rows, None
        return rows, pairs if pairs.shape == rows.v.shape else None

    def state_terms(self, ev: Evaluation) -> StateTerms:
        """The AL terms at the knots (their diagonal Hessians), plus the clearance cost's (full Hessians) while a pair
        is within its activation distance."""
        ocp = self.ocp
        T, n = ocp.horizon, ocp.nq
        lx = np.zeros((T + 1, 2 * n))
        lxx = np.zeros((T + 1, 2 * n))
        z = ev.z
        active = z > 0
        al_active = bool(self.mu > 0 and active.any())
        if al_active:
            # c = [q − hi, lo − q, q̇ − v, −v − q̇]: ∂c/∂q = (+1, −1), ∂c/∂q̇ = (+1, −1)
            lx[1:, :n] = z[:, 0] - z[:, 1]
            lx[1:, n:] = z[:, 2] - z[:, 3]
            lxx[1:, :n] = self.mu * (active[:, 0] | active[:, 1])
            lxx[1:, n:] = self.mu * (active[:, 2] | active[:, 3])
        if ocp.clearance is None:
            return StateTerms(lx, lxx, al_active, al_active)
        rows, pairs = self.rows_with_pairs(ev.q, self.lookahead)
        if rows is not None:
            g, H, c_active = rows.gradient(T, n), rows.hessians(T, n), bool(rows.knots.size)  # active or near
        else:
            g, H, c_active = ocp.clearance_terms(ev.q)
        if not c_active:
            return StateTerms(lx, lxx, al_active, al_active)
        full = np.zeros((T + 1, 2 * n, 2 * n))
        idx = np.arange(2 * n)
        full[:, idx, idx] = lxx
        full[:, :n, :n] += H
        lx[:, :n] += g
        return StateTerms(lx, full, True, al_active, rows, g, pairs)


def multiplier_estimate(ocp: ReachingOCP, ev: Evaluation, ck: np.ndarray) -> np.ndarray:
    """Least-squares multiplier w (7,) of the reaching condition from stationarity of the running cost.

    ``2R u_k + Bᵀλ_{k+1} = 0`` with ``λ_n = [J_eᵀ w; 2Q_v q̇_n]`` and ``λ_k = Aᵀλ_{k+1}`` gives
    ``2R u_k + c_k J_eᵀ w + 2Δt Q_v q̇_n = 0`` for every k; w minimises the residual over k.
    (At the optimum it is the exact multiplier; unlike the penalty's own ``2Q(e + s)`` it does
    not overshoot far from the optimum, where Q ≫ the multiplier.)  The AL state terms are
    left out: they are zero unless a bound is active.
    """
    u, Je, qdn = ev.u, ev.Je, ev.qd[-1]
    b = u @ ocp.R2.T + (2.0 * ocp.dt) * (ocp.Qv @ qdn)[None, :]  # (T, n): 2R u_k + 2Δt Q_v q̇_n
    # controls at their acceleration bound are not stationary: leave them out, joint by joint
    free = ~(np.abs(u) >= ocp.a_max * (1.0 - 1e-9)) if ocp.u_bounded else np.ones(u.shape, dtype=bool)
    c = ck[:, None] * free
    W = np.sum(c * c, axis=0)  # (n,): information about joint j's multiplier
    abar = np.where(W > 0, np.sum(c * b, axis=0) / np.where(W > 0, W, 1.0), 0.0)
    sw = np.sqrt(W / max(float(W.max()), 1e-300))
    # joints at a terminal position bound carry their own multiplier ν_j (unknowns beside w)
    qn = ev.q[-1]
    at = np.flatnonzero((qn <= ocp.q_lower + 1e-9) | (qn >= ocp.q_upper - 1e-9))
    A = Je.T if not at.size else np.hstack([Je.T, np.eye(ocp.nq)[:, at]])
    return -np.linalg.lstsq(sw[:, None] * A, sw * abar, rcond=1e-10)[0][:7]


def terminal_model(ocp: ReachingOCP, ev: Evaluation, w: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Gradient (2nq) and Hessian (2nq × 2nq) of the (shifted) terminal cost at ev's x_n; with a
    multiplier w, the Newton model ``2J_eᵀQJ_e + ∇²_q(wᵀe)``, else Gauss–Newton."""
    n = ocp.nq
    Je, es, qdn = ev.Je, ev.es, ev.qd[-1]
    H = np.zeros((2 * n, 2 * n))
    H[:n, :n] = 2.0 * Je.T @ (ocp.Q @ Je)
    H[n:, n:] = 2.0 * ocp.Qv
    if w is not None and np.any(w != 0):
        H[:n, :n] += ocp.task.error_hessian(ev.q[-1], ocp.target, w)
    g = np.concatenate([2.0 * Je.T @ (ocp.Q @ es), 2.0 * ocp.Qv @ qdn])
    return g, H


def gauss_newton_hessian(ocp: ReachingOCP, ev: Evaluation, lxx_n: np.ndarray) -> np.ndarray:
    """Gauss–Newton terminal Hessian plus the knot-n AL Hessian."""
    n = ocp.nq
    Je = ev.Je
    H = np.zeros((2 * n, 2 * n))
    H[:n, :n] = 2.0 * Je.T @ (ocp.Q @ Je)
    H[n:, n:] = 2.0 * ocp.Qv
    add_state_hessian(H, lxx_n)
    return H
