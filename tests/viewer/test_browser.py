"""The viewer in a real browser: headless Chromium loads the page, the primitive shows, the robots follow the gizmo.

Skipped only when Chromium is missing *and* ``COOP_GA_REQUIRE_BROWSER`` is unset; CI installs Debian's
``chromium`` and sets the variable, so there the test cannot silently skip.
"""

from __future__ import annotations

import colorsys
import os

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.viewer.browser import chromium_path
from coop_ga.viz import PALETTE

from .client import check_primitive_follows_the_gizmo

REQUIRED = bool(os.environ.get("COOP_GA_REQUIRE_BROWSER"))


def _need(what: str, ok: bool) -> None:
    if ok:
        return
    if REQUIRED:
        pytest.fail(f"COOP_GA_REQUIRE_BROWSER is set but {what}")
    pytest.skip(
        f"{what} and COOP_GA_REQUIRE_BROWSER is unset (apt-get install chromium; pip install 'coop_ga[viewer]')"
    )


def colour_pixels(png, color, *, hue_tol: float = 6.0) -> int:
    """Pixels of the colour's hue (±``hue_tol`` degrees), saturated and bright: three.js's tone mapping and
    antialiasing change a line's RGB values, not its hue."""
    from matplotlib.colors import to_rgb
    from PIL import Image

    h0 = colorsys.rgb_to_hsv(*to_rgb(color))[0] * 360.0
    rgb = np.asarray(Image.open(png).convert("RGB"), float) / 255.0
    mx, mn = rgb.max(axis=2), rgb.min(axis=2)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    d = np.where(mx > mn, mx - mn, 1.0)
    h = np.select([mx == r, mx == g], [(g - b) / d % 6.0, (b - r) / d + 2.0], (r - g) / d + 4.0) * 60.0
    dh = np.abs((h - h0 + 180.0) % 360.0 - 180.0)
    return int(np.sum((dh < hue_tol) & ((mx - mn) / np.maximum(mx, 1e-9) > 0.3) & (mx > 0.5)))


def test_colour_pixels_counts_the_hue(tmp_path):
    from PIL import Image

    img = np.full((10, 10, 3), 255, np.uint8)
    img[2:4, 2:8] = (136, 216, 208)  # the turquoise as three.js shows it
    img[6, :] = (120, 216, 155)  # the green start primitive
    Image.fromarray(img).save(tmp_path / "x.png")
    assert colour_pixels(tmp_path / "x.png", PALETTE.final_primitive) == 12


def test_viewer_in_headless_chromium(tmp_path):
    _need("no chromium is on the PATH", chromium_path() is not None)
    try:
        import viser  # noqa: F401
    except ImportError:
        _need("viser is not installed", False)
    from coop_ga.viewer import serve
    from coop_ga.viewer.browser import screenshot

    viewer = serve(cg.cooperative_task("three_iiwa14", "circle"), port=0, block=False)
    try:
        png = screenshot(
            viewer.url,
            tmp_path / "viewer.png",
            size=(1000, 700),
            ready=lambda: viewer.clients_seen > 0,
            settle=3.0,
            accept=lambda p: colour_pixels(p, PALETTE.final_primitive) >= 150,
            timeout=240.0,
        )
        assert viewer.clients_seen >= 1
        assert colour_pixels(png, PALETTE.final_primitive) >= 150  # the turquoise circle (a 5 px line) is drawn
        check_primitive_follows_the_gizmo(viewer)
    finally:
        viewer.stop()
