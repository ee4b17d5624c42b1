"""Layer 6: controllers in the cooperative similarity space (§3.5–3.9, §4).

Differential and Gauss–Newton IK, task-space dynamics and impedance control, nullspace
secondary tasks, teleoperation and iLQR, and obstacle / self-collision avoidance in them
(:mod:`coop_ga.control.avoidance`).  Every solver is called as
``solver(task, q_init, target, options=None, **overrides)`` with a
:class:`~coop_ga.Similarity` target and returns a result derived from
:class:`~coop_ga.control.base.SolverResult` (see :mod:`coop_ga.control.base` for the
shared names).
"""

from ..cooperative.targets import displaced_target
from .avoidance import (
    AvoidanceOptions,
    AvoidanceResult,
    ClearanceCost,
    ClearanceLimit,
    avoidance_reach,
    avoidance_velocity,
    clearance_constraint,
    repulsive_velocity,
)
from .base import SolverResult
from .constrained import (
    LINE_PARAMETERS,
    ConstrainedReachOptions,
    ConstrainedReachResult,
    EqualityConstraint,
    constrained_point_reach,
    constrained_velocity,
    end_point_jacobians,
    line_parameter_constraint,
    line_parameters,
    point_constraint,
    point_task,
    project_onto_constraints,
)
from .diffik import DiffIKOptions, DiffIKResult, diff_ik_reach, diff_ik_step, diff_ik_velocity, joint_velocity
from .dynamics import TaskDynamics, joint_dynamics, task_inertia, task_space_dynamics
from .gauss_newton import GaussNewtonOptions, IKResult, gauss_newton_ik
from .ilqr import ILQRIteration, ILQROptions, ILQRResult, ReachingOCP, ilqr_reach
from .impedance import PAPER_GAINS, ImpedanceOptions, ImpedanceResult, impedance_torque, simulate_impedance
from .nullspace import (
    NullspaceOptions,
    NullspaceResult,
    nullspace_point_reach,
    nullspace_step,
    point_on_circle,
    point_reaching_velocity,
)
from .qp import LinearConstraint, solve_qp
from .reference_ocp import ReferenceProblem, solve_reference
from .teleop import ScriptedInput, Teleoperator, command_to_bivector, run_interactive

__all__ = [
    "LINE_PARAMETERS",
    "PAPER_GAINS",
    "AvoidanceOptions",
    "AvoidanceResult",
    "ClearanceCost",
    "ClearanceLimit",
    "ConstrainedReachOptions",
    "ConstrainedReachResult",
    "DiffIKOptions",
    "DiffIKResult",
    "EqualityConstraint",
    "GaussNewtonOptions",
    "IKResult",
    "ILQRIteration",
    "ILQROptions",
    "ILQRResult",
    "ImpedanceOptions",
    "ImpedanceResult",
    "LinearConstraint",
    "NullspaceOptions",
    "NullspaceResult",
    "ReachingOCP",
    "ReferenceProblem",
    "ScriptedInput",
    "SolverResult",
    "TaskDynamics",
    "Teleoperator",
    "avoidance_reach",
    "avoidance_velocity",
    "clearance_constraint",
    "command_to_bivector",
    "constrained_point_reach",
    "constrained_velocity",
    "diff_ik_reach",
    "diff_ik_step",
    "diff_ik_velocity",
    "displaced_target",
    "end_point_jacobians",
    "gauss_newton_ik",
    "ilqr_reach",
    "impedance_torque",
    "joint_dynamics",
    "joint_velocity",
    "line_parameter_constraint",
    "line_parameters",
    "nullspace_point_reach",
    "nullspace_step",
    "point_constraint",
    "point_on_circle",
    "point_reaching_velocity",
    "point_task",
    "project_onto_constraints",
    "repulsive_velocity",
    "run_interactive",
    "simulate_impedance",
    "solve_qp",
    "solve_reference",
    "task_inertia",
    "task_space_dynamics",
]
