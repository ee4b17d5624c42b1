"""Time plots: the 7 components of a similarity bivector, and error norms.

Both label their y axis and put their legends outside the data (:func:`legend_outside`), so a legend
never covers a curve's peak; every figure's bivector panel carries the same unit label
(:data:`~coop_ga.viz.style.BIVECTOR_UNITS`, :data:`~coop_ga.viz.style.BIVECTOR_RATE_UNITS`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .style import BIVECTOR_COLORS, BIVECTOR_LABELS, BIVECTOR_RATE_UNITS, BIVECTOR_UNITS

__all__ = ["bivector_ylabel", "legend_outside", "plot_bivector", "plot_error"]


def bivector_ylabel(quantity: str = "bivector", *, rate: bool = False) -> str:
    """The y label of a bivector panel: ``"<quantity> [rad | 1 | body length]"`` (``rate``: per second)."""
    return f"{quantity} [{BIVECTOR_RATE_UNITS if rate else BIVECTOR_UNITS}]"


def legend_outside(ax: Any, **kwargs: Any) -> Any:
    """A legend to the right of ``ax``, outside its data area (top-aligned); keywords go to ``ax.legend``.

    Saved with ``bbox_inches="tight"`` (the paper style's default) the figure grows to hold it.
    Returns the legend.
    """
    kw = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0, "fontsize": 8, **kwargs}
    return ax.legend(**kw)


def plot_bivector(
    ax: Any,
    t: Any,
    B: Any,
    *,
    legend: bool = True,
    ls: str = "-",
    lw: float = 1.5,
    labels: bool = True,
    ylabel: str | None = None,
    **kwargs: Any,
) -> list[Any]:
    """Plot a bivector trajectory ``B`` (T, 7) in ``coop_ga.TANGENT_BASIS`` order
    ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` against time ``t`` (T,) [s], one colour per component.

    Units are the bivector's (rad | 1 | body length, or per second for velocities).
    ``legend`` adds a one-column legend with the mathtext labels, to the right of the axes
    (:func:`legend_outside`); ``labels=False`` leaves the lines unlabelled (e.g. a second,
    dashed trajectory on the same axes).  ``ylabel``: the y label, e.g.
    ``bivector_ylabel("command", rate=True)``; None leaves it as it is.  Extra keyword
    arguments go to every ``ax.plot``.  Returns the 7 lines.
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    B = np.asarray(B, dtype=float)
    if B.shape != (len(t), 7):
        raise ValueError(f"B must have shape (len(t), 7) = ({len(t)}, 7), got {B.shape}")
    lines = [
        ax.plot(
            t, B[:, j], color=BIVECTOR_COLORS[j], ls=ls, lw=lw, label=BIVECTOR_LABELS[j] if labels else None, **kwargs
        )[0]
        for j in range(7)
    ]
    if legend and labels:
        legend_outside(ax, handlelength=1.2)
    if ylabel is not None:
        ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    return lines


def plot_error(
    ax: Any,
    t: Any,
    err: Any,
    *,
    log: bool = True,
    floor: float | None = None,
    label: str | None = None,
    ylabel: str | None = r"error $\|e\|$",
    **kwargs: Any,
) -> Any:
    """Plot an error against time ``t`` (T,) [s]: ``err`` (T,) norms, or (T, n) vectors whose
    Euclidean norm per row is plotted.

    ``log`` uses a logarithmic y axis; there, values ≤ 0 would vanish, so they are raised to
    ``floor`` (default: 1e-3 × the smallest positive value).  ``ylabel`` labels the y axis when
    it has no label yet (None: leave it).  Extra keyword arguments (colour, line style, …) go to
    ``ax.plot``.  Returns the line.
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    e = np.asarray(err, dtype=float)
    if e.ndim == 2:
        e = np.linalg.norm(e, axis=1)
    if e.shape != t.shape:
        raise ValueError(f"err must have len(t) = {len(t)} rows, got shape {np.shape(err)}")
    if log:
        pos = e[e > 0]
        lo = floor if floor is not None else (1e-3 * float(pos.min()) if len(pos) else 1e-16)
        e = np.maximum(e, lo)
        ax.set_yscale("log")
    (line,) = ax.plot(t, e, label=label, **kwargs)
    if ylabel is not None and not ax.get_ylabel():
        ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    return line
