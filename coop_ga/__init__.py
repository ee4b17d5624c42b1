"""coop_ga: cooperative task spaces for multi-chain robots with conformal geometric algebra.

The subpackages, bottom to top (each imports only the ones before it; the order is stated once, in
``tests/test_layers.py``, which checks it): :mod:`coop_ga.algebra` (G(4,1) in the null basis, numpy or
CasADi coefficients), :mod:`coop_ga.geometry` (primitives, the kind table, versor groups, similarities),
:mod:`coop_ga.kinematics` (motor forward kinematics of Pinocchio models), ``linkages`` (planar closed
chains), :mod:`coop_ga.systems` (multi-chain systems and their registry), ``collision`` (clearances),
:mod:`coop_ga.viz` (drawing), :mod:`coop_ga.cooperative` (the cooperative task: X_c(q), V_Sc(q), its graph,
guard and Jacobians), :mod:`coop_ga.control` (tasks, limits, one QP step, the solvers and their registry),
``legged``, ``sim``, ``viewer`` (the browser viewer), ``sweep`` and :mod:`coop_ga.harness` (the command
line of experiments and figures).  At the bottom, under all of them: :mod:`coop_ga.errors` (one exception and
one warning family), :mod:`coop_ga.diagnostics` (warnings once per call), :mod:`coop_ga.validation` (argument
checks) and :mod:`coop_ga.codegen` (compiled CasADi functions).

The currency of the API is :class:`coop_ga.Similarity`: cooperative poses, targets and
``displaced_target`` are Similarities; every solver takes ``(task, q_init, target: SimilarityLike, …)``.
The multivector-level functions on raw versors (``exp``, ``log``, ``log_jacobian``, ``apply``,
``similarity``, ``similarity_from_unit``, ``decompose``) live in :mod:`coop_ga.geometry`, the layer below;
here they are methods of :class:`Similarity` (``Similarity.exp(b)``, ``V.log()``, ``V.log_jacobian()``,
``V.apply(X)``, ``Similarity.between(X1, X2)``, ``Similarity.from_unit(X)``, ``V.decompose()``).
The facts of each primitive kind are one table, :data:`KIND_SPECS` (:class:`KindSpec`).

Five lines of control::

    import coop_ga as cg
    task = cg.cooperative_task("three_franka", "circle")
    q_init = task.system.q0
    target = cg.control.displaced_target(task, q_init, translation=(0.1, 0, 0.05), angle=0.3, scale=1.2)
    print(cg.control.gauss_newton_ik(task, q_init, target).error, cg.control.ilqr_reach(task, q_init, target).error)

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
    COOPERATIVE_KINDS,
    KIND_SPECS,
    KINDS,
    TANGENT_BASIS,
    CooperativeKind,
    Dilator,
    Kind,
    KindSpec,
    Motor,
    Primitive,
    Rotor,
    Similarity,
    SimilarityLike,
    Translator,
    VersorGroup,
    center,
    circle,
    closest_point_to_origin,
    direction,
    endpoints,
    interpolate,
    kind_of,
    kind_spec,
    line,
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
    sphere,
    to_euclidean,
    unit_primitive,
    well_definedness,
)

__version__ = "0.1.0"

__all__ = [
    "COOPERATIVE_KINDS",
    "KINDS",
    "KIND_SPECS",
    "TANGENT_BASIS",
    "CacheWarning",
    "ChartError",
    "ChartWarning",
    "CompilationError",
    "CoopGAError",
    "CoopGAWarning",
    "CooperativeKind",
    "CooperativeTask",
    "DegeneracyWarning",
    "DegeneratePrimitiveError",
    "Dilator",
    "InfeasibleConstraintsError",
    "InvalidInputError",
    "InvalidVersorError",
    "JointLimitWarning",
    "Kind",
    "KindSpec",
    "Motor",
    "Multivector",
    "NonFiniteError",
    "PrecisionWarning",
    "Primitive",
    "RenderWarning",
    "RendererUnavailableError",
    "Rotor",
    "Similarity",
    "SimilarityLike",
    "ThreadingError",
    "Translator",
    "UnknownNameError",
    "UnreachableError",
    "UnsupportedJointError",
    "VersorGroup",
    "center",
    "circle",
    "closest_point_to_origin",
    "control",
    "cooperative_task",
    "diagnostics",
    "direction",
    "displaced_target",
    "endpoints",
    "interpolate",
    "kind_of",
    "kind_spec",
    "line",
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
