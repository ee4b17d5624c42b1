"""Controllers in the cooperative similarity space: differential and Gauss–Newton IK,
task-space dynamics and impedance control, nullspace secondary tasks, teleoperation,
iLQR (§3.5–3.9, §4)."""

from .diffik import DiffIKResult, diff_ik_reach, diff_ik_step, joint_velocity
from .dynamics import TaskDynamics, joint_dynamics, task_inertia, task_space_dynamics
from .gauss_newton import IKResult, gauss_newton_ik
from .ilqr import ILQRIteration, ILQRResult, ReachingOCP, displaced_target, ilqr_reach
from .impedance import PAPER_GAINS, ImpedanceResult, impedance_torque, simulate_impedance
from .nullspace import NullspaceResult, nullspace_point_reach, nullspace_step, point_on_circle, point_reaching_velocity
from .teleop import ScriptedInput, Teleoperator, command_to_bivector, run_interactive

__all__ = [
    "DiffIKResult", "diff_ik_reach", "diff_ik_step", "joint_velocity",
    "IKResult", "gauss_newton_ik",
    "TaskDynamics", "joint_dynamics", "task_inertia", "task_space_dynamics",
    "PAPER_GAINS", "ImpedanceResult", "impedance_torque", "simulate_impedance",
    "NullspaceResult", "nullspace_point_reach", "nullspace_step", "point_on_circle", "point_reaching_velocity",
    "ScriptedInput", "Teleoperator", "command_to_bivector", "run_interactive",
    "ILQRIteration", "ILQRResult", "ReachingOCP", "displaced_target", "ilqr_reach",
]
