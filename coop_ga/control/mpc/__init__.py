"""Receding-horizon (model predictive) control of a cooperative primitive with limits and clearance.

Three loops, slowest first (:class:`CooperativeMPC`; the physics loop of :mod:`coop_ga.sim.mpc_track`):

1. **The MPC tick** (every ``period``, default 40 ms): the iLQR of :mod:`coop_ga.control.ilqr` (Eq 53–57 on the
   joint double integrator) re-solved from the measured (q, q̇) toward the target ``V_d(t + n·Δt)`` — the
   time-varying target (a callable or a sampled reference, :class:`TargetSchedule`) taken one horizon ahead,
   so that the plan arrives on the moving target instead of lagging behind it.

   * set up once (:class:`~coop_ga.control.ilqr.RecedingReach`): the problem's checks, the Gramian data and the
     compiled task functions are reused; the unreachability certificate of :func:`~coop_ga.control.ilqr.ilqr_reach`
     is not run inside a tick (a momentarily unreachable target is approached, not given up on; the tick
     reports ‖e‖ instead);
   * warm start: the previous plan's controls shifted by ``period/Δt`` knots (last control repeated);
   * fixed budget: ``max_iter`` iLQR iterations per tick (``first_iter`` on the cold start); the wall time of
     every tick is measured, and a tick over ``time_budget`` warns once (:class:`~coop_ga.errors.RateWarning`,
     with the measured time) and is counted in ``overruns`` — no tick is skipped;
   * position, velocity and acceleration limits are **hard bounds** of the plan (the iLQR's box-DDP on the
     controls, its augmented Lagrangian on q and q̇, and its final feasibility blend: every returned plan is
     inside the limits);
   * clearance (arm–obstacle and arm–arm, :mod:`coop_ga.collision`) can enter the plan as the iLQR's clearance
     *cost* (:class:`~coop_ga.control.avoidance.ClearanceCost`, ``clearance_weight > 0``): it bends the plan away
     from contact early, but costs one collision-model evaluation per knot and line-search trial (~10× the
     tick, ``benchmarks/mpc.py``), so it is off by default and the safety layer alone holds the clearance;
   * output: the acceleration command u_0, its torque by Pinocchio's RNEA (Eq 32), and the diagnostics
     (:class:`MPCTick`: tick and solve time, iterations, bound violation, clearance, ‖e‖ now and at the end).

2. **The safety layer** (every ``filter_dt``, e.g. 10 ms; :meth:`CooperativeMPC.filter`): the joint velocity
   of the plan (plus a feedback ``k (q_plan − q)``) through the limit QP of :mod:`coop_ga.control.solve` with
   the position, velocity and acceleration limits and the **clearance as hard constraints**: the velocity
   dampers of :class:`~coop_ga.control.limits.ClearanceLimit` corrected for the obstacles' own motion
   (:class:`MovingClearanceLimit`, rows (A1') of :mod:`~coop_ga.control.mpc.obstacles`).

   Why clearance is a hard constraint here and not in the iLQR: the iLQR's augmented Lagrangian handles
   the separable box bounds knot by knot (diagonal Hessians in the Riccati pass); a clearance inequality is
   nonlinear in q and couples every joint of a chain pair, and its multipliers would have to be re-converged
   every tick within a budget of one or two iterations — under a fixed budget an AL constraint is only a
   penalty.  The QP enforces it exactly at every 10 ms step (to first order in Δt), at the cost of one
   distance evaluation and one small QP (~1–3 ms).

3. **Joint-level tracking** (every physics step, 1 kHz; outside this package): ``τ = RNEA(q, q̇, a + K_p
   (q_r − q) + K_d (q̇_r − q̇))`` along the safety layer's velocity ramp.

A free flyer (nq ≠ nv, e.g. ``load("g1_arms", free_flyer=True)``): every tick solves the iLQR in its local chart
re-centred at the measured q (:mod:`coop_ga.control.ilqr.chart`); q̇, the command and the plan's velocities and
controls have nv entries, the feedback of the safety layer is ``difference(q, q_plan)`` and the plan is sampled
through ``integrate``; the flyer has no position bound.

Bad input: a target that is not a similarity or has NaN → :class:`~coop_ga.errors.InvalidInputError` /
:class:`~coop_ga.errors.NonFiniteError` naming the time; a state outside the limits, a penetrating pair or an
infeasible safety QP → :class:`MPCInfeasibleError` (an :class:`~coop_ga.errors.InfeasibleConstraintsError`)
with the active set and the fallback command (braking to rest within the acceleration limits).
"""

from .controller import CooperativeMPC, FilterStep, MPCInfeasibleError, MPCTick
from .obstacles import MovingClearanceLimit, MovingSphere, ObstacleWorld
from .options import MPCOptions
from .target import TargetSchedule

__all__ = [
    "CooperativeMPC",
    "FilterStep",
    "MPCInfeasibleError",
    "MPCOptions",
    "MPCTick",
    "MovingClearanceLimit",
    "MovingSphere",
    "ObstacleWorld",
    "TargetSchedule",
]
