"""Teleoperate a cooperative task in the browser: drag the primitive, the robots follow.

``coop_ga.viewer.serve(task)`` opens a viser page with the robots (from their meshes), the cooperative
circle of three Franka arms, a transform gizmo at its centre and a scale slider: the gizmo pose and the
slider set the target similarity V_Sd, and a control thread steps the limit-aware differential IK at
60 Hz towards it (the paper's teleoperation mapping, Eq 44, 48, 61, Figs. 20–21).  The page shows ‖e‖,
the well-definedness, the manipulability per bivector direction, active limits and warnings.

By default the page stays up until Ctrl+C (open the printed URL).  With ``--steps N`` (or ``--fast``:
60 steps) the script moves the target itself — the same call the gizmo's callback makes,
``viewer.session.set_target_pose(position, wxyz, scale)``: 4 cm up and 10 % larger — lets the control
thread run N steps, prints the read-outs and stops: a headless run, no browser needed.  Without viser it
steps the same :class:`coop_ga.viewer.TeleopSession` directly.

Writes ``readout.json`` (the last read-outs).

Run::

    python examples/05_teleoperate_in_the_viewer.py              # interactive, http://127.0.0.1:8080
    python examples/05_teleoperate_in_the_viewer.py --steps 120  # scripted and headless
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
OUTPUTS = ("readout.json",)


def scripted_move(session: coop_ga.viewer.TeleopSession) -> float:
    """Move the target 4 cm up and scale it by 1.1, as a drag of the gizmo and the slider would; returns ‖e‖ before."""
    p, wxyz, s = session.handle_pose()  # where the gizmo is drawn: position [m], quaternion (w, x, y, z), scale
    ok = session.set_target_pose(p + np.array([0.0, 0.0, 0.04]), wxyz, 1.1 * s)
    assert ok, session.readout.error_message
    return float(np.linalg.norm(session.task.error(session.q, session.target)))


def _headless(task: cg.CooperativeTask, steps: int) -> coop_ga.viewer.Readout:
    """The viewer's control logic without a server (no viser needed)."""
    session = coop_ga.viewer.TeleopSession(task)
    e0 = scripted_move(session)
    for _ in range(steps):
        session.step()
    print(f"headless session: ‖e‖ {e0:.3f} → {session.readout.error_norm:.2e} in {steps} steps")
    return session.readout


def _served(task: cg.CooperativeTask, steps: int, port: int, timeout: float) -> coop_ga.viewer.Readout:
    viewer = coop_ga.viewer.serve(task, port=port, block=False)
    try:
        session = viewer.session
        assert session is not None
        print(f"viewer: {viewer.url}")
        with viewer.lock:  # the control thread steps the session under this lock
            e0 = scripted_move(session)
            f0 = viewer.frames
        deadline = time.monotonic() + timeout
        while viewer.frames - f0 < steps and time.monotonic() < deadline:
            time.sleep(0.05)
        with viewer.lock:
            readout = session.readout
            n = viewer.frames - f0
        print(f"served session: ‖e‖ {e0:.3f} → {readout.error_norm:.2e} in {n} control steps at {readout.rate:.0f} Hz")
        return readout
    finally:
        viewer.stop()


def main(argv: list[str] | None = None) -> int:
    """Serve until Ctrl+C, or run a scripted teleoperation of --steps steps; returns 0."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "05")
    ap.add_argument("--system", default="three_franka", help="a registered system (default three_franka)")
    ap.add_argument("--kind", default="circle", help="primitive kind (default circle)")
    ap.add_argument("--port", type=int, default=8080, help="viewer port (0: a free one)")
    ap.add_argument("--steps", type=int, default=0, help="scripted run of N control steps, then stop (0: interactive)")
    ap.add_argument("--fast", action="store_true", help="the same as --steps 60 --port 0")
    ap.add_argument("--timeout", type=float, default=30.0, help="wall-time limit of a scripted run [s]")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.fast:
        args.steps, args.port = args.steps or 60, 0

    task = cg.cooperative_task(args.system, args.kind)
    has_viser = importlib.util.find_spec("viser") is not None
    if args.steps <= 0:
        if not has_viser:
            print("the interactive viewer needs viser: pip install 'coop_ga[viewer]'")
            return 1
        coop_ga.viewer.serve(task, port=args.port)  # blocks until Ctrl+C
        return 0
    readout = _served(task, args.steps, args.port, args.timeout) if has_viser else _headless(task, args.steps)
    summary = {
        "error_norm": readout.error_norm,
        "well_definedness": readout.well_definedness,
        "manipulability": readout.manipulability.tolist(),
        "active_limits": list(readout.active_limits()),
        "message": readout.error_message,
    }
    (args.out / "readout.json").write_text(json.dumps(summary, indent=2))
    print(
        f"well-definedness {readout.well_definedness:.3f}, manipulability per bivector row "
        f"{np.round(readout.manipulability, 2)}, active limits {list(readout.active_limits()) or 'none'}"
    )
    return 0 if readout.error_norm < 1e-2 and not readout.error_message else 1


if __name__ == "__main__":
    sys.exit(main())
