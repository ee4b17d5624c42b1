"""LQ kernels of the double integrator: the Gramian, the closed-form (condensed) steps, the box QPs and the Riccati
(box-DDP) pass, the roll-outs of a policy, the second-order correction and the minimum-energy controls."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .problem import ClearanceRows, ReachingOCP

__all__ = [
    "Condensation",
    "LQStep",
    "add_state_hessian",
    "backward",
    "backward_box",
    "box_qp",
    "condensed_box_step",
    "condensed_rows_step",
    "condensed_step",
    "control_box_step",
    "controls_to",
    "forward_deviation",
    "gramian",
    "lq_step",
    "policy_rollout",
    "second_order_correction",
]


def add_state_hessian(M: np.ndarray, l: np.ndarray) -> None:
    """M += the state-cost Hessian l of one knot: diagonal (2nq,) or full (2nq, 2nq)."""
    if l.ndim == 1:
        M[np.diag_indices(M.shape[0])] += l
    else:
        M += l


def gramian(ocp: ReachingOCP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients of x_n w.r.t. u: ``c_k`` with ``∂q_n/∂u_k = c_k I``, ``∂q̇_n/∂u_k = Δt I``,
    and the 2×2 factor G2 of the Gramian ``W = Σ_k G_k (2R)⁻¹ G_kᵀ = G2 ⊗ (2R)⁻¹``."""
    T = ocp.horizon
    ck = ocp.h + np.arange(T - 1, -1, -1, dtype=float) * ocp.dt**2
    s1 = float(ck.sum())
    G2 = np.array([[float(ck @ ck), ocp.dt * s1], [ocp.dt * s1, T * ocp.dt**2]])
    return ck, G2, np.linalg.inv(ocp.R2)


def condensed_step(
    ocp: ReachingOCP, u: np.ndarray, Vxx: np.ndarray, vx: np.ndarray, ck: np.ndarray, G2: np.ndarray, R2inv: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The LQ step of the unconstrained problem in closed form through the Gramian.

    With ``x_n = x̄_n + Σ_k G_k δu_k`` (``G_k = [c_k I; Δt I]``) the LQ subproblem
    ``min Σ (u_k+δu_k)ᵀR(u_k+δu_k) + vxᵀδx_n + ½δx_nᵀ V_xx δx_n`` has the stationarity
    conditions ``δu_k = −u_k − (2R)⁻¹ G_kᵀ m``, ``m = vx + V_xx δx_n``, hence one
    2nq×2nq solve ``(I + V_xx W) m = vx − V_xx s`` with ``s = Σ G_k u_k``.  Requires the
    condensed Hessian to be positive definite (``W⁻¹ + V_xx ≻ 0``; raises LinAlgError
    otherwise, like the Cholesky of Q_uu in the Riccati pass).
    Returns ``(δu, δq_n, δq̇_n, d₁)``; the model decrease is ``d₁(α − α²/2)``.
    """
    n, dt = ocp.nq, ocp.dt
    W = np.kron(G2, R2inv)
    np.linalg.cholesky(np.linalg.inv(W) + Vxx)  # positive-definiteness check (LinAlgError)
    sq = ck @ u
    sv = dt * u.sum(axis=0)
    svec = np.concatenate([sq, sv])
    m = np.linalg.solve(np.eye(2 * n) + Vxx @ W, vx - Vxx @ svec)
    du = -u - (np.outer(ck, R2inv @ m[:n]) + dt * (R2inv @ m[n:])[None, :])
    gu = u @ ocp.R2.T + np.outer(ck, vx[:n]) + dt * vx[n:][None, :]
    d1 = float(np.sum(gu * du))
    return du, ck @ du, dt * du.sum(axis=0), d1


def condensed_rows_step(
    ocp: ReachingOCP,
    cond: Condensation,
    u: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    rows: ClearanceRows,
    max_travel: float = np.inf,
    max_sets: int = 8,
) -> tuple[np.ndarray, float, float] | None:
    """The LQ step with the terminal model and the clearance rows, in closed form, with an active set on the rows.

    The model is ``Σ (u+δu)ᵀR(u+δu) + v_xᵀδx_n + ½δx_nᵀV_xxδx_n + Σ_r ½w max(0, v_r − y_r)²`` with
    ``y_r = J_r δq_{k_r}`` (the Gauss–Newton model of the hinge, :class:`ClearanceRows`): convex and piecewise
    quadratic.  For a fixed active set A of rows it is quadratic and minimised in closed form (:class:`_RowsSystem`);
    :func:`_rows_newton` minimises the model by a semi-smooth Newton iteration over the active sets with an exact
    line search, at most ``max_sets`` solves.  Rows not active now enter when the step brings them within d_a, so
    the line search is not left to discover them — unless the first step moves a joint by more than ``max_travel``
    (the line search's trust region): the linearised rows say nothing about where such a step ends.  If the step
    leaves the acceleration box at the largest α the line search tries, the box joins the active set
    (:func:`_box_sets`) and the best step inside it is returned (else the step as it is: :func:`lq_step` then takes
    the Riccati pass).  Returns ``(δu, d1, d2)`` — d1 the exact directional derivative at δu = 0, ``d1 + d2`` the
    model change of the full step — or None (not convex).
    """
    try:
        np.linalg.cholesky(cond.Winv + Vxx)  # the rows add a PSD term: the model is convex when this holds
    except np.linalg.LinAlgError:
        return None
    C = cond.C
    assert C is not None  # built for a problem with a clearance cost
    Ru = u @ ocp.R
    v0 = np.maximum(rows.v, 0.0)
    base = 0.5 * rows.w * float(v0 @ v0)

    def model(du: np.ndarray, dx: np.ndarray, y: np.ndarray) -> float:
        hinge = np.maximum(rows.v - y, 0.0)
        run = float(np.sum((2.0 * Ru + du @ ocp.R) * du))
        return run + float(vx @ dx) + 0.5 * float(dx @ Vxx @ dx) + 0.5 * rows.w * float(hinge @ hinge) - base

    try:
        du, dx, y, act = _rows_newton(ocp, cond, u, Vxx, vx, rows, max_sets, max_travel)
    except np.linalg.LinAlgError:
        return None
    f = model(du, dx, y)
    boxed = _box_sets(ocp, cond, u, Vxx, vx, rows, model, act, du, max_sets, max_travel)
    if boxed is not None:
        f, du, dx, y = boxed
    d1 = 2.0 * float(np.sum(Ru * du)) + float(vx @ dx) - rows.w * float(v0 @ y)
    return du, d1, f - d1


def _box_sets(
    ocp: ReachingOCP,
    cond: Condensation,
    u: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    rows: ClearanceRows,
    model: Callable[[np.ndarray, np.ndarray, np.ndarray], float],
    act: np.ndarray,
    du: np.ndarray,
    max_sets: int,
    max_travel: float,
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray] | None:
    """The step of :func:`condensed_rows_step` with the acceleration box in the active set, when the rows' step ``du``
    leaves the box at the largest α the line search tries (``a = min(1, max_travel / travel)``, as in
    :func:`lq_step`), else None (also when R is not diagonal or no step inside the box is found).

    The box is put on the full step so that ``u + a δu`` stays inside ``|u| ≤ a_max``; the rows and the box then
    share one active-set iteration (:func:`_active_sets`), from the rows of ``du`` and the controls it puts past a
    bound.  ``(f, δu, δx_n, y)``.
    """
    C = cond.C
    assert C is not None
    if not ocp.u_bounded or np.any(ocp.R2 - np.diag(np.diag(ocp.R2))):
        return None
    travel = float(np.max(np.abs(C @ du)))
    a = min(1.0, max_travel / travel) if travel > 0 else 1.0
    a_max = np.broadcast_to(ocp.a_max, u.shape)
    if not np.max(np.abs(u + a * du) - a_max) > 1e-12:
        return None
    bounds = (u - (a_max + u) / a, u + (a_max - u) / a)
    x = u + du
    try:
        out = _active_sets(ocp, cond, u, Vxx, vx, rows, model, act, max_sets, (x > bounds[1], x < bounds[0]), bounds)
    except np.linalg.LinAlgError:
        return None

    return out[:4] if out[5] else None


def _rows_newton(
    ocp: ReachingOCP,
    cond: Condensation,
    u: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    rows: ClearanceRows,
    max_sets: int,
    max_travel: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The minimiser of :func:`condensed_rows_step`'s model (rows only): ``(δu, δx_n, y, act)``, by a semi-smooth
    Newton iteration with an exact line search (the finite Newton method for a convex piecewise-quadratic function).

    From δu = 0 and the rows active there, each iteration solves the quadratic of the current active set in closed
    form (:class:`_RowsSystem`) and moves toward its minimiser by the exact minimiser t ∈ [0, 1] of the model on
    the segment (:func:`_segment_minimiser`), then takes the rows active at the new point.  The model decreases at
    every iteration, so the iteration cannot cycle (measured: jumping to each active set's minimiser without the
    line search did not settle within 8 sets on any step of the obstacle scene of benchmarks/ocp.py, and the
    returned step then depended on where it stopped).  It stops when a full step keeps the active set, or after
    ``max_sets`` solves.  A first minimiser that moves a joint by more than ``max_travel`` (the line search's trust
    region) is returned as it is: the linearised rows say nothing about where it ends.
    """
    C = cond.C
    assert C is not None
    Ck = C[rows.knots]
    R, dt, n = ocp.R, ocp.dt, ocp.nq
    Ru2 = 2.0 * (u @ R)
    system = _RowsSystem(ocp, cond, u, Vxx, vx, rows)
    du, dx, y = np.zeros_like(u), np.zeros(2 * n), np.zeros(rows.v.size)
    act = rows.v > 0
    for it in range(max_sets):
        p = system.solve(act) - du
        dxp = np.concatenate([cond.ck @ p, dt * p.sum(axis=0)])
        yp = np.einsum("ri,ri->r", rows.J, Ck @ p)
        if it == 0 and float(np.max(np.abs(C @ p))) > max_travel:
            return p, dxp, yp, act
        # the smooth part along du + t p: slope b + a2 t at t
        pR = p @ R
        a2 = 2.0 * float(np.sum(pR * p)) + float(dxp @ Vxx @ dxp)
        b = float(np.sum((Ru2 + 2.0 * (du @ R)) * p)) + float(vx @ dxp) + float(dxp @ Vxx @ dx)
        t = _segment_minimiser(b, a2, rows.w, rows.v - y, yp)
        if t == 0.0:
            break
        du, dx, y = du + t * p, dx + t * dxp, y + t * yp
        new = rows.v - y > 0
        if t == 1.0 and np.array_equal(new, act):
            break
        act = new
    return du, dx, y, act


def _segment_minimiser(b: float, a2: float, w: float, r: np.ndarray, s: np.ndarray) -> float:
    """The minimiser t ∈ [0, 1] of the convex ``φ(t) = b t + ½ a2 t² + ½ w Σ max(0, r_i − t s_i)²`` (up to a
    constant): its slope ``b + a2 t − w Σ s_i max(0, r_i − t s_i)`` is nondecreasing and affine between the
    breakpoints ``t = r_i / s_i``; the root is found between the two breakpoints that bracket it, exactly."""

    def slopes(t: np.ndarray) -> np.ndarray:
        return b + a2 * t - w * (np.maximum(r[None, :] - t[:, None] * s[None, :], 0.0) @ s)

    ends = slopes(np.array([0.0, 1.0]))
    if ends[1] <= 0.0:
        return 1.0
    if ends[0] >= 0.0:
        return 0.0
    nz = s != 0.0
    bp = r[nz] / s[nz]
    T = np.concatenate([[0.0], np.unique(bp[(bp > 0.0) & (bp < 1.0)]), [1.0]])
    g = slopes(T)
    j = int(np.argmax(g > 0.0))  # g[0] < 0 < g[-1]: the first breakpoint past the root
    return float(T[j - 1] - g[j - 1] * (T[j] - T[j - 1]) / (g[j] - g[j - 1]))


class _RowsSystem:
    """The closed-form system of :func:`_rows_solve` for many active sets of the same rows: what does not depend on
    the active set (the rows' Gramian factors, the right-hand side) computed once, each active set then its block
    of the observations' Gramian and one solve."""

    def __init__(
        self, ocp: ReachingOCP, cond: Condensation, u: np.ndarray, Vxx: np.ndarray, vx: np.ndarray, rows: ClearanceRows
    ):
        n, dt, T = ocp.nq, ocp.dt, ocp.horizon
        C, Gam = cond.C, cond.Gamma
        assert C is not None and Gam is not None
        k, J, w = rows.knots, rows.J, rows.w
        Ck = C[k]
        self.JR = J @ cond.R2inv
        self.Mx = np.kron(cond.G2, cond.R2inv)
        # the rows' block against δx_n: rows r and columns [δq_n; δq̇_n]
        self.Mrx = np.hstack([Gam[k, T][:, None] * self.JR, (dt * Ck.sum(axis=1))[:, None] * self.JR])
        sx = np.concatenate([cond.ck @ u, dt * u.sum(axis=0)])
        sy = np.einsum("ri,ri->r", J, Ck @ u)
        self.rhs_x, self.rhs_y = vx - Vxx @ sx, -w * rows.v - w * sy
        self.Gam, self.k, self.Vxx, self.w, self.n, self.dt = Gam, k, Vxx, w, n, dt
        self.u, self.ck, self.Ck, self.J, self.R2inv = u, cond.ck, Ck, J, cond.R2inv

    def blocks(self, act: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(a, M, H_z M, rhs)`` of the rows ``act`` (m,): their indices, the observations' Gramian, its product
        with ``H_z`` and the right-hand side ``b − H_z s`` (:func:`_rows_solve`)."""
        n = self.n
        a = np.flatnonzero(act)
        k, J, JR = self.k[a], self.J[a], self.JR[a]
        M = np.empty((2 * n + a.size, 2 * n + a.size))
        M[: 2 * n, : 2 * n] = self.Mx
        M[2 * n :, : 2 * n] = self.Mrx[a]
        M[: 2 * n, 2 * n :] = M[2 * n :, : 2 * n].T
        M[2 * n :, 2 * n :] = self.Gam[np.ix_(k, k)] * (JR @ J.T)
        HzM = np.empty_like(M)
        HzM[: 2 * n] = self.Vxx @ M[: 2 * n]
        HzM[2 * n :] = self.w * M[2 * n :]
        return a, M, HzM, np.concatenate([self.rhs_x, self.rhs_y[a]])

    def step(self, a: np.ndarray, mv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(δu, Gᵀm)`` (n, nq) from the solution m of the rows ``a``'s system."""
        n = self.n
        GTm = (
            np.outer(self.ck, mv[:n])
            + self.dt * mv[n : 2 * n][None, :]
            + self.Ck[a].T @ (self.J[a] * mv[2 * n :, None])
        )
        return -self.u - GTm @ self.R2inv, GTm

    def solve(self, act: np.ndarray) -> np.ndarray:
        """The minimiser δu (n, nq) of the quadratic model with the rows ``act`` (m,) active."""
        a, _, HzM, rhs = self.blocks(act)
        try:
            mv = np.linalg.solve(np.eye(HzM.shape[0]) + HzM, rhs)
        except np.linalg.LinAlgError as err:
            raise np.linalg.LinAlgError("singular active-set system") from err
        return self.step(a, mv)[0]


def _active_sets(
    ocp: ReachingOCP,
    cond: Condensation,
    u: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    rows: ClearanceRows,
    model: Callable[[np.ndarray, np.ndarray, np.ndarray], float],
    act: np.ndarray,
    max_sets: int,
    clamped: tuple[np.ndarray, np.ndarray],
    bounds: tuple[np.ndarray, np.ndarray],
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """The active-set iteration of :func:`_box_sets` from the rows ``act`` and the controls ``clamped = (hi, lo)``
    (n, nq masks): ``(f, δu, δx_n, y, act, inside)`` of the step with the smallest model value, the steps inside
    the box first (``inside``: the returned one is).  A primal-dual active set on the rows and on ``bounds = (lo,
    hi)`` of the new controls x = u + δu: clamp the controls past a bound, release the clamped ones whose gradient
    ``2R x + Gᵀm`` points into the box."""
    C = cond.C
    assert C is not None
    Ck = C[rows.knots]
    r2 = np.diag(ocp.R2)
    best: tuple[bool, float, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
    for _ in range(max_sets):
        solved = _rows_solve(ocp, cond, u, Vxx, vx, rows, act, clamped, bounds)
        if solved is None:
            raise np.linalg.LinAlgError("singular active-set system")
        du, GTm = solved
        dx = np.concatenate([cond.ck @ du, ocp.dt * du.sum(axis=0)])
        y = np.einsum("ri,ri->r", rows.J, Ck @ du)
        f = model(du, dx, y)
        x = u + du
        outside = bool(np.any((x - bounds[1] > 1e-12) | (x - bounds[0] < -1e-12)))
        if best is None or (outside, f) < (best[0], best[1]):
            best = (outside, f, du, dx, y, act)
        new = rows.v - y > 0
        hi, lo = clamped
        grad = x * r2 + GTm
        box = (x - bounds[1] > 1e-12) | (hi & (grad <= 0)), (x - bounds[0] < -1e-12) | (lo & (grad >= 0))
        if np.array_equal(new, act) and np.array_equal(box[0], hi) and np.array_equal(box[1], lo):
            break
        clamped = box
        act = new
    assert best is not None
    return best[1], best[2], best[3], best[4], best[5], not best[0]


def _rows_solve(
    ocp: ReachingOCP,
    cond: Condensation,
    u: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    rows: ClearanceRows,
    act: np.ndarray,
    clamped: tuple[np.ndarray, np.ndarray] | None = None,
    bounds: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The minimiser δu (n, nq) of the quadratic model with the rows ``act`` active, by Woodbury, and ``Gᵀm`` (n, nq).

    Every term other than ``Σ u_kᵀRu_k`` is a function of the observations ``z = [δx_n; y_A]``, linear in δu:
    ``z = G δu``.  With the model ``bᵀz + ½ zᵀ H_z z`` (``H_z = diag(V_xx, w I)``, ``b = [v_x; −w v_A]``)
    stationarity gives ``δu = −u − (2R)⁻¹ Gᵀ m`` with ``(I + H_z M) m = b − H_z s``, ``s = G u`` and
    ``M = G (2R)⁻¹ Gᵀ`` — the Gramian of the observations, in closed form for the double integrator
    (``Cov(q_k, q_l) = Γ_kl (2R)⁻¹``, :class:`Condensation`): one (2nq + |A|)-dimensional solve instead of the
    Riccati pass over the n knots.  ``clamped = (hi, lo)`` (n, nq masks; R diagonal): those controls are held at
    ``±a_max`` — with ``x = u + δu`` the free part is ``−(2R)⁻¹(Gᵀm)_f``, so M loses the clamped columns' terms
    ``G_c (2R)⁻¹_c G_cᵀ`` and the right-hand side gains ``H_z G_c x_c``.
    """
    system = _RowsSystem(ocp, cond, u, Vxx, vx, rows)
    a, M, HzM, rhs = system.blocks(act)
    if clamped is not None:
        assert bounds is not None
        xc = _clamp_correction(ocp, cond, rows.knots[a], rows.J[a], M, HzM, rhs, Vxx, rows.w, clamped, bounds)
    try:
        mv = np.linalg.solve(np.eye(M.shape[0]) + HzM, rhs)
    except np.linalg.LinAlgError:
        return None
    du, GTm = system.step(a, mv)
    if clamped is not None:
        mask = clamped[0] | clamped[1]
        du[mask] = xc[mask] - u[mask]
    return du, GTm


def _clamp_correction(
    ocp: ReachingOCP,
    cond: Condensation,
    k: np.ndarray,
    J: np.ndarray,
    M: np.ndarray,
    HzM: np.ndarray,
    rhs: np.ndarray,
    Vxx: np.ndarray,
    w: float,
    clamped: tuple[np.ndarray, np.ndarray],
    bounds: tuple[np.ndarray, np.ndarray],
) -> np.ndarray:
    """In place for :func:`_rows_solve`: M, ``H_z M`` and the right-hand side with the controls of ``clamped = (hi,
    lo)`` held at ``±a_max``; returns those controls' values (n, nq; zero elsewhere)."""
    n, dt = ocp.nq, ocp.dt
    C = cond.C
    assert C is not None
    hi, lo = clamped
    xc = np.where(hi, bounds[1], np.where(lo, bounds[0], 0.0))
    kc, ic = np.nonzero(hi | lo)
    Gc = np.zeros((M.shape[0], kc.size))  # the observations' columns of the clamped controls
    cols = np.arange(kc.size)
    Gc[ic, cols] = cond.ck[kc]
    Gc[n + ic, cols] = dt
    Gc[2 * n :] = J[:, ic] * C[np.ix_(k, kc)]
    M -= (Gc * np.diag(cond.R2inv)[ic]) @ Gc.T
    HzM[: 2 * n] = Vxx @ M[: 2 * n]
    HzM[2 * n :] = w * M[2 * n :]
    z = Gc @ xc[kc, ic]
    rhs[: 2 * n] += Vxx @ z[: 2 * n]
    rhs[2 * n :] += w * z[2 * n :]
    return xc


def box_qp(
    H: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray, max_iter: int = 30
) -> tuple[np.ndarray, np.ndarray]:
    """``argmin ½xᵀHx + gᵀx`` s.t. ``lo ≤ x ≤ hi`` by projected Newton (Tassa et al. 2014, Alg. 3).

    Returns ``(x, free)`` with ``free`` the mask of the unclamped coordinates at the solution
    (the feedback gains of the clamped ones are zero).  H must be positive definite.
    """
    x = np.clip(x0, lo, hi)
    free = np.ones(x.shape, dtype=bool)
    f = 0.5 * x @ H @ x + g @ x
    for _ in range(max_iter):
        grad = g + H @ x
        clamped = ((x <= lo) & (grad > 0)) | ((x >= hi) & (grad < 0))
        free = ~clamped
        if not free.any():
            break
        dx = np.zeros_like(x)
        Hf = H[np.ix_(free, free)]
        dx[free] = -np.linalg.solve(Hf, grad[free])
        if float(np.max(np.abs(dx))) < 1e-13 * (1.0 + float(np.max(np.abs(x)))):
            break
        step = 1.0
        while True:  # projected Armijo line search
            xn = np.clip(x + step * dx, lo, hi)
            fn = 0.5 * xn @ H @ xn + g @ xn
            if fn - f <= 0.1 * float(grad @ (xn - x)) or step < 1e-10:
                break
            step *= 0.5
        if step < 1e-10 or f - fn <= 1e-15 * (1.0 + abs(f)):
            x, f = xn, fn
            break
        x, f = xn, fn
    grad = g + H @ x
    free = ~(((x <= lo) & (grad > 0)) | ((x >= hi) & (grad < 0)))
    return x, free


def backward_box(
    ocp: ReachingOCP,
    u: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    lx: np.ndarray | None = None,
    lxx: np.ndarray | None = None,
    box: bool = False,
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Riccati recursion (box-DDP) for the double integrator with separable state costs.

    ``Vxx, vx``: Hessian and gradient of the terminal cost (plus the knot-n state cost).
    ``lx, lxx``: (n+1, 2nq) gradients and Hessians of the state costs at the knots, the Hessians
    *diagonal* (n+1, 2nq) (the augmented-Lagrangian terms) or full (n+1, 2nq, 2nq) (with a
    clearance cost); row 0 unused, row n already in Vxx, vx.
    ``box``: minimise each knot's ``Q(δu)`` over ``a_lo − u_k ≤ δu ≤ a_hi − u_k`` (:func:`box_qp`).

    ``Q_x = Aᵀv``, ``Q_u = 2R u_k + Bᵀv``, ``Q_xx = AᵀVA``, ``Q_ux = BᵀVA``,
    ``Q_uu = 2R + BᵀVB``; unconstrained ``[k, K] = −Q_uu⁻¹[Q_u, Q_ux]``; then
    ``v ← Q_x + Kᵀ Q_uu k + Kᵀ Q_u + Q_uxᵀ k``, ``V ← Q_xx + Kᵀ Q_uu K + Kᵀ Q_ux + Q_uxᵀ K``
    (plus the state cost of x_k).  Raises ``LinAlgError`` if some Q_uu is not positive definite.

    Returns feedforward k (n, nq), gains K (n, nq, 2nq) and the model coefficients
    ``d1 = Σ kᵀQ_u``, ``d2 = ½ Σ kᵀQ_uu k`` (predicted change ``α d1 + α² d2``).
    """
    n, T = ocp.nq, ocp.horizon
    kff = np.empty((T, n))
    Kfb = np.empty((T, n, 2 * n))
    V = Vxx.copy()
    v = vx.copy()
    d1 = d2 = 0.0
    Ru = u @ ocp.R2.T
    hi_all = ocp.a_max
    prev = np.zeros(n)
    for k in range(T - 1, -1, -1):
        Q = _q_terms(ocp, V, v, Ru[k])
        np.linalg.cholesky(Q.uu)  # positive-definiteness check (LinAlgError)
        # the box QP where the nominal control is at (within 0.1 % of) its bound: with the stiff terminal
        # cost the feedforward alone (δx = 0) is large at the last knots although the actual δu = k + K δx
        # is small, and clamping it there (Tassa's box-DDP verbatim) wrecked the step (25 rad of travel on
        # the flagship); new saturations are caught by the clipped forward roll-out and enter the box QP of
        # the next iteration
        if box and np.any(np.abs(u[k]) >= 0.999 * hi_all):
            kk, K, v, V, Quu_k = _clamped_knot(Q, -hi_all - u[k], hi_all - u[k], prev)
        else:
            kk, K, v, V, Quu_k = _free_knot(Q)
        prev = kk
        V = 0.5 * (V + V.T)
        if k > 0 and lx is not None and lxx is not None:
            v += lx[k]
            add_state_hessian(V, lxx[k])
        kff[k] = kk
        Kfb[k] = K
        d1 += float(kk @ Q.u)
        d2 += 0.5 * float(kk @ Quu_k)
    return kff, Kfb, d1, d2


@dataclass(frozen=True)
class _QTerms:
    """The quadratic model of one knot's Q-function: Q_x (2nq), Q_u (nq), Q_xx, Q_ux, Q_uu."""

    x: np.ndarray
    u: np.ndarray
    xx: np.ndarray
    ux: np.ndarray
    uu: np.ndarray


def _q_terms(ocp: ReachingOCP, V: np.ndarray, v: np.ndarray, Ru_k: np.ndarray) -> _QTerms:
    """Q_x, Q_u, Q_xx, Q_ux, Q_uu of a knot from the value function (V, v) of the next one and ``2R u_k``, with the
    block structure of ``A = [[I, Δt I], [0, I]]``, ``B = [h I; Δt I]`` (h = ½Δt²)."""
    n, dt, h = ocp.nq, ocp.dt, ocp.h
    BV = h * V[:n] + dt * V[n:]  # Bᵀ V (n × 2n)
    Quu = ocp.R2 + h * BV[:, :n] + dt * BV[:, n:]
    Qux = np.empty((n, 2 * n))
    Qux[:, :n] = BV[:, :n]
    Qux[:, n:] = dt * BV[:, :n] + BV[:, n:]
    Qu = Ru_k + h * v[:n] + dt * v[n:]
    VA = np.empty_like(V)  # V A = [V_:q, Δt V_:q + V_:v]
    VA[:, :n] = V[:, :n]
    VA[:, n:] = dt * V[:, :n] + V[:, n:]
    Qxx = VA.copy()  # Aᵀ (V A): row block q unchanged, row block v += Δt row block q
    Qxx[n:] += dt * VA[:n]
    Qx = v.copy()
    Qx[n:] += dt * v[:n]
    return _QTerms(x=Qx, u=Qu, xx=Qxx, ux=Qux, uu=Quu)


def _free_knot(Q: _QTerms) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Unconstrained knot: ``[k, K] = −Q_uu⁻¹[Q_u, Q_ux]`` and the value function ``(v, V)`` before symmetrisation;
    also ``Q_uu k`` (= −Q_u)."""
    sol = -np.linalg.solve(Q.uu, np.column_stack([Q.u, Q.ux]))
    kk, K = sol[:, 0], sol[:, 1:]
    return kk, K, Q.x + Q.ux.T @ kk, Q.xx + Q.ux.T @ K, -Q.u


def _clamped_knot(
    Q: _QTerms, lo: np.ndarray, hi: np.ndarray, prev: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Knot with the control box ``lo ≤ δu ≤ hi`` (:func:`box_qp`, warm-started at ``prev``): clamped controls get zero
    feedback rows.  Returns ``k, K, v, V`` (before symmetrisation) and ``Q_uu k``."""
    kk, free = box_qp(Q.uu, Q.u, lo, hi, prev)
    n = kk.shape[0]
    K = np.zeros((n, Q.ux.shape[1]))
    if free.all():
        K = -np.linalg.solve(Q.uu, Q.ux)
    elif free.any():
        K[free] = -np.linalg.solve(Q.uu[np.ix_(free, free)], Q.ux[free])
    Quu_k = Q.uu @ kk
    v = Q.x + K.T @ (Quu_k + Q.u) + Q.ux.T @ kk
    V = Q.xx + K.T @ (Q.uu @ K) + K.T @ Q.ux + Q.ux.T @ K
    return kk, K, v, V, Quu_k


def backward(ocp: ReachingOCP, u: np.ndarray, Vxx: np.ndarray, vx: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Unconstrained Riccati pass (:func:`backward_box` without bounds): ``(k, K, d1)``."""
    kff, Kfb, d1, _ = backward_box(ocp, u, Vxx, vx)
    return kff, Kfb, d1


def forward_deviation(ocp: ReachingOCP, kff: np.ndarray, Kfb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """α = 1 roll-out of the affine policy on deviations (no bounds): δu (n, nq), δq_n, δq̇_n."""
    n, dt, h = ocp.nq, ocp.dt, ocp.h
    du = np.empty_like(kff)
    dx = np.zeros(2 * n)
    for k in range(ocp.horizon):
        d = kff[k] + Kfb[k] @ dx
        du[k] = d
        dx[:n] += dt * dx[n:] + h * d
        dx[n:] += dt * d
    return du, dx[:n].copy(), dx[n:].copy()


def policy_rollout(ocp: ReachingOCP, u: np.ndarray, kff: np.ndarray, Kfb: np.ndarray, alpha: float) -> np.ndarray:
    """New controls of the policy ``u_k + α k_k + K_k δx_k``, clipped to the acceleration bounds."""
    n, dt, h = ocp.nq, ocp.dt, ocp.h
    un = np.empty_like(u)
    dx = np.zeros(2 * n)
    lo, hi = -ocp.a_max, ocp.a_max
    for k in range(ocp.horizon):
        uk = np.clip(u[k] + alpha * kff[k] + Kfb[k] @ dx, lo, hi)
        un[k] = uk
        d = uk - u[k]
        dx[:n] += dt * dx[n:] + h * d
        dx[n:] += dt * d
    return un


def condensed_box_step(
    ocp: ReachingOCP,
    u: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    ck: np.ndarray,
    R2inv: np.ndarray,
    Winv: np.ndarray,
) -> tuple[np.ndarray, float, float, np.ndarray] | None:
    """The LQ step over the terminal state with the terminal bounds, in closed form otherwise.

    For a terminal state ``y = Σ_k G_k ũ_k`` (relative to the free drift) the cheapest controls
    are the minimum-energy ones, ``ũ_k = (2R)⁻¹ G_kᵀ W⁻¹ y`` (u affine in time: every joint
    moves on a cubic), with running cost ``½ yᵀ W⁻¹ y``.  The LQ subproblem therefore reduces
    to a 2nq-dimensional QP in ``δx_n = y − s`` (``s = Σ G_k u_k``):
    ``min ½ δxᵀ(W⁻¹ + V_xx)δx + (W⁻¹ s + v_x)ᵀ δx`` over the box of the position and velocity
    limits of x_n (:func:`box_qp`).  Rest-to-rest cubics are monotone, so the terminal bounds
    are usually all the path constraints there are; the caller checks every knot.
    Returns ``(δu, d1, d2, δx_n)`` (predicted change ``α d1 + α² d2``) or None if not convex.
    """
    n, dt = ocp.nq, ocp.dt
    H = Winv + Vxx
    try:
        np.linalg.cholesky(H)
    except np.linalg.LinAlgError:
        return None
    svec = np.concatenate([ck @ u, dt * u.sum(axis=0)])
    g = Winv @ svec + vx
    xn = np.concatenate([q[-1], qd[-1]])
    margin = 1e-13 * (1.0 + np.abs(xn))  # keep x_n a hair inside, so round-off cannot put it outside
    lo = np.concatenate([ocp.q_lower, -ocp.v_max]) - xn + margin
    hi = np.concatenate([ocp.q_upper, ocp.v_max]) - xn - margin
    lo, hi = np.minimum(lo, 0.0), np.maximum(hi, 0.0)  # the current x_n is inside (or the AL path is used)
    dx0 = -np.linalg.solve(H, g)
    dx = dx0 if np.all((dx0 >= lo) & (dx0 <= hi)) else box_qp(H, g, lo, hi, np.clip(dx0, lo, hi))[0]
    lam = Winv @ (svec + dx)
    du = (np.outer(ck, R2inv @ lam[:n]) + dt * (R2inv @ lam[n:])[None, :]) - u
    Ru = u @ ocp.R
    d1 = 2.0 * float(np.sum(Ru * du)) + float(vx @ dx)
    d2 = float(np.einsum("ki,ij,kj->", du, ocp.R, du)) + 0.5 * float(dx @ Vxx @ dx)
    return du, d1, d2, dx


def control_box_step(
    ocp: ReachingOCP, u: np.ndarray, Vxx: np.ndarray, vx: np.ndarray, ck: np.ndarray, max_iter: int = 50
) -> tuple[np.ndarray, float, float] | None:
    """The LQ step with the acceleration bounds, exactly, by projected Newton over the whole control sequence.

    With linear dynamics the LQ subproblem is the QP ``min ½ δuᵀ H δu + gᵀ δu`` over the box
    ``−a − u_k ≤ δu_k ≤ a − u_k`` with ``H = 2R ⊗ I_n + Gᵀ V_xx G`` (G: δu → δx_n, rank 2nq) and
    ``g_k = 2R u_k + G_kᵀ v_x`` — Tassa et al.'s box QP, solved for all knots at once instead of
    knot by knot (their per-knot QP clamps the feedforward at δx = 0, which with the stiff terminal
    cost saturates the last knots for nothing).  Newton steps on the free set use the Woodbury
    identity (``2R`` diagonal plus a rank-2nq term): O(n·nq·nq) per iteration.  Requires a
    diagonal R; returns ``(δu, d1, d2)`` or None (not convex, or R not diagonal).
    """
    n, dt = ocp.nq, ocp.dt
    r2 = np.diag(ocp.R2)
    if not np.allclose(ocp.R2, np.diag(r2)) or not np.all(r2 > 0):
        return None
    lo, hi = -ocp.a_max - u, ocp.a_max - u

    def G(v: np.ndarray) -> np.ndarray:  # (T, n) → δx_n (2n)
        return np.concatenate([ck @ v, dt * v.sum(axis=0)])

    def GT(y: np.ndarray) -> np.ndarray:  # 2n → (T, n)
        return np.outer(ck, y[:n]) + dt * y[n:][None, :]

    g = u * r2 + GT(vx)

    def f_grad(x: np.ndarray) -> tuple[float, np.ndarray]:
        y = G(x)
        Vy = Vxx @ y
        return float(0.5 * np.sum(x * x * r2) + 0.5 * y @ Vy + np.sum(g * x)), x * r2 + GT(Vy) + g

    x = np.zeros_like(u)
    f, grad = f_grad(x)
    eye = np.eye(2 * n)
    for _ in range(max_iter):
        clamped = ((x <= lo) & (grad > 0)) | ((x >= hi) & (grad < 0))
        free = ~clamped
        # Newton direction on the free set: (D + Gfᵀ V Gf) d = −grad_f, D = 2R (diagonal)
        dinv = np.where(free, 1.0 / r2, 0.0)
        rhs = -np.where(free, grad, 0.0)
        a = dinv * rhs
        # Gf D⁻¹ Gfᵀ (2n × 2n): blocks over the free entries
        ckf = ck[:, None] * dinv  # (T, n)
        S11 = np.diag((ck[:, None] * ckf).sum(axis=0))
        S12 = np.diag(dt * ckf.sum(axis=0))
        S22 = np.diag(dt * dt * dinv.sum(axis=0))
        M = np.block([[S11, S12], [S12, S22]])
        try:
            z = np.linalg.solve(eye + Vxx @ M, Vxx @ G(a))
        except np.linalg.LinAlgError:
            return None
        d = a - dinv * GT(z)
        if float(np.max(np.abs(d))) < 1e-14 * (1.0 + float(np.max(np.abs(x)))):
            break
        step = 1.0
        while True:  # projected Armijo line search
            xn = np.clip(x + step * d, lo, hi)
            fn, gn = f_grad(xn)
            if fn - f <= 0.1 * float(np.sum(grad * (xn - x))) or step < 1e-10:
                break
            step *= 0.5
        converged = f - fn <= 1e-14 * (1.0 + abs(f))
        x, f, grad = xn, fn, gn
        if converged:
            break
    if not f < 0:
        return None
    y = G(x)
    d1 = float(np.sum(g * x))
    d2 = float(0.5 * np.sum(x * x * r2) + 0.5 * y @ Vxx @ y)
    return x, d1, d2


def second_order_correction(
    ocp: ReachingOCP, cond: Condensation, u: np.ndarray, Je: np.ndarray, es: np.ndarray
) -> np.ndarray | None:
    """Controls ``u − δu_c`` with the minimum-energy δu_c such that ``J_e δq_n = e_s`` and ``δq̇_n = 0`` (J_e, e_s the
    Jacobian and the shifted terminal error at u); None if the trajectory then leaves the bounds."""
    n, dt = ocp.nq, ocp.dt
    G2, R2inv = cond.G2, cond.R2inv
    Cw = np.block([[G2[0, 0] * Je @ R2inv @ Je.T, G2[0, 1] * Je @ R2inv], [G2[1, 0] * R2inv @ Je.T, G2[1, 1] * R2inv]])
    y = np.linalg.lstsq(Cw, np.concatenate([es, np.zeros(n)]), rcond=1e-12)[0]
    a_q = R2inv @ (Je.T @ y[:7])
    a_v = R2inv @ y[7:]
    u_c = u - (np.outer(cond.ck, a_q) + dt * a_v[None, :])
    q_c, qd_c = ocp.rollout(u_c)
    if ocp.limit_mode == "enforce" and ocp.violation(q_c, qd_c, u_c) > 1e-12:
        return None
    return u_c


def controls_to(ocp: ReachingOCP, q_goal: np.ndarray) -> np.ndarray:
    """Minimum-energy controls (n, nq) taking (q_init, q̇_init) to (q_goal, 0) (closed form via the Gramian)."""
    n, dt, T = ocp.nq, ocp.dt, ocp.horizon
    ck, G2, R2inv = gramian(ocp)
    Winv = np.kron(np.linalg.inv(G2), ocp.R2)
    free = np.concatenate([ocp.q_init + T * dt * ocp.qd_init, ocp.qd_init])  # the drift with u = 0
    y = np.concatenate([q_goal, np.zeros(n)]) - free
    lam = Winv @ y
    return np.outer(ck, R2inv @ lam[:n]) + dt * (R2inv @ lam[n:])[None, :]


@dataclass(frozen=True)
class Condensation:
    """The Gramian data of a problem (:func:`gramian`), computed once per solve: ``c_k`` (n,), G2 (2, 2), (2R)⁻¹,
    the inverse Gramian ``W⁻¹ = G2⁻¹ ⊗ 2R`` of x_n (metric (2R)⁻¹) and its smallest eigenvalue."""

    ck: np.ndarray
    G2: np.ndarray
    R2inv: np.ndarray
    Winv: np.ndarray
    wmin: float
    C: np.ndarray | None = None
    Gamma: np.ndarray | None = None

    @classmethod
    def of(cls, ocp: ReachingOCP) -> Condensation:
        """The Gramian data; with a clearance cost also ``C`` (n+1, n): ``∂q_k/∂u_j = C[k, j] I``
        (``h + (k−1−j) Δt²`` for j < k, else 0) and ``Γ = C Cᵀ`` (n+1, n+1), for :func:`condensed_rows_step`."""
        ck, G2, R2inv = gramian(ocp)
        Winv = np.kron(np.linalg.inv(G2), ocp.R2)
        C = Gamma = None
        if ocp.clearance is not None:
            T = ocp.horizon
            k = np.arange(T + 1, dtype=float)[:, None]
            j = np.arange(T, dtype=float)[None, :]
            C = np.where(j < k, ocp.h + (k - 1.0 - j) * ocp.dt**2, 0.0)
            Gamma = C @ C.T
        wmin = float(np.linalg.eigvalsh(Winv)[0])
        return cls(ck=ck, G2=G2, R2inv=R2inv, Winv=Winv, wmin=wmin, C=C, Gamma=Gamma)


@dataclass(frozen=True)
class LQStep:
    """One LQ step from the controls u: the α = 1 change ``du`` (n, nq), the model coefficients (predicted merit
    change ``α d1 + α² d2``) and how it was computed (``"condensed"`` or ``"riccati"``)."""

    kind: str
    u: np.ndarray
    du: np.ndarray
    d1: float
    d2: float

    def trial(self, alpha: float) -> np.ndarray:
        """The trial controls ``u + α du``."""
        return self.u + alpha * self.du


def lq_step(
    ocp: ReachingOCP,
    cond: Condensation,
    u: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    Vxx: np.ndarray,
    vx: np.ndarray,
    lx: np.ndarray,
    lxx: np.ndarray,
    *,
    condensed: bool,
    rows: ClearanceRows | None = None,
    max_travel: float = np.inf,
) -> LQStep | None:
    """One LQ step from u (trajectory q, q̇), or None if the model is not convex.

    ``Vxx, vx``: the terminal model; ``lx, lxx``: the state terms at the knots (:func:`backward_box`).
    With ``condensed`` (no AL term active, ``backward="auto"``) and clearance ``rows``: :func:`condensed_rows_step`
    (the acceleration box in its active set when the step leaves it) when its trajectory is inside every bound at the largest α the line search tries (``max_travel`` / the
    step's joint travel, or 1).  With ``condensed`` and no rows: :func:`condensed_box_step` when the full step's
    trajectory is inside every bound (then every α ∈ [0, 1] is: the bounds are linear in u), or
    :func:`control_box_step` when only the acceleration bounds are in the way; else (or when those fail the bounds)
    ``"riccati"`` (:func:`backward_box` with the AL terms and the control box).
    """
    if condensed and rows is not None:  # clearance rows: closed form while the step stays inside every bound
        rstep = condensed_rows_step(ocp, cond, u, Vxx, vx, rows, max_travel)
        if rstep is None:
            return None
        du, d1, d2 = rstep
        # the line search tries α ≤ max_travel / (the full step's joint travel) only, and the bounds are linear in
        # u: the step is inside every bound for all those α when it is at the largest one
        q1, qd1 = ocp.rollout(u + du)
        travel = float(np.max(np.abs(q1 - q)))
        a = min(1.0, max_travel / travel) if travel > 0 else 1.0
        q1, qd1 = ocp.rollout(u + a * du)
        if ocp.violation(q1, qd1, u + a * du) <= 1e-12:
            return LQStep("condensed", u, du, d1, d2)
    elif condensed:
        step = condensed_box_step(ocp, u, q, qd, Vxx, vx, cond.ck, cond.R2inv, cond.Winv)
        if step is None:
            return None
        du, d1, d2, _ = step
        q1, qd1 = ocp.rollout(u + du)
        if ocp.violation(q1, qd1, u + du) <= 1e-12:  # round-off at a bound the box QP put x_n on
            return LQStep("condensed", u, du, d1, d2)
        if ocp.u_bounded and ocp.violation(q1, qd1) <= 1e-12:  # only the acceleration bounds are in the way
            cstep = control_box_step(ocp, u, Vxx, vx, cond.ck)
            if cstep is not None:
                du, d1, d2 = cstep
                q1, qd1 = ocp.rollout(u + du)
                if ocp.violation(q1, qd1) <= 1e-12:
                    return LQStep("condensed", u, du, d1, d2)
    try:
        kff, Kfb, d1, d2 = backward_box(ocp, u, Vxx, vx, lx, lxx, box=ocp.u_bounded)
    except np.linalg.LinAlgError:
        return None
    # the α = 1 roll-out of the box-DDP policy, then u + α (u₁ − u): with linear dynamics this is the policy's
    # own roll-out wherever no control clips, it stays inside the control box (both ends are), and it avoids the
    # high feedback gains of the stiff terminal cost amplifying a clipped control into the last knots
    u1 = policy_rollout(ocp, u, kff, Kfb, 1.0)
    return LQStep("riccati", u, u1 - u, d1, d2)
