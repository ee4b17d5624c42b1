"""A scripted viser client: what the browser sends when the gizmo is dragged, sent from Python."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

import coop_ga as cg
from coop_ga.viewer.session import matrix_to_quaternion, quaternion_to_matrix


def drag_gizmo(port: int, name: str, position, wxyz) -> None:
    """Connect to the viser server on 127.0.0.1:``port`` as a browser does (subprotocol ``viser-v<version>``) and
    send the ``TransformControlsUpdateMessage`` of a drag of the transform controls ``name`` to the pose."""
    import msgspec
    import viser
    from websockets.sync.client import connect

    msg = {
        "type": "TransformControlsUpdateMessage",
        "name": name,
        "wxyz": [float(x) for x in wxyz],
        "position": [float(x) for x in position],
        "owner": "",
    }
    with connect(f"ws://127.0.0.1:{port}", subprotocols=[f"viser-v{viser.__version__}"], open_timeout=30) as ws:
        ws.send(msgspec.msgpack.encode(msg))
        time.sleep(0.5)  # let the server handle it before the connection closes


def wait_for(condition: Callable[[], bool], timeout: float, what: str) -> None:
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.05)


def rx(deg: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of a rotation by ``deg`` about +x."""
    a = np.deg2rad(deg)
    return np.array([np.cos(a / 2), np.sin(a / 2), 0.0, 0.0])


def check_primitive_follows_the_gizmo(viewer) -> None:
    """Drag the gizmo (as a client) 4–5 cm away and tilt it 10°, set the scale slider to 1.1 (server API):
    the robots' circle converges to the gizmo's within 0.1 mm and 1 mrad, and the drawn circle with it."""
    s, task = viewer.session, viewer.session.task
    p0, w0, _ = s.handle_pose()
    r0 = cg.radius(task.primitive(s.q0))
    p = p0 + np.array([0.04, -0.03, 0.02])
    w = matrix_to_quaternion(quaternion_to_matrix(rx(10.0)) @ quaternion_to_matrix(w0))
    viewer.page.scale.value = 1.1
    drag_gizmo(viewer.port, "/gizmo", p, w)
    wait_for(lambda: np.allclose(s.target.translation, p, atol=1e-12), 30, "the gizmo pose to reach the session")
    wait_for(lambda: s.readout.error_norm < 1e-6, 120, "the robots to reach the target")
    X = task.primitive(s.q)
    n = quaternion_to_matrix(rx(10.0)) @ np.array([0.0, 0.0, 1.0])
    assert np.linalg.norm(np.asarray(cg.center(X)) - p) < 1e-4
    assert abs(cg.radius(X) - 1.1 * r0) < 1e-4
    assert np.arccos(np.clip(np.dot(cg.normal(X), n), -1.0, 1.0)) < 1e-3
    drawn = np.asarray(viewer.page.current._nodes["lines"].points, float).reshape(-1, 3)
    with viewer.lock:
        X = task.primitive(s.q)
    assert np.allclose(np.linalg.norm(drawn - cg.center(X), axis=1), cg.radius(X), atol=1e-5)  # float32 points
    assert np.allclose((drawn - cg.center(X)) @ np.asarray(cg.normal(X)), 0.0, atol=1e-5)
