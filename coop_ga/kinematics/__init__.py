"""Kinematics layer: motor forward kinematics of Pinocchio models and multi-chain systems,
singularity classification by meets of the joint-axis lines, and the 5-DOF arm's geometric IK."""

from .arm5_ik import ARM5, Arm5Geometry, Arm5IKResult, Arm5UnreachableError, arm5_ik
from .chains import LOCAL_TO_TANGENT, Joint, KinematicTree, motor_from_se3
from .singularities import SingularityReport, axis_relation, classify_singularities, joint_axis_lines

__all__ = [
    "ARM5",
    "LOCAL_TO_TANGENT",
    "Arm5Geometry",
    "Arm5IKResult",
    "Arm5UnreachableError",
    "Joint",
    "KinematicTree",
    "SingularityReport",
    "arm5_ik",
    "axis_relation",
    "classify_singularities",
    "joint_axis_lines",
    "motor_from_se3",
]
