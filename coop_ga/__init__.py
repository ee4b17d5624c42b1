"""coop_ga: cooperative task spaces for multi-chain robots with conformal geometric algebra.

Layers (each depends only on the ones above it):

1. :mod:`coop_ga.algebra` — G(4,1) in the null basis, numpy or CasADi coefficients;
2. :mod:`coop_ga.geometry` — primitives, versor groups (exp/log), similarities;
3. :mod:`coop_ga.kinematics` — motor forward kinematics of Pinocchio models;
4. :mod:`coop_ga.systems` — multi-chain systems, their registry and the robots we ship;
5. :mod:`coop_ga.viz` — drawing (robots, primitives, frames, plots);
6. :mod:`coop_ga.cooperative` — cooperative primitives, V_Sc(q), its graph, guard and Jacobians;
7. :mod:`coop_ga.control` — differential/Gauss–Newton IK, impedance, iLQR, teleoperation;
8. :mod:`coop_ga.harness` — the command-line harness of experiments and figures.

Cross-cutting, at the bottom: :mod:`coop_ga.errors` (one exception and one warning
family), :mod:`coop_ga.diagnostics` (warnings once per call), :mod:`coop_ga.validation`
(argument checks), :mod:`coop_ga.codegen` (compiled CasADi functions).

The currency of the API is :class:`coop_ga.Similarity`: cooperative poses, targets and
``displaced_target`` are Similarities.

Five lines of control::

    import coop_ga as cg
    task = cg.cooperative_task("three_franka", "circle")
    q0 = task.system.q0
    target = cg.control.displaced_target(task, q0, translation=(0.1, 0, 0.05), angle=0.3, scale=1.2)
    print(cg.control.gauss_newton_ik(task, q0, target).error, cg.control.ilqr_reach(task, q0, target).error)

Reference: T. Löw, C. Bilaloglu, S. Calinon, *Cooperative Task Spaces for Multi-Arm
Manipulation Control based on Similarity Transformations*.
"""

from . import control, diagnostics, systems, validation
from .algebra import Multivector
from .cooperative import CooperativeTask, cooperative_task, displaced_target
from .errors import (
    CacheWarning,
    ChartError,
    ChartWarning,
    CompilationError,
    CoopGAError,
    CoopGAWarning,
    DegeneracyWarning,
    DegeneratePrimitiveError,
    InfeasibleConstraintsError,
    InvalidInputError,
    InvalidVersorError,
    JointLimitWarning,
    NonFiniteError,
    PrecisionWarning,
    RendererUnavailableError,
    RenderWarning,
    ThreadingError,
    UnknownNameError,
    UnreachableError,
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
    interpolate,
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
    reference_trajectory,
    screw_axis,
    screw_exp,
    screw_log,
    similarity,
    similarity_from_unit,
    sphere,
    to_euclidean,
    unit_primitive,
    well_definedness,
)

__version__ = "0.1.0"

__all__ = [
    "KINDS",
    "TANGENT_BASIS",
    "CacheWarning",
    "ChartError",
    "ChartWarning",
    "CompilationError",
    "CoopGAError",
    "CoopGAWarning",
    "CooperativeTask",
    "DegeneracyWarning",
    "DegeneratePrimitiveError",
    "Dilator",
    "InfeasibleConstraintsError",
    "InvalidInputError",
    "InvalidVersorError",
    "JointLimitWarning",
    "Motor",
    "Multivector",
    "NonFiniteError",
    "PrecisionWarning",
    "Primitive",
    "RenderWarning",
    "RendererUnavailableError",
    "Rotor",
    "Similarity",
    "ThreadingError",
    "Translator",
    "UnknownNameError",
    "UnreachableError",
    "UnsupportedJointError",
    "VersorGroup",
    "apply",
    "center",
    "circle",
    "closest_point_to_origin",
    "control",
    "cooperative_task",
    "decompose",
    "diagnostics",
    "direction",
    "displaced_target",
    "endpoints",
    "exp",
    "interpolate",
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
    "reference_trajectory",
    "screw_axis",
    "screw_exp",
    "screw_log",
    "similarity",
    "similarity_from_unit",
    "sphere",
    "systems",
    "to_euclidean",
    "unit_primitive",
    "validation",
    "well_definedness",
]

from types import ModuleType as _ModuleType


def __getattr__(name: str) -> _ModuleType:
    """``coop_ga.viz`` and ``coop_ga.viewer`` are imported on first use (PEP 562): drawing and the
    browser viewer stay out of ``import coop_ga``."""
    if name in ("viz", "viewer"):
        import importlib

        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
