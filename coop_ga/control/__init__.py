"""Controllers in the cooperative similarity space (§3.5–3.9, §4).

The velocity-level controllers are built like mink and pink: a
:class:`~coop_ga.control.configuration.Configuration` (q, the previous q̇, and the kinematics and
task graph evaluated once per q), :mod:`~coop_ga.control.tasks` (an error, its Jacobian, a gain:
the cooperative similarity, an end-point position, line parameters, a posture, a joint velocity),
:mod:`~coop_ga.control.limits` (linear inequalities on q̇: position, velocity, acceleration,
clearance, user rows), one QP step :func:`solve_step` (priority levels, equalities) and one runner
:func:`run_ik`.  Differential IK, the nullspace, constrained and avoidance runners and
teleoperation are compositions of these.  Gauss–Newton IK, task-space dynamics and impedance
control and iLQR complete the package.  Every solver is registered in :data:`SOLVERS`
(:mod:`~coop_ga.control.registry`) and called as ``solver(task, q_init, target, options=None,
**problem, **overrides)`` with a :class:`~coop_ga.Similarity` target (or ``(task, q_init, index,
target_point, ...)`` for the point runners), returning a result derived from
:class:`~coop_ga.control.base.SolverResult` (see :mod:`coop_ga.control.base` for the shared names).
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
from .configuration import Configuration
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
from .limits import (
    AccelerationLimit,
    ConfigurationLimit,
    Inequalities,
    Limit,
    UserConstraints,
    VelocityLimit,
    default_limits,
)
from .nullspace import (
    NullspaceOptions,
    NullspaceResult,
    nullspace_point_reach,
    nullspace_step,
    point_on_circle,
    point_reaching_velocity,
)
from .qp import LinearConstraint, solve_qp
from .reference_ocp import ReferenceProblem, TangentReachingOCP, solve_reference
from .registry import SOLVERS, SolverEntry, get_solver, register_solver
from .solve import IKRun, RunHooks, StepSolution, run_ik, solve_step
from .tasks import (
    BodyVelocityTask,
    JointVelocityTask,
    LineParameterTask,
    PositionTask,
    PostureTask,
    SimilarityTask,
    Task,
)
from .teleop import ScriptedInput, Teleoperator, command_to_bivector, run_interactive

__all__ = [
    "LINE_PARAMETERS",
    "PAPER_GAINS",
    "SOLVERS",
    "AccelerationLimit",
    "AvoidanceOptions",
    "AvoidanceResult",
    "BodyVelocityTask",
    "ClearanceCost",
    "ClearanceLimit",
    "Configuration",
    "ConfigurationLimit",
    "ConstrainedReachOptions",
    "ConstrainedReachResult",
    "DiffIKOptions",
    "DiffIKResult",
    "EqualityConstraint",
    "GaussNewtonOptions",
    "IKResult",
    "IKRun",
    "ILQRIteration",
    "ILQROptions",
    "ILQRResult",
    "ImpedanceOptions",
    "ImpedanceResult",
    "Inequalities",
    "JointVelocityTask",
    "Limit",
    "LineParameterTask",
    "LinearConstraint",
    "NullspaceOptions",
    "NullspaceResult",
    "PositionTask",
    "PostureTask",
    "ReachingOCP",
    "ReferenceProblem",
    "RunHooks",
    "ScriptedInput",
    "SimilarityTask",
    "SolverEntry",
    "SolverResult",
    "StepSolution",
    "TangentReachingOCP",
    "Task",
    "TaskDynamics",
    "Teleoperator",
    "UserConstraints",
    "VelocityLimit",
    "avoidance_reach",
    "avoidance_velocity",
    "clearance_constraint",
    "command_to_bivector",
    "constrained_point_reach",
    "constrained_velocity",
    "default_limits",
    "diff_ik_reach",
    "diff_ik_step",
    "diff_ik_velocity",
    "displaced_target",
    "end_point_jacobians",
    "gauss_newton_ik",
    "get_solver",
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
    "register_solver",
    "repulsive_velocity",
    "run_ik",
    "run_interactive",
    "simulate_impedance",
    "solve_qp",
    "solve_reference",
    "solve_step",
    "task_inertia",
    "task_space_dynamics",
]
