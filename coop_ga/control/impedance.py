"""Impedance control in the cooperative similarity space (Eq 49–52), simulated with Pinocchio.

Error and its rate (Eq 49, in this package's convention)
--------------------------------------------------------
The error is ``B_e = log(Ṽ_Sc(q) V_Sd)`` (7,), the target seen from the current
cooperative frame.  The paper writes ``Ḃ_e = −½ 𝒱_Sc``; the ½ belongs to its bivector
normalisation (``V = exp(−½ B)``).  Our 7-vectors absorb it: ``b = J^G q̇`` satisfies
``V(q + Δt q̇) ≈ V(q) exp(Δt b)`` (body frame), hence

    B_e(t + Δt) = log(exp(−Δt b) exp(B_e)) = B_e − Δt b + O(Δt ‖b‖ ‖B_e‖),

i.e. ``Ḃ_e = −J^G q̇`` at B_e = 0 (factor 1, not ½), and exactly ``Ḃ_e = J_e q̇`` with
``J_e = ∂B_e/∂q`` from :meth:`CooperativeTask.error_and_jacobian` (Eq 47).  The
controller uses the exact rate by default (``error_rate='exact'``; ``'approx'`` uses
``−J^G q̇``); ``tests/control/test_impedance.py`` checks both against finite differences.

Control law (Eq 50–52)
----------------------
::

    𝒱̇_d = K B_e + D Ḃ_e                               (Eq 50, V̇_Sd = 0)
    𝒲   = Λ 𝒱̇_d + μ + g_S                             (Eq 51, Λ, μ, g_S from Eq 36–38)
    τ   = J^Gᵀ 𝒲 + τ_null                              (Eq 52 + nullspace term)

With ``Ḃ_e ≈ −𝒱`` and ``𝒱̇ = P 𝒱̇_d`` (P: projector onto range J^G, see
:mod:`coop_ga.control.dynamics`) the closed loop is ``B̈_e + D Ḃ_e + K B_e ≈ 0`` on the
controllable directions.

Nullspace.  J^G has a large kernel (rank 6 of 21 for three arms on a circle), and Eq 52
alone leaves those 15 directions undamped — and uncompensated against gravity, since
``J^Gᵀ g_S`` is only the task part of g.  Two options:

* ``nullspace='compensate'`` (default): ``τ_null = N̄ᵀ (h − M D_null q̇)`` with
  ``h = C q̇ + g`` and the dynamically consistent ``N̄ᵀ = I − J^Gᵀ Λ J^G M⁻¹``.  Since
  ``J^Gᵀ(μ + g_S) + N̄ᵀ h = h + J^Gᵀ Λ (−J̇ q̇)``, this is full gravity/Coriolis
  compensation, ``τ = h + J^Gᵀ Λ (𝒱̇_d − J̇ q̇ + J^G D_null q̇) − M D_null q̇``, and the
  nullspace torque cannot disturb the task (``J M⁻¹ N̄ᵀ = 0``).
* ``nullspace='damping'``: the paper's Eq 52 plus only ``τ_null = N (−M D_null q̇)``,
  ``N = I − J⁺J`` (kinematic projector, Eq 58).  Gravity is then compensated only in
  the task directions; the nullspace falls (three iiwa14 on a circle: the error grows
  from 0.23 to 0.68 within 0.2 s and the simulation diverges) — kept as an ablation.

``D_null`` [1/s] is an *acceleration-level* damping (``q̈_null ≈ −D_null q̇``), scaled by
M: a plain torque damping ``−d q̇`` [N m s/rad] is unstable under explicit 1 kHz
integration on light joints (iiwa link 7: about 1e-3 kg m², stable only for d < 2).

Simulation: the plant is Pinocchio's forward dynamics ``q̈ = ABA(q, q̇, τ)`` (gravity
``model.gravity``, no friction) integrated with semi-implicit Euler
(``q̇ += Δt q̈; q += Δt q̇``), Δt = 1 ms by default.

A free flyer (nq ≠ nv): M(q), h(q, q̇) = C q̇ + g and the torques have nv entries (``pin.crba``,
``pin.nonLinearEffects`` on the floating model), q moves by ``pinocchio.integrate`` and the first six torque
entries are a wrench on the base in its LOCAL frame ([f; m], effort unbounded) — a fully actuated free flyer
(thrusters, or a base held by an external mechanism), not a legged robot, which must produce that wrench through
its contacts.

Limits (``task.system.limits``, :class:`~coop_ga.systems.limits.JointLimits`)
-----------------------------------------------------------------------------
* Torque: with ``torque_limits='saturate'`` (default) the command of Eq 52 is clipped
  joint by joint to ``±effort`` (URDF ``<limit effort>``; an unbounded joint is never
  clipped) before it reaches the plant — what a drive does; ``'none'`` applies the raw
  command (the plant then receives torques beyond the rating, and a
  :class:`~coop_ga.errors.JointLimitWarning` says so).  Saturation breaks the task/nullspace
  decoupling of the law for that step, so the closed loop is no longer exactly the
  second-order error dynamics above; it is reported, not hidden:
  :attr:`ImpedanceResult.saturated_steps` (control steps in which at least one joint was
  clipped) and :attr:`ImpedanceResult.effort_ratio` (max ``|τ_cmd| / effort`` of the
  unsaturated command; > 1 iff something was, or with ``'none'`` should have been, clipped).
* Position and velocity: not enforced (the controller has no notion of them and the
  plant has no joint stops); every state of the run is checked —
  :attr:`~ImpedanceResult.position_violation` (largest excursion outside
  ``[lower, upper]``), :attr:`~ImpedanceResult.velocity_ratio` (max ``|q̇| / velocity``),
  and the number of states outside each limit — and one
  :class:`~coop_ga.errors.JointLimitWarning` per call reports a violation.  A run that
  violated them is not ``converged``, whatever its final error (the states it went
  through are not reachable by the real robot).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..diagnostics import collect_warnings, warn
from ..errors import CoopGAError, InvalidInputError, JointLimitWarning, NonFiniteError
from ..geometry.groups import SimilarityLike
from .base import SolverResult, check_q, check_v, resolve_options
from .dynamics import task_inertia

__all__ = ["PAPER_GAINS", "ImpedanceOptions", "ImpedanceResult", "error_rate", "impedance_torque", "simulate_impedance"]

#: §4.1: K = diag(1, 1, 1, 7.5, 7.5, 7.5, 7.5), D = 5 I (rows e12, e13, e23, e0∞, e1∞, e2∞, e3∞)
PAPER_GAINS = (np.diag([1.0, 1.0, 1.0, 7.5, 7.5, 7.5, 7.5]), 5.0 * np.eye(7))


def _gain(G: Any, what: str) -> np.ndarray:
    a = validation.array(G, what)
    if a.ndim == 0:
        a = float(a) * np.eye(7)
    elif a.shape == (7,):
        a = np.diag(a)
    if a.shape != (7, 7):
        raise InvalidInputError(f"{what} must be a scalar, a 7-vector (diagonal) or a 7×7 matrix, got shape {a.shape}")
    return a


@dataclass(frozen=True, eq=False)  # eq=False: the gains are arrays
class ImpedanceOptions:
    """Settings of :func:`simulate_impedance` and :func:`impedance_torque`.

    K, D: stiffness and damping on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` (scalar, 7-vector
        diagonal or 7×7; default the paper's §4.1 gains :data:`PAPER_GAINS`).
    duration: simulated time [s] (≥ 0); dt: control and integration step [s] (1 kHz default).
    D_null: nullspace damping [1/s] (acceleration level, see the module docstring).
    nullspace: ``'compensate'`` (default) or ``'damping'`` (the paper's Eq 52, an ablation).
    error_rate: ``'exact'`` (Ḃ_e = J_e q̇) or ``'approx'`` (Ḃ_e = −J^G q̇).
    rcond: relative eigenvalue cut-off of the pseudo-inverse in Λ (Eq 36).
    tol: the result is ``converged`` when the final ‖B_e‖ < tol (and the position and
        velocity limits held over the run).
    torque_limits: ``'saturate'`` (default): clip the commanded τ to ±``effort`` of
        ``task.system.limits`` before applying it; ``'none'``: apply the raw command (the
        excess is still measured and warned about).  See "Limits" in the module docstring.
    warn_limits: emit one :class:`~coop_ga.errors.JointLimitWarning` per call when the run
        left the position or velocity limits (or exceeded the effort limits with
        ``torque_limits='none'``); the counts in the result are filled either way.
    """

    K: Any = field(default_factory=lambda: PAPER_GAINS[0].copy())
    D: Any = field(default_factory=lambda: PAPER_GAINS[1].copy())
    duration: float = 4.0
    dt: float = 1e-3
    D_null: float = 2.0
    nullspace: str = "compensate"
    error_rate: str = "exact"
    rcond: float = 1e-8
    tol: float = 1e-3
    torque_limits: str = "saturate"
    warn_limits: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "K", _gain(self.K, "K"))
        object.__setattr__(self, "D", _gain(self.D, "D"))
        validation.nonnegative(self.duration, "duration")
        validation.positive(self.dt, "dt")
        validation.nonnegative(self.D_null, "D_null")
        validation.choice(self.nullspace, ("compensate", "damping"), "nullspace")
        validation.choice(self.error_rate, ("exact", "approx"), "error_rate")
        validation.scalar(self.rcond, "rcond", low=0.0, high=1.0)
        validation.nonnegative(self.tol, "tol")
        validation.choice(self.torque_limits, ("saturate", "none"), "torque_limits")
        if not isinstance(self.warn_limits, bool):
            raise InvalidInputError(f"warn_limits must be True or False, got {self.warn_limits!r}")


def error_rate(
    task: Any, q: Any, qd: Any, target: SimilarityLike, mode: str = "exact"
) -> tuple[np.ndarray, np.ndarray]:
    """``(B_e, Ḃ_e)`` (7,), (7,) at (q, q̇): exact ``Ḃ_e = J_e q̇`` or approximate ``−J^G q̇``."""
    validation.choice(mode, ("exact", "approx"), "mode")
    qdv = check_v(task, qd, "qd")
    e, Je = task.error_and_jacobian(q, validation.target(target))
    if mode == "exact":
        return e, Je @ qdv
    return e, -(task.jacobian(q) @ qdv)


@dataclass(frozen=True, kw_only=True)
class ImpedanceResult(SolverResult):
    """Result of :func:`simulate_impedance` (fields of :class:`~coop_ga.control.base.SolverResult`
    plus; T = number of control steps + 1, ``iterations`` = T − 1, ``converged`` iff the final
    ‖B_e‖ < ``tol`` and no state left the position or velocity limits, ``q`` = the final
    configuration):

    t (T,) [s]; trajectory (T, nq) [rad]; qd (T, nv) [rad/s]; error_vectors (T, 7) B_e;
    error_norm (T,) ‖B_e‖;
    tau (T, nv) [N m]: the torque applied from state t[k] — the command clipped to ±effort
    with ``torque_limits='saturate'`` (the last row is the command at the final state, not
    applied); tau_command (T, nv) [N m]: the command of Eq 52 before saturation.

    Limits (those of ``task.system.limits``; every number below can be recomputed from the
    arrays above and the limits — ``tests/control/test_impedance.py`` does):

    torque_limits: the option used (``'saturate'`` or ``'none'``).
    saturated_steps: number of *applied* control steps k < T − 1 with ``|tau_command[k, j]| >
        effort[j]`` for some joint j (with ``'none'``: the steps that exceeded the rating).
    effort_ratio: ``max_{k < T−1, j} |tau_command[k, j]| / effort[j]`` (joints with a finite
        effort; 0 if none) — > 1 iff ``saturated_steps > 0``.
    position_violation: largest excursion of ``trajectory`` outside ``[lower, upper]`` over the
        T states [rad] (0 = inside).
    velocity_ratio: ``max_{k, j} |qd[k, j]| / velocity[j]`` over the T states (> 1 = violated).
    position_violation_steps, velocity_violation_steps: number of states t_k (of T, the
        initial one included) outside the position / velocity limits (strictly);
        limit_violation_steps: states outside either.
    """

    t: np.ndarray
    trajectory: np.ndarray
    qd: np.ndarray
    error_vectors: np.ndarray
    error_norm: np.ndarray
    tau: np.ndarray
    tau_command: np.ndarray
    torque_limits: str = "saturate"
    saturated_steps: int = 0
    effort_ratio: float = 0.0
    position_violation: float = 0.0
    velocity_ratio: float = 0.0
    position_violation_steps: int = 0
    velocity_violation_steps: int = 0
    limit_violation_steps: int = 0

    @property
    def within_limits(self) -> bool:
        """True iff no state left the position or velocity limits (torque saturation is allowed)."""
        return self.limit_violation_steps == 0

    @property
    def ratio(self) -> float:
        """``error_norm[-1] / error_norm[0]``."""
        return float(self.error_norm[-1] / self.error_norm[0]) if self.error_norm[0] > 0 else 0.0

    @property
    def max_rise(self) -> float:
        """Largest relative rise of ‖B_e‖ above its running minimum, ``max_t (e_t / min_{s≤t} e_s − 1)``."""
        run_min = np.minimum.accumulate(self.error_norm)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(run_min > 0, self.error_norm / run_min - 1.0, 0.0)
        return float(np.max(r))


class _Controller:
    """Per-step impedance law with preallocated state (used by :func:`simulate_impedance`)."""

    def __init__(self, task: Any, target: SimilarityLike, o: ImpedanceOptions):
        import pinocchio as pin

        self.pin = pin
        self.task = task
        self.model = task.system.model
        self.data = self.model.createData()
        self.Vd = validation.target(target)
        self.K, self.D = o.K, o.D
        self.D_null = float(o.D_null)
        self.nullspace = o.nullspace
        self.error_rate = o.error_rate
        self.rcond = float(o.rcond)
        self.I = np.eye(task.nv)
        self._iu = np.triu_indices(task.nv, 1)

    def __call__(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """τ (nv,) and B_e (7,) at (q (nq,), q̇ (nv,))."""
        pin, model, data, task = self.pin, self.model, self.data, self.task
        J = task.evaluate_views(q)[2]
        e, Je = task.error_and_jacobian(q, self.Vd)
        de = Je @ qd if self.error_rate == "exact" else -(J @ qd)
        a_d = self.K @ e + self.D @ de  # Eq 50
        M = pin.crba(model, data, q)
        M[self._iu[1], self._iu[0]] = M[self._iu]  # symmetrise (crba fills the upper triangle)
        h = pin.nonLinearEffects(model, data, q, qd)  # C q̇ + g
        Minv = np.linalg.inv(M)
        JMinv = J @ Minv
        Lam = task_inertia(J, Minv, rcond=self.rcond)  # Eq 36
        Jdqd = task.jdot_qdot(q, qd)
        dn = self.D_null * qd
        if self.nullspace == "compensate":
            # τ = Jᵀ(Λ a_d + μ + g_S) + N̄ᵀ(h − M dn) = h + JᵀΛ(a_d − J̇q̇ + J dn) − M dn
            tau = h + J.T @ (Lam @ (a_d - Jdqd + J @ dn)) - M @ dn
        else:
            W = Lam @ (a_d + JMinv @ h - Jdqd)  # Eq 51 with μ + g_S = Λ(J M⁻¹ (C q̇ + g) − J̇ q̇)
            Jp = np.linalg.pinv(J, rcond=1e-10)
            Mdn = M @ dn
            tau = J.T @ W - (Mdn - Jp @ (J @ Mdn))
        return tau, e


def impedance_torque(
    task: Any, q: Any, qd: Any, target: SimilarityLike, options: ImpedanceOptions | None = None, **overrides: Any
) -> np.ndarray:
    """Joint torque τ (nv,) [N m] of the similarity impedance law (Eq 49–52) at (q, q̇).

    See the module docstring for the law, the nullspace options and ``error_rate``;
    ``options``: :class:`ImpedanceOptions` (keyword ``overrides`` replace its fields; only the
    gains, ``D_null``, ``nullspace``, ``error_rate``, ``rcond`` and ``torque_limits`` matter
    here).  The torque is the one :func:`simulate_impedance` applies: clipped to ±effort of
    ``task.system.limits`` with ``torque_limits='saturate'`` (default), the raw command of
    Eq 52 with ``'none'``.
    """
    o = resolve_options(ImpedanceOptions, options, overrides, "impedance_torque")
    ctl = _Controller(task, target, o)
    tau = ctl(check_q(task, q), check_v(task, qd, "qd"))[0]
    if o.torque_limits == "saturate":
        eff = task.system.limits.effort
        tau = np.clip(tau, -eff, eff)
    return tau


def _simulate(
    task: Any, ctl: Any, q: np.ndarray, qd: np.ndarray, o: ImpedanceOptions, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(Q, Q̇, τ, τ_cmd, e)`` of n steps of the plant (semi-implicit Euler on Pinocchio's ABA, module docstring)."""
    import pinocchio as pin

    dt = o.dt
    model = task.system.model
    plant = model.createData()
    T = n + 1
    system = task.system
    free = system.nq != system.nv  # a free flyer: q moves by integrate, velocities and torques have nv entries
    Q = np.empty((T, task.nq))
    QD = np.empty((T, task.nv))
    TAU = np.empty((T, task.nv))
    TAU_CMD = np.empty((T, task.nv))
    E = np.empty((T, 7))
    effort = task.system.limits.effort
    saturate = o.torque_limits == "saturate" and bool(np.any(np.isfinite(effort)))
    for k in range(T):
        try:
            tau_cmd, e = ctl(q, qd)
        except CoopGAError as ex:  # the state left the task's domain (degenerate primitive, overflow)
            raise NonFiniteError(f"impedance simulation diverged at t = {k * dt:.4f} s: {ex}") from ex
        tau = np.clip(tau_cmd, -effort, effort) if saturate else tau_cmd
        Q[k], QD[k], TAU[k], TAU_CMD[k], E[k] = q, qd, tau, tau_cmd, e
        if k == n:
            break
        qdd = pin.aba(model, plant, q, qd, tau)
        qd = qd + dt * qdd
        q = system.integrate(q, dt * qd) if free else q + dt * qd
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))) or float(np.max(np.abs(q))) > 1e3:
            raise NonFiniteError(f"impedance simulation diverged at t = {(k + 1) * dt:.4f} s")
    return Q, QD, TAU, TAU_CMD, E


def _message(En: np.ndarray, small: bool, o: ImpedanceOptions, stats: dict[str, Any], n: int, T: int) -> str:
    msg = (
        f"‖B_e‖ = {En[-1]:.3g} after {o.duration:g} s ({'<' if small else '≥'} tol = {o.tol:g}; "
        f"ratio to the start {En[-1] / En[0] if En[0] > 0 else 0.0:.3g})"
    )
    if stats["saturated_steps"]:
        msg += (
            f"; torque {'saturated' if o.torque_limits == 'saturate' else 'above the effort limit'} in "
            f"{stats['saturated_steps']} of {n} steps (max |τ|/effort = {stats['effort_ratio']:.3g})"
        )
    if stats["limit_violation_steps"]:
        msg += (
            f"; joint limits violated in {stats['limit_violation_steps']} of {T} states (position by up to "
            f"{stats['position_violation']:.3g} rad, max |q̇|/limit = {stats['velocity_ratio']:.3g})"
            + " — not converged"
        )
    return msg


def simulate_impedance(
    task: Any,
    q_init: Any,
    target: SimilarityLike,
    options: ImpedanceOptions | None = None,
    *,
    qd_init: Any = None,
    **overrides: Any,
) -> ImpedanceResult:
    """Simulate the similarity impedance controller (Eq 49–52) on the system's rigid-body dynamics.

    Args:
        task: a :class:`coop_ga.CooperativeTask` (its system's Pinocchio model is the plant).
        q_init: (nq,) initial configuration [rad]; qd_init: (nv,) initial velocity (default 0).
        target: V_Sd, a :class:`~coop_ga.Similarity`; constant (V̇_Sd = 0).
        options: :class:`ImpedanceOptions` (gains, duration, Δt, nullspace handling, …);
            keyword ``overrides`` replace its fields (``simulate_impedance(t, q, V, K=25, D=10)``).

    The commanded torque is saturated to ±effort of ``task.system.limits`` unless
    ``torque_limits='none'``; position and velocity limits are monitored, not enforced (module
    docstring, "Limits"): the result counts the violations and one
    :class:`~coop_ga.errors.JointLimitWarning` per call reports them.

    Returns:
        :class:`ImpedanceResult`.  Raises :class:`NonFiniteError` if the state diverges.
    """
    o = resolve_options(ImpedanceOptions, options, overrides, "simulate_impedance")
    dt, duration = o.dt, o.duration
    q = check_q(task, q_init, "q_init")
    qd = np.zeros(task.nv) if qd_init is None else check_v(task, qd_init, "qd_init")
    ctl = _Controller(task, target, o)
    n = round(duration / dt)
    T = n + 1
    lim = task.system.limits
    with collect_warnings() as caught:
        Q, QD, TAU, TAU_CMD, E = _simulate(task, ctl, q, qd, o, n)
        stats = _limit_statistics(lim, task.system.limit_coordinates(Q), QD, TAU_CMD[:n])
        if o.warn_limits:
            _warn_limits(task.name, stats, o.torque_limits, T)
    En = np.linalg.norm(E, axis=1)
    small = bool(En[-1] < o.tol)
    converged = small and stats["limit_violation_steps"] == 0
    msg = _message(En, small, o, stats, n, T)
    return ImpedanceResult(
        converged=converged,
        error=float(En[-1]),
        iterations=n,
        message=msg,
        q=Q[-1].copy(),
        warnings=dict(caught.counts),
        t=np.arange(T) * dt,
        trajectory=Q,
        qd=QD,
        error_vectors=E,
        error_norm=En,
        tau=TAU,
        tau_command=TAU_CMD,
        torque_limits=o.torque_limits,
        **stats,
    )


def _limit_statistics(lim: Any, Q: np.ndarray, QD: np.ndarray, tau_applied_cmd: np.ndarray) -> dict[str, Any]:
    """Limit counts of a run (see :class:`ImpedanceResult`): states Q, QD (T, nv) (Q in the limits' coordinates,
    :meth:`~coop_ga.systems.System.limit_coordinates`), the commands of the applied steps (T − 1, nv) before
    saturation."""
    finite = np.isfinite(lim.effort)
    if tau_applied_cmd.size and np.any(finite):
        ratio = np.abs(tau_applied_cmd[:, finite]) / lim.effort[finite]
        over = ratio > 1.0
        saturated_steps = int(np.count_nonzero(np.any(over, axis=1)))
        effort_ratio = float(np.max(ratio))
    else:
        saturated_steps, effort_ratio = 0, 0.0
    pos_out = np.any((Q < lim.lower) | (Q > lim.upper), axis=1)
    vel_out = np.any(np.abs(QD) > lim.velocity, axis=1)
    return {
        "saturated_steps": saturated_steps,
        "effort_ratio": effort_ratio,
        "position_violation": lim.position_violation(Q),
        "velocity_ratio": float(np.max(np.abs(QD) / lim.velocity)),
        "position_violation_steps": int(np.count_nonzero(pos_out)),
        "velocity_violation_steps": int(np.count_nonzero(vel_out)),
        "limit_violation_steps": int(np.count_nonzero(pos_out | vel_out)),
    }


def _warn_limits(name: str, stats: dict[str, Any], torque_limits: str, T: int) -> None:
    """One JointLimitWarning for the position/velocity violations of a run, one for unsaturated excess torque."""
    if stats["limit_violation_steps"]:
        parts = []
        if stats["position_violation_steps"]:
            parts.append(
                f"position by up to {stats['position_violation']:.3g} rad in {stats['position_violation_steps']} states"
            )
        if stats["velocity_violation_steps"]:
            parts.append(
                f"velocity up to {stats['velocity_ratio']:.3g}× its limit in {stats['velocity_violation_steps']} states"
            )
        warn(
            f"impedance simulation of '{name}' left the joint limits ({'; '.join(parts)}, of {T}); position and "
            "velocity limits are monitored, not enforced — lower the gains or start closer to the target",
            JointLimitWarning,
            key=name,
        )
    if torque_limits == "none" and stats["saturated_steps"]:
        warn(
            f"impedance simulation of '{name}' applied torques above the effort limits in "
            f"{stats['saturated_steps']} steps (up to {stats['effort_ratio']:.3g}× the limit; torque_limits='none')",
            JointLimitWarning,
            key=f"{name}:effort",
        )
