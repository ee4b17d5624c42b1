"""Kinematics layer: motor forward kinematics of Pinocchio models and multi-chain systems."""

from .chains import LOCAL_TO_TANGENT, Joint, KinematicTree, motor_from_se3

__all__ = ["LOCAL_TO_TANGENT", "Joint", "KinematicTree", "motor_from_se3"]
