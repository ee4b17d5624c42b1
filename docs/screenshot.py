"""Write ``docs/assets/viewer.png``: the teleoperation page of the viewer in headless Chromium.

The capture is the viewer's browser test (``tests/viewer/test_browser.py``): serve a task on a free port,
load the page with :func:`coop_ga.viewer.browser.screenshot`, retake it until the primitive's colour shows.
Needs the ``viewer`` extra and Debian's ``chromium``.  Run from the repository root::

    python docs/screenshot.py            # or --system allegro --kind sphere --out /tmp/x.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the tests' colour check, and coop_ga from this checkout

import coop_ga as cg  # noqa: E402
from coop_ga.viewer import serve  # noqa: E402
from coop_ga.viewer.browser import screenshot  # noqa: E402
from coop_ga.viz import PALETTE  # noqa: E402
from tests.viewer.test_browser import colour_pixels  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--system", default="three_franka", help="a registered system (default: three_franka)")
    parser.add_argument("--kind", default="circle", help="the primitive kind (default: circle)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "assets" / "viewer.png", help="the PNG to write")
    parser.add_argument("--size", type=int, nargs=2, default=(1280, 800), help="window width height [px]")
    args = parser.parse_args(argv)
    viewer = serve(cg.cooperative_task(args.system, args.kind), port=0, block=False)
    try:
        png = screenshot(
            viewer.url,
            args.out,
            size=tuple(args.size),
            ready=lambda: viewer.clients_seen > 0,
            settle=4.0,
            accept=lambda p: colour_pixels(p, PALETTE.final_primitive) >= 150,
            timeout=240.0,
        )
    finally:
        viewer.stop()
    print(f"wrote {png} ({colour_pixels(png, PALETTE.final_primitive)} pixels of the primitive's colour)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
