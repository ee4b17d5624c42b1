"""The error contract of coop_ga.linkages: bad arguments raise a CoopGAError naming them, work is bounded.

Regression tests: ``FourBar.simulate([0, 1e6])`` never returned (11 million crank substeps), a zero
``max_step`` looped forever, NaN link points and coupler points gave NaN motions, ``branch=True`` was taken
for +1, and ``freudenstein_output`` returned NaN where the linkage cannot be assembled.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from coop_ga.errors import InvalidInputError, NonFiniteError
from coop_ga.linkages import (
    Link,
    Linkage,
    LinkageError,
    Prismatic,
    Revolute,
    crank_limits,
    dyad,
    four_bar,
    freudenstein_output,
    grashof,
    slider_crank,
)
from coop_ga.linkages.model import MAX_SUBSTEPS
from coop_ga.linkages.planar import apply_point, motor_pose

NAN = float("nan")
FB = (2.0, 0.5, 2.0, 1.5)


def test_a_huge_crank_range_is_refused_at_once_naming_the_range_and_the_limit():
    fb = four_bar(*FB)
    t0 = time.perf_counter()
    for f in (fb.simulate, fb.solve):
        with pytest.raises(InvalidInputError, match=r"crank_angles span 1e\+06 rad .* max_substeps = 100000"):
            f([0.0, 1e6])
    assert time.perf_counter() - t0 < 5.0  # refused before any work (it ran for hours before)
    # the limit is an option: a smaller one refuses a shorter range, a larger one allows it
    with pytest.raises(InvalidInputError, match="max_substeps = 10"):
        fb.solve(np.linspace(0.0, 2 * np.pi, 5), max_substeps=10)
    m = fb.solve(np.linspace(0.0, 2 * np.pi, 5), max_substeps=200)  # ≥ 2π / 5° = 72 substeps (+ halvings)
    assert m.complete and 72 <= m.substeps.sum() <= 200
    assert MAX_SUBSTEPS == 100_000


def test_substeps_halved_beyond_the_budget_stop_the_motion_with_a_message():
    """A non-Grashof 4-bar halves its substeps toward the toggle: with a budget of 8 the motion stops early."""
    fb = four_bar(1.0, 0.8, 0.5, 0.45)
    lim = crank_limits(1.0, 0.8, 0.5, 0.45)[0]
    m = fb.solve(np.linspace(0.0, lim + 0.2, 3), max_substeps=8, max_step=0.5)
    assert not m.complete and "max_substeps" in m.message


@pytest.mark.parametrize(
    "options, arg",
    [
        ({"max_step": 0.0}, "max_step"),
        ({"min_step": 0.0}, "min_step"),
        ({"min_step": 1.0, "max_step": 0.1}, "min_step"),
        ({"tol": -1.0}, "tol"),
        ({"max_iter": 2.5}, "max_iter"),
        ({"guard": "no"}, "guard"),
        ({"speed": 2.0}, "speed"),
    ],
)
def test_track_options_are_checked(options, arg):
    with pytest.raises(InvalidInputError, match=arg):
        four_bar(*FB).simulate([0.0, 0.5], **options)


def test_link_geometry_and_joints_are_checked():
    with pytest.raises(NonFiniteError, match=r"points\['B'\] of link 'coupler'"):
        Link("coupler", {"A": (0.5, 0.0), "B": (NAN, 1.2)})
    with pytest.raises(InvalidInputError, match=r"Link\.points"):
        Link("bar", [[0.0, 0.0]])
    with pytest.raises(InvalidInputError, match="Revolute a"):
        Revolute("crank.A", ("coupler", "A"))
    with pytest.raises(InvalidInputError, match="Prismatic guide"):
        Prismatic(("s", "S"), ("g", "G1"))
    with pytest.raises(InvalidInputError, match="links must be a list of Link"):
        Linkage(["ground", "crank"], [])
    with pytest.raises(LinkageError, match="guide points 'G1' and 'G2' of link 'ground' coincide"):
        Linkage(
            [
                Link("ground", {"O": (0, 0), "G1": (0, 3), "G2": (0, 3)}),
                Link("crank", {"O": (0, 0), "A": (1, 0)}),
                Link("rod", {"A": (1, 0), "S": (0, 3.873)}),
                Link("slider", {"S": (0, 3.873)}),
            ],
            [
                Revolute(("crank", "A"), ("rod", "A")),
                Revolute(("rod", "S"), ("slider", "S")),
                Prismatic(("slider", "S"), ("ground", "G1", "G2")),
            ],
        )


def test_four_bar_arguments_are_checked():
    with pytest.raises(InvalidInputError, match="branch must be the integer"):
        four_bar(*FB, branch=True)  # True == 1 was accepted
    with pytest.raises(InvalidInputError, match="branch"):
        four_bar(*FB, branch=1.0)
    with pytest.raises(NonFiniteError, match="coupler_point"):
        four_bar(*FB).__class__(*FB, coupler_point=(NAN, 0.5))
    with pytest.raises(InvalidInputError, match=r"ground \[m\] must be a real number"):
        grashof("2", 0.5, 2.0, 1.5)
    with pytest.raises(NonFiniteError, match="phi"):
        four_bar(*FB).closed_form(NAN)
    with pytest.raises(InvalidInputError, match="motors"):
        four_bar(*FB).newton([0.0] * 8, 0.0)  # zero rotation parts: no rigid motion
    with pytest.raises(InvalidInputError, match="phi"):
        four_bar(*FB).positions(four_bar(*FB).identity_motors(), "0")
    with pytest.raises(InvalidInputError, match="rod"):
        slider_crank(1.0, float("inf"))


def test_closed_forms_never_return_nan():
    """Freudenstein's output was NaN where the 4-bar cannot be assembled: now an error naming the angle."""
    lengths = (1.0, 0.8, 0.5, 0.45)  # at θ2 = π the crank tip is 1.8 m from D, beyond b + c = 0.95
    with pytest.raises(LinkageError, match=r"theta2: .* first θ2 = 3\.14"):
        freudenstein_output(*lengths, [0.0, 3.14])
    out = freudenstein_output(*lengths, [0.0, 0.1])
    assert np.all(np.isfinite(out))
    with pytest.raises(InvalidInputError, match="crank"):
        crank_limits(2.0, 0.0, 2.0, 1.5)  # a ZeroDivisionError before
    with pytest.raises(NonFiniteError, match=r"\bp\b"):
        dyad([NAN, 0.0], [1.0, 0.0], 1.0, 1.0)
    with pytest.raises(InvalidInputError, match="branch"):
        dyad([0.0, 0.0], [1.0, 0.0], 1.0, 1.0, 2)


def test_planar_motors_check_numeric_input():
    with pytest.raises(InvalidInputError, match=r"\bm\b.*rotation part"):
        apply_point([0.0, 0.0, 0.0, 0.0], (1.0, 0.0))
    with pytest.raises(NonFiniteError, match=r"\bm\b"):
        motor_pose([NAN, 0.0, 0.0, 0.0])
    with pytest.raises(InvalidInputError, match=r"\bm\b"):
        motor_pose([1.0, 0.0, 0.0])
