"""``python -m coop_ga.viewer``: teleoperate a system's cooperative primitive, or play a trajectory file.

    python -m coop_ga.viewer three_franka circle            # gizmo + scale slider, robots follow (IK)
    python -m coop_ga.viewer allegro sphere --port 8081
    python -m coop_ga.viewer --play results/reaching/trajectory.npz
    python -m coop_ga.viewer --play results/nullspace_secondary/trajectories.npz --key direct_trajectory
    python -m coop_ga.viewer --play runs/box_carry                # a coop_ga.sim run folder (model.xml, log.npz)

Open the printed address in a browser (over SSH: ``ssh -L 8080:localhost:8080 host``).  Ctrl+C stops.
"""

from __future__ import annotations

import argparse
import sys

from ..errors import CoopGAError


def _parser() -> argparse.ArgumentParser:
    from .. import systems
    from ..geometry import KINDS

    p = argparse.ArgumentParser(
        prog="python -m coop_ga.viewer",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=f"systems: {', '.join(systems.names())}; kinds: {', '.join(KINDS)}",
    )
    p.add_argument("system", nargs="?", help="registered system to teleoperate (or to play a file on, with --play)")
    p.add_argument("kind", nargs="?", help="cooperative primitive kind (with --play: overrides metrics.json; 'none')")
    p.add_argument("--play", metavar="PATH", help="an experiment's .npz or a coop_ga.sim run folder / log.npz")
    p.add_argument("--key", help="with --play: the trajectory array of the file (default q, else the first)")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (0.0.0.0: every interface)")
    p.add_argument("--port", type=int, default=8080, help="port (0: a free one)")
    p.add_argument("--rate", type=float, default=60.0, help="control steps per second (Δt = 1/rate)")
    p.add_argument("--servo-gain", type=float, default=5.0, help="b = gain · e until a device axis saturates [1/s]")
    p.add_argument("--rz-mode", choices=("dilation", "rotation"), help="sixth device axis (default: by kind)")
    p.add_argument("--max-faces", type=int, default=150_000, help="triangles per robot sent to the browser")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    from . import play_file, serve

    try:
        if args.play:
            play_file(
                args.play,
                key=args.key,
                system=args.system,
                kind=args.kind,
                host=args.host,
                port=args.port,
                max_faces=args.max_faces,
            )
            return 0
        if not args.system or not args.kind:
            _parser().error("give SYSTEM KIND to teleoperate, or --play PATH")
        from ..cooperative import cooperative_task

        task = cooperative_task(args.system, args.kind)
        serve(
            task,
            host=args.host,
            port=args.port,
            rate=args.rate,
            max_faces=args.max_faces,
            servo_gain=args.servo_gain,
            rz_mode=args.rz_mode,
        )
    except CoopGAError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
