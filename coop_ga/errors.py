"""One exception hierarchy and one warning hierarchy for everything coop_ga raises or warns.

Every error derives from :class:`CoopGAError`, so ``except coop_ga.CoopGAError``
catches all of them.  The concrete classes also derive from the matching
built-in (``ValueError`` / ``KeyError`` / ``RuntimeError``) so generic handlers keep
working.  Messages name the problem *and* the fix.

Every warning derives from :class:`CoopGAWarning` (``warnings.simplefilter("error",
coop_ga.CoopGAWarning)`` turns all of them into errors).  How warnings are emitted —
once per condition and public call, pointing at the caller's line — is in
:mod:`coop_ga.warn`.
"""

from __future__ import annotations

__all__ = [
    "CacheWarning",
    "ChartError",
    "ChartWarning",
    "CompilationError",
    "CoopGAError",
    "CoopGAWarning",
    "DegeneracyWarning",
    "DegeneratePrimitiveError",
    "InfeasibleConstraintsError",
    "InvalidInputError",
    "InvalidVersorError",
    "JointLimitWarning",
    "NonFiniteError",
    "PrecisionWarning",
    "RateWarning",
    "RenderWarning",
    "RendererUnavailableError",
    "ThreadingError",
    "UnknownNameError",
    "UnreachableError",
    "UnsupportedJointError",
]


class CoopGAError(Exception):
    """Base class of every exception raised by coop_ga."""


class InvalidInputError(CoopGAError, ValueError):
    """An argument has the wrong shape, type or value (e.g. a q of the wrong size)."""


class NonFiniteError(InvalidInputError):
    """An argument contains NaN or inf."""


class DegeneratePrimitiveError(CoopGAError, ValueError):
    """Points do not span the requested primitive (coincident, collinear, coplanar)."""


class InvalidVersorError(InvalidInputError):
    """A multivector is not an element of the requested versor group (or has zero norm)."""


class ChartError(CoopGAError, ValueError):
    """A similarity lies at the half-turn discontinuity of the minimal-rotation chart of V_Sc."""


class UnknownNameError(CoopGAError, KeyError):
    """An unknown system, robot, frame or primitive kind; the message lists the valid ones."""

    def __str__(self) -> str:  # KeyError would otherwise repr() the message
        return str(self.args[0]) if self.args else ""


class UnsupportedJointError(CoopGAError, ValueError):
    """A kinematic model contains a joint type coop_ga cannot express as a motor."""


class InfeasibleConstraintsError(CoopGAError, RuntimeError):
    """The limits and user constraints of a controller's QP step have no common point (or the QP solver failed)."""


class CompilationError(CoopGAError, RuntimeError):
    """Generating, compiling or loading a CasADi function failed and no fallback was allowed."""


class ThreadingError(CoopGAError, RuntimeError):
    """An object that is not thread-safe was used from a second thread."""


class UnreachableError(CoopGAError, ValueError):
    """A foot (end-point) target has no inverse-kinematics solution: it is out of a leg's reach
    (the message names the legs and by how many mm) or its only solution leaves the joint limits
    (the message names the joint and by how much).

    Attributes: ``legs`` (names of the offending legs), ``distance`` (the largest distance out of
    reach [m], 0.0 for a pure joint-limit failure) and ``violation`` (the largest joint-limit
    violation [rad], 0.0 for a reach failure).
    """

    def __init__(self, message: str, *, legs: tuple[str, ...] = (), distance: float = 0.0, violation: float = 0.0):
        super().__init__(message)
        self.legs = tuple(legs)
        self.distance = float(distance)
        self.violation = float(violation)


class CoopGAWarning(UserWarning):
    """Base class of every warning coop_ga emits."""


class DegeneracyWarning(CoopGAWarning):
    """A cooperative primitive is close to degenerate (near a geometric singularity)."""


class ChartWarning(CoopGAWarning):
    """V_Sc is near the half-turn discontinuity of its minimal-rotation chart (axis ≈ −unit axis)."""


class JointLimitWarning(CoopGAWarning):
    """A configuration lies outside the joint limits (reported, never silently clipped)."""


class PrecisionWarning(CoopGAWarning):
    """A result lost precision (e.g. a primitive far from the origin); the message estimates the error."""


class RateWarning(CoopGAWarning):
    """A periodic controller's tick took longer than its period (the message gives the measured time)."""


class CacheWarning(CoopGAWarning):
    """The compile cache was unusable and a fallback was taken (the message says which and the fix)."""


class RenderWarning(CoopGAWarning):
    """The figure was drawn with a fallback: no OpenGL context for the mesh renderer (matplotlib
    meshes instead), or a robot without visual geometry (its skeleton instead)."""


class RendererUnavailableError(CoopGAError, RuntimeError):
    """The renderer asked for explicitly (``backend="vtk"``) cannot run here (the message says why)."""
