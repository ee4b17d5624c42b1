"""coop_ga: cooperative task spaces for multi-chain robots with conformal geometric algebra.

Layers (each depends only on the ones above it):

1. :mod:`coop_ga.algebra` — G(4,1) in the null basis, numpy or CasADi coefficients;
2. :mod:`coop_ga.geometry` — primitives, versor groups (exp/log), similarities;
3. :mod:`coop_ga.kinematics` — motor forward kinematics of Pinocchio models, systems;
4. :mod:`coop_ga.cooperative` — cooperative primitives, V_Sc(q) and its Jacobians;
5. :mod:`coop_ga.control` — differential/Gauss–Newton IK, impedance, iLQR, teleoperation.

Reference: T. Löw, C. Bilaloglu, S. Calinon, *Cooperative Task Spaces for Multi-Arm
Manipulation Control based on Similarity Transformations*.
"""

from .algebra import Multivector
from .errors import (
    ChartWarning,
    CoopGAError,
    DegeneracyWarning,
    DegeneratePrimitiveError,
    InvalidInputError,
    InvalidVersorError,
    JointLimitWarning,
    NonFiniteError,
    UnknownNameError,
    UnsupportedJointError,
)
from .geometry import (
    KINDS,
    TANGENT_BASIS,
    Dilator,
    Motor,
    Primitive,
    Rotor,
    Similarity,
    Translator,
    VersorGroup,
    apply,
    center,
    circle,
    closest_point_to_origin,
    decompose,
    direction,
    endpoints,
    exp,
    kind_of,
    line,
    log,
    log_jacobian,
    meet,
    normal,
    plane,
    point,
    point_pair,
    primitive_from_points,
    project,
    radius,
    similarity,
    similarity_from_unit,
    sphere,
    to_euclidean,
    unit_primitive,
    well_definedness,
)

from . import systems
from .cooperative import CooperativeTask, cooperative_task

__version__ = "0.1.0"

__all__ = [
    "Multivector",
    "systems",
    "CooperativeTask",
    "cooperative_task",
    "ChartWarning",
    "CoopGAError",
    "DegeneracyWarning",
    "DegeneratePrimitiveError",
    "InvalidInputError",
    "InvalidVersorError",
    "JointLimitWarning",
    "NonFiniteError",
    "UnknownNameError",
    "UnsupportedJointError",
    "KINDS",
    "TANGENT_BASIS",
    "Dilator",
    "Motor",
    "Primitive",
    "Rotor",
    "Similarity",
    "Translator",
    "VersorGroup",
    "apply",
    "center",
    "circle",
    "closest_point_to_origin",
    "decompose",
    "direction",
    "endpoints",
    "exp",
    "kind_of",
    "line",
    "log",
    "log_jacobian",
    "meet",
    "normal",
    "plane",
    "point",
    "point_pair",
    "primitive_from_points",
    "project",
    "radius",
    "similarity",
    "similarity_from_unit",
    "sphere",
    "to_euclidean",
    "unit_primitive",
    "well_definedness",
]
