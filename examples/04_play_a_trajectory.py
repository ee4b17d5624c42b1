"""Play a trajectory: an offscreen GIF with ``coop_ga.viz.animate``, and the browser viewer's playback.

Three KUKA iiwa 14 (``three_iiwa14``) move their cooperative circle 5 cm sideways and 3 cm up with
differential IK (Eq 48, 61).  The (T, 21) trajectory is saved the way every experiment saves one
(``trajectory.npz`` with ``q``, ``t`` and the ``target`` similarity's 12 coefficients, and a
``metrics.json`` naming the system and the primitive kind), rendered to ``reach.gif`` frame by frame
without a display, and — when viser is installed (``pip install 'coop_ga[viewer]'``) — loaded by the
viewer's playback page (``coop_ga.viewer.play_file``, the same as ``python -m coop_ga.viewer --play
DIR/trajectory.npz``), with ``block=False`` so that the script keeps control: ``--serve SECONDS`` keeps the
page up that long (open the printed URL), the default stops it at once.

Writes ``trajectory.npz``, ``metrics.json`` and ``reach.gif``.

Run::

    python examples/04_play_a_trajectory.py --out /tmp/ex04 --serve 60
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import coop_ga as cg
import coop_ga.viewer

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("trajectory.npz", "metrics.json", "reach.gif")


def main(argv: list[str] | None = None) -> int:
    """Reach, save, animate, (play); returns 0."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "04")
    ap.add_argument("--frames", type=int, default=12, help="frames of the GIF (default 12)")
    ap.add_argument("--fast", action="store_true", help="3 stick-figure frames instead of meshes")
    ap.add_argument("--serve", type=float, default=0.0, help="seconds to keep the viewer's page up (needs viser)")
    ap.add_argument("--port", type=int, default=0, help="viewer port (0: a free one)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    task = cg.cooperative_task("three_iiwa14", "circle")
    q0 = task.system.q0
    target = cg.control.displaced_target(task, q0, translation=(0.05, 0.0, 0.03))
    options = cg.control.DiffIKOptions()  # Δt 0.01 s, gain 10/s
    run = cg.control.diff_ik_reach(task, q0, target, options)
    t = options.dt * np.arange(len(run.trajectory))  # [s]
    print(f"differential IK: converged={run.converged}, ‖e‖ {run.error:.1e}, trajectory {run.trajectory.shape}")

    npz = args.out / "trajectory.npz"
    np.savez(npz, q=run.trajectory, t=t, target=target.coeffs)
    (args.out / "metrics.json").write_text(json.dumps({"system": task.system.name, "kind": task.kind}, indent=2))

    start = time.process_time()
    gif = cg.viz.animate(
        task.system,
        run.trajectory,
        task.primitive,
        args.out / "reach.gif",
        t=t,
        frames=3 if args.fast else args.frames,
        target=target.apply(task.unit),
        backend="skeleton" if args.fast else "auto",
        size=(4.0, 3.0),
        dpi=80,
    )
    print(f"animation: {gif.name}, {gif.stat().st_size / 1e3:.0f} kB, {time.process_time() - start:.1f} s of CPU")

    if importlib.util.find_spec("viser") is None:
        print("viser is not installed: skipping the browser playback (pip install 'coop_ga[viewer]')")
        return 0 if run.converged else 1
    viewer = coop_ga.viewer.play_file(npz, port=args.port, block=False)  # system and kind from metrics.json
    try:
        rec = viewer.recording
        assert rec is not None
        print(f"viewer: {viewer.url} plays {rec.key} of {rec.system.name}, {len(rec.q)} frames over {rec.t[-1]:.2f} s")
        time.sleep(max(args.serve, 0.0))
    finally:
        viewer.stop()
    return 0 if run.converged else 1


if __name__ == "__main__":
    sys.exit(main())
