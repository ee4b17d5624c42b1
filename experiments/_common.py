"""Small helpers shared by experiment scripts: output directory, JSON, progress, drawing.

Import from a script in this directory with ``from _common import ...`` (the scripts put
their own directory on ``sys.path``).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any, Iterable, Iterator, Sequence

import numpy as np

#: Mathtext labels of the 7 similarity-bivector components (TANGENT_BASIS order).
BIVECTOR_LABELS = (r"$e_{12}$", r"$e_{13}$", r"$e_{23}$", r"$e_{0\infty}$", r"$e_{1\infty}$", r"$e_{2\infty}$",
                   r"$e_{3\infty}$")


def out_dir(path: str | Path) -> Path:
    """Create (if needed) and return the output directory."""
    p = Path(path)
    p.mkdir(parents=True, exist_ok=True)
    return p


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.bool_, bool)):
        return bool(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if np.isfinite(v) else str(v)  # JSON has no NaN/inf
    return x


def write_json(path: str | Path, obj: Any) -> Path:
    """Write ``obj`` (numpy scalars/arrays allowed) as indented JSON."""
    p = Path(path)
    p.write_text(json.dumps(_jsonable(obj), indent=2) + "\n")
    return p


class Stage:
    """``with Stage("compiling task"):`` prints ``[label] … done (1.23 s)`` to stderr."""

    def __init__(self, label: str, quiet: bool = False):
        self.label, self.quiet = label, quiet

    def __enter__(self) -> "Stage":
        self.t0 = time.perf_counter()
        if not self.quiet:
            print(f"[{self.label}] ...", end="", flush=True, file=sys.stderr)
        return self

    def __exit__(self, *exc: Any) -> None:
        self.seconds = time.perf_counter() - self.t0
        if not self.quiet:
            print(f" done ({self.seconds:.2f} s)", flush=True, file=sys.stderr)


def progress(items: Sequence[Any] | Iterable[Any], label: str, total: int | None = None, width: int = 30,
             quiet: bool = False) -> Iterator[Any]:
    """A dependency-free text progress bar on stderr: ``label [#####.....] 12/40``.

    Redrawn in place on a terminal (only when it changes); when stderr is not a terminal
    (logs, CI) a single line is printed at the end.
    """
    total = len(items) if total is None and hasattr(items, "__len__") else total  # type: ignore[arg-type]
    tty = sys.stderr.isatty()
    last = -1
    t0 = time.perf_counter()
    i = 0
    for i, x in enumerate(items, 1):
        yield x
        if not quiet and total and tty:
            k = int(width * i / total)
            if k != last or i == total:
                last = k
                print(f"\r{label} [{'#' * k}{'.' * (width - k)}] {i}/{total}", end="", file=sys.stderr, flush=True)
    if not quiet and total:
        end = f" ({time.perf_counter() - t0:.2f} s)"
        print(("" if tty else f"{label}: {i}/{total}") + end, file=sys.stderr, flush=True)


def chain_skeletons(system: Any, q: Any, ground: bool = True) -> list[np.ndarray]:
    """Polylines (one (m_i, 3) array per end frame) through the joint origins of each chain
    (Pinocchio ``oMi``), root to tip, ending at the end frame (``oMf``) — world frame [m].

    With ``ground=True`` a chain whose first joint hangs directly off the world and lies
    above z = 0 starts at the point below it on the floor (a pedestal, for fixed-base arms).
    """
    import pinocchio as pin

    model = system.model
    data = model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, float))
    pin.updateFramePlacements(model, data)
    out = []
    for fname in system.end_frames:
        fid = model.getFrameId(fname)
        chain = []
        j = int(model.frames[fid].parentJoint)
        while j > 0:
            chain.append(j)
            j = int(model.parents[j])
        pts = [np.array(data.oMi[j].translation) for j in reversed(chain)]
        pts.append(np.array(data.oMf[fid].translation))
        if ground and chain and int(model.parents[chain[-1]]) == 0 and pts[0][2] > 0:
            pts.insert(0, np.array([pts[0][0], pts[0][1], 0.0]))
        out.append(np.array(pts))
    return out


def circle_points(center: Any, radius: float, normal: Any, m: int = 120) -> np.ndarray:
    """(m+1, 3) points of the circle with the given center [m], radius [m] and unit normal."""
    c = np.asarray(center, float).reshape(3)
    n = np.asarray(normal, float).reshape(3)
    n = n / np.linalg.norm(n)
    a = np.cross(n, [1.0, 0.0, 0.0])
    if np.linalg.norm(a) < 0.1:
        a = np.cross(n, [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    t = np.linspace(0.0, 2.0 * np.pi, m + 1)
    return c + float(radius) * (np.outer(np.cos(t), a) + np.outer(np.sin(t), b))


def set_equal_3d(ax: Any, pts: np.ndarray, pad: float = 0.05) -> None:
    """Equal aspect ratio for a matplotlib 3D axis around the given (N, 3) points (lowest point at the bottom)."""
    lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad
    c, r = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo))
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(lo[2], lo[2] + 2 * r)  # floor at the bottom
    try:
        ax.set_box_aspect((1, 1, 1))
    except AttributeError:  # old matplotlib
        pass
