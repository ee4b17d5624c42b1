"""The facts of each primitive kind, in one table (:data:`KIND_SPECS`).

Every module that needs to know something about a kind — how many points span it, whether it is flat,
its unit primitive and axis, its degrees of freedom, how its points degenerate, which least-squares
kind fits it — reads it here instead of comparing kind names, so adding a kind means adding a row
(and its graph builder, docs/contributing.md) and ``tests/cooperative/test_kinds.py`` checks every
fact of every row against computation.

=============  ======  =====  ====  ===========================  ==============  ==================================
kind           points  flat   DOF   unit primitive X_u           axis of X_u     Table 1 blades (exact at X_u)
=============  ======  =====  ====  ===========================  ==============  ==================================
point          1       no     3     the origin                   —               e1∞ e2∞ e3∞ (everywhere)
point_pair     2       no     6     (0, ∓1, 0)                   direction +e2   e12 e23 e0∞ e1∞ e2∞ e3∞
line           2       yes    4     the e2 axis                  direction +e2   e12 e23 e1∞ e3∞
circle         3       no     6     unit circle in z = 0         normal +e3      e13 e23 e0∞ e1∞ e2∞ e3∞
plane          3       yes    3     the plane z = 0              normal +e3      e13 e23 e3∞
sphere         4       no     4     the unit sphere              —               e0∞ e1∞ e2∞ e3∞ (everywhere)
sphere_fit     ≥ 4     no     4     as sphere (it fits one)      —               as sphere
plane_fit      ≥ 3     yes    3     as plane (it fits one)       normal +e3      as plane
line_fit       ≥ 2     yes    4     as line (it fits one)        direction +e2   as line
circle_fit     ≥ 3     no     6     as circle (it fits one)      normal +e3      as circle
=============  ======  =====  ====  ===========================  ==============  ==================================

A point pair has no least-squares kind: it is its two points, and more points have no best pair (their principal
axis is ``line_fit``, :mod:`coop_ga.cooperative.primitive`).

The controllable blades are the paper's Table 1 column (seed 003).  Measured
(``experiments/table1.py``, docs/table1.md): the DOF column is right everywhere, the blade sets span
the range of J^G exactly at the unit primitive, and away from it only for points and spheres
(:attr:`KindSpec.blades_hold_everywhere`): for the others the minimal-rotation chart couples roll
into the body-frame rows the paper excludes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal, TypeAlias, cast

from ..errors import InvalidInputError, UnknownNameError

__all__ = [
    "COOPERATIVE_KINDS",
    "FIT_KINDS",
    "FLAT_KINDS",
    "KINDS",
    "KIND_SPECS",
    "N_POINTS",
    "UNIT_AXIS",
    "AxisRole",
    "CooperativeKind",
    "FitKind",
    "Kind",
    "KindSpec",
    "kind_spec",
]

#: an exact primitive kind: spanned by exactly :attr:`KindSpec.n_points` points (∧ e∞ for the flats)
Kind: TypeAlias = Literal["point", "point_pair", "line", "circle", "plane", "sphere"]
#: a least-squares kind: the best sphere / plane / line / circle through any number of points (:mod:`coop_ga.cooperative.primitive`)
FitKind: TypeAlias = Literal["sphere_fit", "plane_fit", "line_fit", "circle_fit"]
#: every kind a cooperative task accepts
CooperativeKind: TypeAlias = Literal[
    "point", "point_pair", "line", "circle", "plane", "sphere", "sphere_fit", "plane_fit", "line_fit", "circle_fit"
]
#: how a kind's axis is read: the direction of a point pair / line, the normal of a circle / plane
AxisRole: TypeAlias = Literal["direction", "normal"]

Vec3: TypeAlias = tuple[float, float, float]


@dataclass(frozen=True)
class KindSpec:
    """The facts of one primitive kind (module table).

    Attributes:
        name: the kind's name (a :data:`CooperativeKind`).
        n_points: points that span it (an exact kind), or the fewest a least-squares kind accepts.
        flat: ``∧ e∞`` is appended (a line or plane: it passes through infinity, has no centre or radius).
        dof: degrees of freedom of the primitive = rank of the similarity Jacobian J^G (Table 1's dimension).
        unit_points: points (n_points × 3) [m] that span the unit primitive X_u (Table 1, §3.3), in the order
            that gives it the orientation of :attr:`axis`.
        axis: orientation axis of X_u (3,), or None (points and spheres have none).
        axis_role: ``"direction"`` (point pair, line: first point → second) or ``"normal"`` (circle, plane:
            right hand from the point order), or None.
        half_turn_axis: the fixed axis ⟂ :attr:`axis` of the half-turn the similarity uses when the target's
            axis is exactly opposite (:func:`~coop_ga.geometry.similarity.rotor_between`), or None.
        controllable_blades: the paper's Table 1 column, names of :data:`~coop_ga.geometry.groups.TANGENT_BASIS`.
        blades_hold_everywhere: whether those blades span the range of J^G at every configuration (measured:
            only where V_Sc has no rotation part); they always do at X_u.
        degenerate: how the spanning points degenerate (``"coincide"``, ``"are collinear"``, ``"are
            coplanar"``; empty for a point, which never does).
        degeneracy: the guard's sentence for degenerate end points of a cooperative task.
        advice: what to do about degenerate points (the geometry layer's error message).
        max_degree: the largest length degree of its blades (Euclidean generators + 2 for e∞): a round's
            coefficients grow like ``|x|^max_degree`` (a flat's two degrees slower, its e∞ factor being exact),
            which bounds the coordinates whose primitive is representable in float64 (conservatively for flats).
        primitive_kind: the exact kind of the primitive itself (``"sphere"`` for ``"sphere_fit"``; the kind of
            V_Sc's unit primitive); the kind itself for exact kinds.
        least_squares: a least-squares kind (any number ≥ n_points of points).
        fit_kind: for an exact kind, the least-squares kind that stands in for it when more points than it needs
            are given (the sphere's and the plane's; None otherwise).  The line and the circle have least-squares
            kinds too (``line_fit``, ``circle_fit``: :data:`FIT_KINDS`), asked for by name only: a stance circle
            goes through exactly three feet (:mod:`coop_ga.legged` reads this field as "any number of feet").
    """

    name: CooperativeKind
    n_points: int
    flat: bool
    dof: int
    unit_points: tuple[Vec3, ...]
    axis: Vec3 | None
    axis_role: AxisRole | None
    half_turn_axis: Vec3 | None
    controllable_blades: tuple[str, ...]
    blades_hold_everywhere: bool
    degenerate: str
    degeneracy: str
    advice: str
    max_degree: int
    primitive_kind: Kind
    least_squares: bool = False
    fit_kind: FitKind | None = None

    @property
    def grade(self) -> int:
        """Grade of its direct (OPNS) blade: the number of spanning points, plus one for ``∧ e∞``."""
        return self.n_points + int(self.flat)

    @property
    def fit_name(self) -> FitKind | None:
        """Its name as a :data:`FitKind` for a least-squares kind, None for an exact kind (the branch of the fit
        code, typed)."""
        return cast(FitKind, self.name) if self.least_squares else None

    @property
    def has_radius(self) -> bool:
        """Round and spanned by more than one point: a point pair, circle or sphere (a point's radius is 0)."""
        return not self.flat and self.n_points > 1

    @property
    def dimension(self) -> int:
        """Dimension of the primitive as a point set: 0 (point, point pair), 1 (line, circle), 2 (plane, sphere)."""
        return max(self.grade - 2, 0)

    def points_used(self, available: int | None = None) -> int:
        """How many end points a task of this kind uses: :attr:`n_points` for an exact kind; for a least-squares
        kind all ``available`` ones, which must be at least :attr:`n_points`.

        Raises:
            InvalidInputError: a least-squares kind without ``available``, or with fewer points than it needs.
        """
        if not self.least_squares:
            return self.n_points
        if available is None:
            raise InvalidInputError(f"a {self.name} uses all the end points it is given; say how many")
        if available < self.n_points:
            raise InvalidInputError(
                f"a least-squares {self.primitive_kind} ({self.name}) needs at least {self.n_points} points, "
                f"got {available}"
            )
        return int(available)


_E2: Vec3 = (0.0, 1.0, 0.0)
_E3: Vec3 = (0.0, 0.0, 1.0)

_EXACT = (
    KindSpec(
        "point", 1, False, 3, ((0.0, 0.0, 0.0),), None, None, None,
        ("e1∞", "e2∞", "e3∞"), True,
        "", "", "", 2, "point",
    ),
    KindSpec(
        "point_pair", 2, False, 6, ((0.0, -1.0, 0.0), (0.0, 1.0, 0.0)), _E2, "direction", _E3,
        ("e12", "e23", "e0∞", "e1∞", "e2∞", "e3∞"), False,
        "coincide", "the two end points coincide",
        "its measure is |b−a|/(|b−a| + ε·max(|a|,|b|)), 0 for coincident points", 3, "point_pair",
    ),
    KindSpec(
        "line", 2, True, 4, ((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)), _E2, "direction", _E3,
        ("e12", "e23", "e1∞", "e3∞"), False,
        "coincide", "the two end points coincide",
        "a line needs two distinct points", 4, "line",
    ),
    KindSpec(
        "circle", 3, False, 6, ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (-1.0, 0.0, 0.0)), _E3, "normal", (1.0, 0.0, 0.0),
        ("e13", "e23", "e0∞", "e1∞", "e2∞", "e3∞"), False,
        "are collinear", "the three end points are (nearly) collinear",
        "a circle through collinear points is a line — use line() or move a point off the line", 4, "circle",
    ),
    KindSpec(
        "plane", 3, True, 3, ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), _E3, "normal", (1.0, 0.0, 0.0),
        ("e13", "e23", "e3∞"), False,
        "are collinear", "the three end points are (nearly) collinear",
        "they do not fix a plane — move one point off the line", 5, "plane", fit_kind="plane_fit",
    ),
    KindSpec(
        "sphere", 4, False, 4, ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (-1.0, 0.0, 0.0)), None, None, None,
        ("e0∞", "e1∞", "e2∞", "e3∞"), True,
        "are coplanar", "the four end points are (nearly) coplanar",
        "four coplanar points span a plane, not a sphere — use plane()/circle() or move a point off the plane", 5,
        "sphere", fit_kind="sphere_fit",
    ),
)  # fmt: skip

_FITTED = {s.name: s for s in _EXACT}
_FITS = (
    replace(
        _FITTED["sphere"],
        name="sphere_fit",
        least_squares=True,
        fit_kind=None,
        degeneracy="the end points are (nearly) coplanar: no 4 of them span a sphere",
    ),
    replace(
        _FITTED["plane"],
        name="plane_fit",
        least_squares=True,
        fit_kind=None,
        degeneracy="the end points are (nearly) collinear, or spread evenly in every direction (no best plane)",
    ),
    replace(
        _FITTED["line"],
        name="line_fit",
        least_squares=True,
        fit_kind=None,
        degeneracy="the end points (nearly) coincide, or spread evenly across a plane (no principal axis)",
    ),
    replace(
        _FITTED["circle"],
        name="circle_fit",
        least_squares=True,
        fit_kind=None,
        degeneracy="the end points are (nearly) collinear, or spread evenly in every direction (no best plane)",
    ),
)

#: the table: every kind a cooperative task accepts → its facts
KIND_SPECS: dict[str, KindSpec] = {s.name: s for s in (*_EXACT, *_FITS)}
#: the exact kinds, in the order of the module table
KINDS: tuple[Kind, ...] = cast(tuple[Kind, ...], tuple(s.name for s in _EXACT))
#: every kind a cooperative task accepts (the exact kinds, then the least-squares kinds)
COOPERATIVE_KINDS: tuple[CooperativeKind, ...] = cast(tuple[CooperativeKind, ...], tuple(KIND_SPECS))
#: least-squares kind → the exact kind it fits
FIT_KINDS: dict[str, Kind] = {s.name: s.primitive_kind for s in _FITS}
#: the exact kinds that pass through infinity (∧ e∞)
FLAT_KINDS: tuple[str, ...] = tuple(s.name for s in _EXACT if s.flat)
#: exact kind → the number of points that span it
N_POINTS: dict[str, int] = {s.name: s.n_points for s in _EXACT}
#: exact kind → the orientation axis of its unit primitive (None: no orientation)
UNIT_AXIS: dict[str, Vec3 | None] = {s.name: s.axis for s in _EXACT}


def kind_spec(kind: str, *, least_squares: bool = True) -> KindSpec:
    """The :class:`KindSpec` of ``kind``: one of :data:`COOPERATIVE_KINDS`, or of :data:`KINDS` only if
    ``least_squares`` is False.

    Raises:
        InvalidInputError: ``kind`` is not a string.
        UnknownNameError: no such kind (the message lists the accepted ones).
    """
    spec = KIND_SPECS.get(kind) if isinstance(kind, str) else None
    if spec is not None and (least_squares or not spec.least_squares):
        return spec
    names = COOPERATIVE_KINDS if least_squares else KINDS
    if not isinstance(kind, str):
        raise InvalidInputError(
            f"kind must be a string, one of {', '.join(names)}; got {type(kind).__name__} {kind!r}"[:200]
        )
    raise UnknownNameError(f"unknown primitive kind {kind!r}; choose one of {', '.join(names)}")
