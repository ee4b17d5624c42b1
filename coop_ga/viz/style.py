"""One palette, one font set-up and one resolution for every coop_ga figure (paper style).

Colours follow the paper's figures: the robot at its *initial* configuration is drawn
light (a near-white surface when drawn from its meshes), at its *final* configuration
grey; the *initial* primitive is green, the *final* one turquoise, a *target* black and
dashed; end-point *trajectories* are red; *intermediate* primitives are thin lines shaded
from the initial to the final colour.

Use :func:`style` as a context manager (``with style(): ...``) or :func:`use_style`
once per script; :data:`DPI` is the resolution every figure is saved with.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from cycler import cycler

__all__ = [
    "BIVECTOR_COLORS",
    "BIVECTOR_LABELS",
    "BIVECTOR_RATE_UNITS",
    "BIVECTOR_UNITS",
    "DPI",
    "LINEWIDTH",
    "PALETTE",
    "RC",
    "Palette",
    "blend",
    "style",
    "use_style",
]

#: Resolution [dots per inch] of every saved figure.
DPI = 150

#: Mathtext labels of the 7 similarity-bivector components, in ``coop_ga.TANGENT_BASIS``
#: order ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``.
BIVECTOR_LABELS = (
    r"$e_{12}$",
    r"$e_{13}$",
    r"$e_{23}$",
    r"$e_{0\infty}$",
    r"$e_{1\infty}$",
    r"$e_{2\infty}$",
    r"$e_{3\infty}$",
)

#: Units of the 7 bivector components (rotation | dilation, ln of the scale | translation in lengths of the
#: primitive's body frame: its radius, or 1 m for flats), and of their rates.
BIVECTOR_UNITS = "rad | 1 | body length"
BIVECTOR_RATE_UNITS = "rad/s | 1/s | body length/s"

#: One colour per bivector component (matplotlib's tab10, first seven).
BIVECTOR_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2")


@dataclass(frozen=True)
class Palette:
    """Named colours (any matplotlib colour spec) of the paper style."""

    robot: str = "0.15"  # a single configuration (system drawings)
    initial_robot: str = "0.78"  # initial configuration: light
    final_robot: str = "0.35"  # final configuration: grey
    fixed: str = "0.6"  # locked / fixed structure (bases, locked legs)
    end_point: str = "#d62728"  # end-point markers
    initial_primitive: str = "#2ca02c"  # green
    final_primitive: str = "#40e0d0"  # turquoise
    target_primitive: str = "black"  # dashed
    primitive: str = "#1f77b4"  # a primitive drawn on its own
    trajectory: str = "#d62728"  # red end-point paths
    # paths that must be told apart (left / right hand, …): the first is ``trajectory``
    trajectories: tuple[str, ...] = ("#d62728", "#9467bd", "#ff7f0e", "#8c564b")
    target_point: str = "#ff7f0e"  # a target point (orange: apart from the black held / neutral markers)
    frame_axes: tuple[str, str, str] = ("#d62728", "#2ca02c", "#1f77b4")  # x, y, z
    # robots drawn from their meshes (lit surfaces: lighter than the skeleton lines)
    initial_mesh: str = "0.96"  # initial configuration: near-white
    final_mesh: str = "0.58"  # final configuration: grey
    robot_mesh: str = "0.72"  # a single configuration

    def intermediate(self, s: float) -> Any:
        """Colour of an intermediate primitive at fraction ``s`` ∈ [0, 1] of the motion
        (initial → final colour)."""
        return blend(self.initial_primitive, self.final_primitive, s)


PALETTE = Palette()

#: Line widths [pt] used by the drawing functions.
LINEWIDTH = {"robot": 2.2, "primitive": 2.0, "intermediate": 0.8, "trajectory": 1.4, "wire": 0.4}

#: matplotlib rcParams of the paper style (fonts, grid, legend, saving).
RC: dict[Any, Any] = {
    "font.family": "DejaVu Sans",
    "mathtext.fontset": "dejavusans",
    "font.size": 9.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 9.0,
    "legend.fontsize": 8.0,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "axes.grid": False,
    "grid.alpha": 0.3,
    "legend.framealpha": 0.85,
    "figure.dpi": 100.0,
    "savefig.dpi": DPI,
    "savefig.bbox": "tight",
    "savefig.pad_inches": 0.1,
    "axes.prop_cycle": cycler(color=[*BIVECTOR_COLORS, "#7f7f7f", "#bcbd22", "#17becf"]),  # tab10
}


def blend(c0: Any, c1: Any, s: float) -> tuple[float, float, float, float]:
    """RGBA colour ``(1 − s) c0 + s c1`` (``s`` clipped to [0, 1])."""
    from matplotlib.colors import to_rgba

    s = float(np.clip(s, 0.0, 1.0))
    a, b = np.asarray(to_rgba(c0)), np.asarray(to_rgba(c1))
    return tuple(float(x) for x in (1.0 - s) * a + s * b)  # type: ignore[return-value]


@contextlib.contextmanager
def style() -> Iterator[None]:
    """Context manager: the paper-style rcParams inside the block only."""
    import matplotlib

    with matplotlib.rc_context(RC):
        yield


def use_style() -> None:
    """Apply the paper-style rcParams globally (for the rest of the process)."""
    import matplotlib

    matplotlib.rcParams.update(RC)
