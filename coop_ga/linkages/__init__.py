"""Planar closed-loop linkages in CGA with a Lie-algebra Newton solver (seed 004).

Links are rigid bodies moved by planar motors of G(4,1) (:mod:`.planar`), joints are CGA
residuals, the crank is advanced step by step and the other links follow by Newton steps in
the Lie algebra with a CasADi Jacobian, with branch tracking (:mod:`.model`).  Classic
linkages and their closed forms are in :mod:`.library`::

    from coop_ga.linkages import four_bar
    xy = four_bar(2.0, 0.5, 2.0, 1.5).simulate(np.linspace(0, 2 * np.pi, 361))   # (361, 4, 2)
"""

from .library import (
    FourBar,
    crank_limits,
    dyad,
    four_bar,
    freudenstein_output,
    grashof,
    slider_crank,
    ten_bar,
    watt_six_bar,
)
from .model import Link, Linkage, LinkageError, LinkageMotion, Prismatic, Revolute

__all__ = [
    "FourBar",
    "Link",
    "Linkage",
    "LinkageError",
    "LinkageMotion",
    "Prismatic",
    "Revolute",
    "crank_limits",
    "dyad",
    "four_bar",
    "freudenstein_output",
    "grashof",
    "slider_crank",
    "ten_bar",
    "watt_six_bar",
]
