"""Screenshots of a viewer page in headless Chromium (the browser test, the docs' pictures).

:func:`screenshot` starts ``chromium --headless`` (Debian's ``chromium`` package; ``$COOP_GA_CHROMIUM``
or ``chromium`` / ``chromium-browser`` / ``google-chrome`` on the PATH) on the page with the DevTools
protocol on a local port, waits until ``ready()`` says the page is up (e.g. the viewer saw the
client), lets it render for ``settle`` seconds and captures the window (``Page.captureScreenshot``),
with nothing but the standard library and ``websockets`` (a dependency of viser).  No GPU is needed:
WebGL runs on SwiftShader (``--enable-unsafe-swiftshader``), slowly but correctly.

Chromium's own ``--screenshot`` flag waits for the page to become idle under ``--virtual-time-budget``,
which a live page that streams 60 scene updates a second never is; hence the protocol.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
import tempfile
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import CoopGAError

__all__ = ["BROWSER_FLAGS", "ENV_CHROMIUM", "chromium_path", "screenshot"]

#: environment variable naming the Chromium executable
ENV_CHROMIUM = "COOP_GA_CHROMIUM"

#: flags of a quiet, self-contained headless Chromium (no sandbox: it runs as root in CI containers)
BROWSER_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
    "--hide-scrollbars",
    "--mute-audio",
)


def chromium_path() -> str | None:
    """The Chromium executable (``$COOP_GA_CHROMIUM``, else the first of chromium, chromium-browser,
    google-chrome on the PATH), or None."""
    env = os.environ.get(ENV_CHROMIUM)
    if env:
        return env if Path(env).is_file() else shutil.which(env)
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


def _devtools_port(profile: Path, proc: subprocess.Popen, timeout: float) -> int:
    """The DevTools port Chromium chose (``--remote-debugging-port=0`` writes it to DevToolsActivePort)."""
    f = profile / "DevToolsActivePort"
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if proc.poll() is not None:
            raise CoopGAError(f"chromium exited with code {proc.returncode} before opening its DevTools port")
        if f.is_file():
            text = f.read_text().split()
            if text:
                return int(text[0])
        time.sleep(0.1)
    raise CoopGAError(f"chromium opened no DevTools port within {timeout:.0f} s")


def _page_socket(port: int, timeout: float) -> str:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=5) as r:
            pages = [t for t in json.load(r) if t.get("type") == "page"]
        if pages:
            return str(pages[0]["webSocketDebuggerUrl"])
        time.sleep(0.2)
    raise CoopGAError("chromium shows no page")


class _DevTools:
    """A minimal DevTools protocol client (one page)."""

    def __init__(self, url: str):
        from websockets.sync.client import connect

        self.ws = connect(url, max_size=64 * 2**20, open_timeout=30)
        self.n = 0

    def call(self, method: str, timeout: float = 60.0, **params: Any) -> dict[str, Any]:
        self.n += 1
        self.ws.send(json.dumps({"id": self.n, "method": method, "params": params}))
        end = time.monotonic() + timeout
        while True:
            msg = json.loads(self.ws.recv(timeout=max(end - time.monotonic(), 0.01)))
            if msg.get("id") == self.n:
                if "error" in msg:
                    raise CoopGAError(f"DevTools {method}: {msg['error']}")
                return dict(msg.get("result", {}))

    def close(self) -> None:
        self.ws.close()


def screenshot(
    url: str,
    path: str | Path,
    *,
    size: tuple[int, int] = (1280, 800),
    ready: Callable[[], bool] | None = None,
    settle: float = 3.0,
    timeout: float = 120.0,
    accept: Callable[[Path], bool] | None = None,
) -> Path:
    """Load ``url`` in headless Chromium and write a PNG of the window to ``path`` (module docstring).

    Args:
        url: the page (e.g. :attr:`coop_ga.viewer.Viewer.url`).
        path: the PNG to write (parents created).
        size: window width × height [px].
        ready: polled until True before the settle time starts (e.g. ``lambda: viewer.clients_seen > 0``).
        settle: seconds to let the page render after ``ready``.
        timeout: seconds for the whole capture.
        accept: if given, screenshots are retaken (every ``settle`` s, until ``timeout``) until it returns
            True for the written file (a slow software renderer may need several seconds for the first frame).

    Returns:
        The path written.

    Raises:
        CoopGAError: no Chromium, or it failed (the message says which step); ``accept`` never satisfied.
    """
    exe = chromium_path()
    if exe is None:
        raise CoopGAError(f"no chromium on the PATH (apt-get install chromium, or set ${ENV_CHROMIUM})")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    end = time.monotonic() + timeout
    with tempfile.TemporaryDirectory(prefix="coop_ga_chromium_") as tmp:
        profile = Path(tmp)
        cmd = [exe, *BROWSER_FLAGS, f"--user-data-dir={profile}", "--remote-debugging-port=0"]
        cmd += [f"--window-size={int(size[0])},{int(size[1])}", url]
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            dt = _DevTools(_page_socket(_devtools_port(profile, proc, 30.0), 30.0))
            try:
                while ready is not None and not ready():
                    if time.monotonic() > end:
                        raise CoopGAError(f"the page {url} did not become ready within {timeout:.0f} s")
                    time.sleep(0.1)
                while True:
                    time.sleep(settle)
                    png = dt.call("Page.captureScreenshot", format="png")["data"]
                    out.write_bytes(base64.b64decode(png))
                    if accept is None or accept(out):
                        return out
                    if time.monotonic() > end:
                        raise CoopGAError(f"the screenshot of {url} never passed the check within {timeout:.0f} s")
            finally:
                dt.close()
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
