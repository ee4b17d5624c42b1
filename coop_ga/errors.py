"""One exception hierarchy for everything coop_ga raises on bad input.

Every error derives from :class:`CoopGAError`, so ``except coop_ga.CoopGAError``
catches all of them.  The concrete classes also derive from the matching
built-in (``ValueError`` / ``KeyError``) so generic handlers keep working.
Messages name the problem *and* the fix.
"""

from __future__ import annotations

__all__ = [
    "CoopGAError",
    "InvalidInputError",
    "NonFiniteError",
    "DegeneratePrimitiveError",
    "InvalidVersorError",
    "UnknownNameError",
    "UnsupportedJointError",
    "DegeneracyWarning",
    "ChartWarning",
    "JointLimitWarning",
]


class CoopGAError(Exception):
    """Base class of every exception raised by coop_ga."""


class InvalidInputError(CoopGAError, ValueError):
    """An argument has the wrong shape, type or value (e.g. a q of the wrong size)."""


class NonFiniteError(InvalidInputError):
    """An argument contains NaN or inf."""


class DegeneratePrimitiveError(CoopGAError, ValueError):
    """Points do not span the requested primitive (coincident, collinear, coplanar)."""


class InvalidVersorError(CoopGAError, ValueError):
    """A multivector is not an element of the requested versor group (or has zero norm)."""


class UnknownNameError(CoopGAError, KeyError):
    """An unknown system, robot, frame or primitive kind; the message lists the valid ones."""

    def __str__(self) -> str:  # KeyError would otherwise repr() the message
        return str(self.args[0]) if self.args else ""


class UnsupportedJointError(CoopGAError, ValueError):
    """A kinematic model contains a joint type coop_ga cannot express as a motor."""


class DegeneracyWarning(UserWarning):
    """A cooperative primitive is close to degenerate (near a geometric singularity)."""


class ChartWarning(UserWarning):
    """V_Sc is near the half-turn discontinuity of its minimal-rotation chart (axis ≈ −unit axis)."""


class JointLimitWarning(UserWarning):
    """A configuration lies outside the joint limits (reported, never silently clipped)."""
