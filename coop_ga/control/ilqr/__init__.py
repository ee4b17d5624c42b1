"""iLQR for cooperative reaching under joint limits: optimal control in the similarity task space (§3.9, Eq 53–57).

The problem (Eq 53) for a joint-space double integrator
--------------------------------------------------------
* state ``x_k = [q_k; q̇_k]`` (2·nq) [rad, rad/s], control ``u_k = q̈_k`` (nq) [rad/s²] (Eq 55);
* linear dynamics ``x_{k+1} = A x_k + B u_k`` (Eq 54) — the *exact* zero-order-hold
  discretisation of ``q̈ = u`` (acceleration piecewise constant over each interval):

      q_{k+1} = q_k + Δt q̇_k + ½Δt² u_k,      q̇_{k+1} = q̇_k + Δt u_k;

* running cost ``l(x_k, u_k) = u_kᵀ R u_k`` (Eq 56);
* terminal cost (Eq 57 plus a rest term)

      l_f(x_n) = ‖e(q_n)‖²_Q + q̇_nᵀ Q_v q̇_n,      e(q) = log(Ṽ_Sc(q) V_Sd)   (Eq 44),

  e the 7-vector on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``;
* **constraints** (𝒳, 𝒰 of Eq 53), from ``task.system.limits`` unless ``limit_mode="none"``:
  ``lower ≤ q_k ≤ upper`` and ``|q̇_k| ≤ velocity`` at the knots k = 1 … n, and
  ``|u_k| ≤ acceleration`` (k = 0 … n−1; infinite bounds are absent).

Horizon: the paper (§4.2) states n = 250 knots, Δt = 0.001 s *and* a 2.5 s horizon, which
contradict each other (250 × 0.001 s = 0.25 s).  We keep the 250 knots and the 2.5 s
horizon, i.e. **Δt = 0.01 s** (defaults ``horizon=250, dt=0.01``).

Terminal error as a constraint (``terminal="constraint"``, default)
--------------------------------------------------------------------
With Eq 57 alone the optimum keeps a bias ``e* ≈ (2Q)⁻¹ λ*`` (λ* the multiplier of the
reaching condition): with ``R = 1e-3``, ``Q = 1e5`` it is ~1e-6 on the arms but up to
1e-4 on the small hands, so ``tol = 1e-5`` was missed on reachable targets.  By default
``e(q_n) = 0`` is therefore an equality constraint handled by the method of multipliers:
the terminal cost is ``(e + s)ᵀ Q (e + s)`` with the shift ``s ← s + e`` after each inner
solve (``λ_e = 2Q s``), so Q is the penalty and ``e → 0`` whatever Q/R are: the default
``tol`` is always reachable on a reachable target.  ``terminal="soft"`` solves Eq 57
exactly (the problem of ``benchmarks/ocp.py``'s reference solvers).

Solver: augmented-Lagrangian box-DDP
------------------------------------
(ALTRO-style; Howell, Jackson, Manchester 2019; box-DDP of Tassa, Mansard, Todorov 2014.)

* **Control bounds** are handled exactly in the backward pass: at each knot the
  quadratic model of ``Q(δu)`` is minimised over the box ``a_lo − u_k ≤ δu ≤ a_hi − u_k``
  by projected Newton (:func:`~.lq.box_qp`); clamped controls get zero feedback rows, and the
  forward pass clips the controls.
* **Position and velocity bounds** at every knot by an augmented Lagrangian (the
  Powell–Hestenes–Rockafellar form ``(1/2μ)(max(0, λ + μc)² − λ²)`` per inequality c ≤ 0):
  the terms are separable, so their gradients and (diagonal) Hessians enter the Riccati
  recursion knot by knot; after each inner solve ``λ ← max(0, λ + μc)`` and μ grows ×10
  (up to ``al_max_penalty``) when the violation did not drop by 4.  Why AL rather than
  a barrier: the iterates need not start strictly inside, active limits are reached
  exactly in the limit, and the inner problem stays a smooth unconstrained iLQR.
* **No run-away steps.** Far from the target the terminal model is Gauss–Newton
  (``2 J_eᵀ Q J_e``, positive semi-definite); the Newton model (``+ Σ w_i ∇²e_i``, the
  Hessian of the Lagrangian, with w the least-squares multiplier estimate from stationarity
  of the running cost; :meth:`CooperativeTask.error_hessian`) is used only once
  ``‖e‖ < newton_switch``, convexified where needed (the condensed Hessian ``W⁻¹ + H_f``
  lifted to ``λ_min(W⁻¹)``, W the controllability Gramian), so the nullspace curvature
  that Gauss–Newton ignores (it converges only linearly on the redundant arms) is used
  where it is accurate and the convergence becomes superlinear.  And every step's joint travel is capped: the line
  search starts at ``α ≤ max_travel / max_k |δq_k|∞`` (a trust region on the joint
  motion of one iteration, default 0.5 rad).  The study behind this (the robustness benchmark):
  the previous default took a first Newton step that multiplied joint travel by 14
  (118 rad at 71 rad/s on one hexapod target) and the Armijo test accepted it.
* Line search: Armijo backtracking on the augmented merit (running + terminal + AL
  terms), evaluated exactly (a roll-out and one compiled task evaluation per trial).
* Speed: when no AL term is active and no control bound binds, the LQ step is computed in
  closed form through the controllability Gramian (:func:`~.lq.condensed_step`, ~1 ms for 21
  joints, identical to the Riccati step); otherwise by the Riccati/box-QP pass (~15 ms).
  ``backward="riccati"`` forces the Riccati pass.

Clearance cost (``clearance=``, default None: off)
--------------------------------------------------
With ``ILQROptions(clearance=ClearanceCost(cm, weight, activation))``
(:class:`coop_ga.control.avoidance.ClearanceCost`) the running cost gains, at the knots
k = 1 … n, ``w Σ_i ½ max(0, d_a − d_i(q_k))²`` over the collision model's signed clearances
d_i (link–obstacle and link–link, [m]): a squared hinge (C¹), zero while every pair is farther
than d_a.  It is a penalty, not a constraint: it increases the clearance (measured in
``tests/control/test_avoidance.py``) but does not guarantee a bound on it;
``ILQRResult.min_clearance`` reports the smallest clearance of the returned trajectory (at the knots).  Since
it is a penalty, a solve with a clearance cost is never *done* while the trajectory has a negative clearance (it
iterates on, e.g. from the restart's guess, which the obstacle-blind IK planned), the restart is rejected when its
trajectory crosses an obstacle that the first solve's did not, and a result with ``min_clearance < 0`` is never
``converged`` (its message says by how much it penetrates).

* **Evaluation, once per roll-out, all knots at once.**  The capsule ends of every knot come from one call of
  generated C (the collision model's motor kinematics mapped over the horizon,
  :meth:`~coop_ga.collision.model.CollisionModel.trajectory_ends`); a broad phase on the capsules' bounding
  spheres keeps only the pairs that may be within d_a (exactly: a capsule lies inside its sphere), and only those
  are computed exactly (:meth:`~coop_ga.collision.model.CollisionModel.close_pairs`).
* **Its LQ model**: the rows within :data:`~.merit.CLEARANCE_LOOKAHEAD` · d_a (0.3 d_a) of activation
  (:class:`~.problem.ClearanceRows`, Jacobians from one Pinocchio call per knot that has one), each
  ``½ w max(0, v_r − J_r δq_k)²`` (Gauss–Newton on the hinge; ``v = d_a − d``).  While no AL term is active the
  step is computed in closed form (:func:`~.lq.condensed_rows_step`): for a fixed set of active rows the LQ
  problem depends on u only through the terminal state and the rows' ``J_r δq_k``, so by Woodbury it is one
  (2nq + m)-dimensional solve with the Gramian of those observations (closed form for the double integrator);
  the active set is updated from the rows the step leaves within d_a (a semi-smooth Newton iteration, ≤ 8
  sets, the best model value kept).  Rows not active now thus enter the model when a step reaches them, instead
  of being discovered by the line search.  When that step leaves the acceleration box at the line search's
  largest α, the box joins the active set (R diagonal: the clamped controls' columns leave the Woodbury
  system, one more iteration of ≤ 8 sets on rows and box together).  The step is used when its trajectory is
  inside every bound at the line search's largest α; else (or with an AL term active) the Riccati pass with the
  rows' Gauss–Newton Hessians as full state-cost blocks.  The terminal model is Gauss–Newton while a row is near (the multiplier estimate of
  the Newton model knows no clearance cost).  The line search evaluates the exact cost.
* Measured on the obstacle scene of ``benchmarks/ocp.py`` (100 knots): before, 20 iterations and ~8000 knot-by-
  knot collision evaluations (87 % of the time) made the reach 357–457× the reach without the cost; now about
  12 iterations (docs/performance.md has the run's ratio).

Feasibility of what is returned.  After the solve, the trajectory is blended with a
strictly feasible reference (rest at q_init, or braking to rest from a moving start):
``u ← (1 − β) u + β u_ref`` with the smallest β that satisfies every bound (the
constraints are affine in u, so β is computed exactly).  β is 0 when the AL solution is
already feasible and tiny otherwise (reported).  A start on a position bound is feasible
but rest there is not *strictly* feasible (the blend could not move the trajectory off that
bound); the blend is then done joint by joint (the dynamics and the bounds are separable per
joint), each joint that leaves a bound with its own strictly feasible reference: braking, a
bang-bang move of ≤ 0.05 rad inward off the bound, or, for a joint moving out through its
bound, a reversal of its velocity in one knot where the acceleration bound allows it.  Hence
**every returned trajectory satisfies the bounds** (to 1e-12), including a start on a bound
(Talos' neutral configuration has four arm joints on one); only a start that no control keeps
inside (a joint moving out through the bound it sits on faster than its acceleration bound can
reverse) is reported as such and is not converged.

Fast honest failure.  Before iterating, :func:`~.reachability.unreachable` checks a certificate: every end point
stays in a ball about its chain's first joint (radius: the sum of the link offsets, plus the
travel of prismatic joints), and ``e = 0`` puts every end point on the target primitive; if the
target primitive misses one ball by a margin (ten times the displacement ``tol`` allows), no
configuration reaches the target and the solve returns at once (rest, or braking to rest, inside
the limits) with ``converged=False`` and a message saying the target is not reachable inside the
limits from this start.  A target 3 m away thus fails in ~0.01 s instead of the full budget
(1–7 s, 1–20× the bounded Gauss–Newton IK's time; ``benchmarks/ilqr_unreachable.py``).  The
certificate is exact, so no run that can converge is cut short.  A target within reach that the
limits (or the primitive's orientation) make unreachable is not certified; the **stall test** ends
its solve instead: once ‖e‖ has fallen by less than 1 % over the last 3 iterations, stays above
100·tol, the trajectory is inside the bounds, and the end configuration is a stationary point of
‖e‖ within the limits (:func:`~.reachability.bounded_stationarity` < 1e-2: the joints on a limit
block every descent direction), the solve stops with a message saying so and that the target is
not reachable inside the limits from this start (a local statement: the restart, ``ILQROptions.restart``, still tries
the bounded Gauss–Newton IK's configuration).  Two planes of the benchmark that the limits keep
0.07–0.12 m away used to run their 60 iterations (3–7× the IK's time) and end with "max_iter
reached"; they stop after 16–17.  On 1202 solves (10 systems × 6 kinds × 4 displacement sizes × 3
targets, from rest and moving) the stall test never held before any of the 834 that converge, and
their results are unchanged.

``converged`` means: ``‖e(q_n)‖ < tol`` **and** the bounds hold **and** the last step was
accepted by the line search on the true (re-evaluated) merit.  An unreachable target
(outside the reachable set, or only reachable outside the limits) ends with
``converged=False`` and a message naming the active constraints and the residual.
A start outside the limits raises :class:`~coop_ga.errors.InvalidInputError` (use
``limit_mode="none"`` to study it).
A free flyer (nq ≠ nv)
----------------------
A system with a free flyer is solved in a local chart of its configuration manifold, ``q(x) = q_ref ⊕ (x − c)``
(q_ref the start, :class:`RecedingReach` re-centres it at every solve): everything above holds for x (nv) with the
task's Jacobian and Hessian composed with the chart, a joint's chart coordinate is its own coordinate and the
flyer's six have no position bound (:mod:`~coop_ga.control.ilqr.chart`: why a chart, what its bounds mean, and
how the result is mapped back: ``trajectory`` (n+1, nq), ``qd`` (n+1, nv) tangent velocities, ``u`` (n, nv)).
Without a free flyer no chart is built (results bit-identical).

The package
-----------
:mod:`~.problem` (:class:`ReachingOCP`: dynamics, costs, bounds), :mod:`~.options`
(:class:`ILQROptions`), :mod:`~.lq` (the LQ kernels: Gramian, closed-form and box-QP steps, the
Riccati/box-DDP pass, roll-outs), :mod:`~.merit` (the augmented merit and its
:class:`~.merit.Evaluation`, the terminal models), :mod:`~.feasibility` (the strictly feasible
references and the final blend), :mod:`~.reachability` (the unreachability certificate),
:mod:`~.chart` (the free flyer's chart: :class:`~.chart.ChartTask`,
:class:`~.chart.ChartClearance`), :mod:`~.solver` (:func:`ilqr_reach`, the AL and iLQR loops, the restart; :class:`RecedingReach`, the same solve
set up once and re-run from new starts and targets without the certificate — the inner solver of
:mod:`coop_ga.control.mpc`) and :mod:`~.results`
(:class:`ILQRResult`, :class:`ILQRIteration`, the verdict).
"""

from ...cooperative.targets import displaced_target
from .options import ILQROptions
from .problem import DEFAULT_Q, DEFAULT_QV, DEFAULT_R, ReachingOCP
from .results import ILQRIteration, ILQRResult
from .solver import RecedingReach, ilqr_reach

__all__ = [
    "DEFAULT_Q",
    "DEFAULT_QV",
    "DEFAULT_R",
    "ILQRIteration",
    "ILQROptions",
    "ILQRResult",
    "ReachingOCP",
    "RecedingReach",
    "displaced_target",
    "ilqr_reach",
]
