"""Robots drawn from their visual meshes: geometry models of every system, both mesh renderers,
the renderer choice and its fallbacks."""

from __future__ import annotations

import importlib.util
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import viz
from coop_ga.errors import InvalidInputError
from coop_ga.viz import backends, mesh

HAS_PYVISTA = importlib.util.find_spec("pyvista") is not None
needs_pyvista = pytest.mark.skipif(not HAS_PYVISTA, reason="pyvista is not installed (pip install '.[viz]')")


@pytest.fixture(scope="module")
def franka():
    return cg.systems.load("three_franka")


def _scene(s, q0, q1):
    task = cg.cooperative_task(s, "circle")
    return (
        viz.Scene()
        .robot(s, q0, "initial", "initial")
        .robot(s, q1, "final", "final")
        .primitive(task.primitive(q0), "initial", "initial circle")
        .primitive(task.primitive(q1), "final", "final circle")
        .curve(np.array([s.end_points(q0 + a * (q1 - q0))[0] for a in np.linspace(0, 1, 5)]), label="path")
    )


def _urdf_visual_origins(path):
    """{link: [4×4 pose of each <visual> in the link frame]} read from the URDF text (not through Pinocchio)."""
    import pinocchio as pin

    out = {}
    for link in ET.parse(path).getroot().iter("link"):
        poses = []
        for v in link.findall("visual"):
            o = v.find("origin")
            xyz = np.array([float(x) for x in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()])
            rpy = np.array([float(x) for x in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()])
            T = np.eye(4)
            T[:3, :3] = pin.rpy.rpyToMatrix(*rpy)
            T[:3, 3] = xyz
            poses.append(T)
        out[link.get("name")] = poses
    return out


@pytest.mark.parametrize("name", cg.systems.names())
def test_every_system_has_visual_geometry_at_its_links(name):
    """Each visual object sits at (world pose of its link, FK) · (its <visual> origin in the URDF)."""
    import pinocchio as pin

    s = cg.systems.load(name)
    gm = s.visual_model()
    assert gm is not None and gm.ngeoms > 0 and s.visual_skipped == []
    d = s.model.createData()
    pin.framesForwardKinematics(s.model, d, s.q0)
    poses = viz.mesh.object_placements(s, s.q0)
    assert poses.shape == (gm.ngeoms, 4, 4)
    n_checked = 0
    for src in s.visuals:
        origins = _urdf_visual_origins(src.urdf)
        for link, Ts in origins.items():
            for k, T in enumerate(Ts):
                gid = gm.getGeometryId(f"{src.prefix}{link}_{k}")
                assert gid < gm.ngeoms, f"{src.prefix}{link}_{k} missing"
                oMf = d.oMf[s.model.getFrameId(src.prefix + link, pin.FrameType.BODY)].homogeneous
                np.testing.assert_allclose(poses[gid], oMf @ T, atol=1e-12)
                n_checked += 1
    assert n_checked == gm.ngeoms


def test_combined_model_matches_example_robot_data(franka):
    """three_franka (appended, prefixed, fingers locked): arm 1's meshes are where example-robot-data's
    own Panda (its visual model, Pinocchio placements) puts them, moved to arm 1's base."""
    import example_robot_data as erd
    import pinocchio as pin

    from coop_ga.systems.library import _ring_placements

    q = franka.q0 + np.random.default_rng(1).uniform(-0.3, 0.3, franka.nq)
    poses = viz.mesh.object_placements(franka, q)
    gm = franka.visual_model()
    r = erd.load("panda")
    qr = np.array(r.q0)
    qr[:7] = q[7:14]
    rd, rgd = r.model.createData(), r.visual_model.createData()
    pin.forwardKinematics(r.model, rd, qr)
    pin.updateGeometryPlacements(r.model, rd, r.visual_model, rgd)
    base = _ring_placements(3, 0.8)[1]
    for i, o in enumerate(r.visual_model.geometryObjects):
        np.testing.assert_allclose(
            poses[gm.getGeometryId("arm1_" + o.name)], (base * rgd.oMg[i]).homogeneous, atol=1e-12
        )


def test_meshes_are_cached_and_decimated(franka):
    m1 = viz.robot_mesh(franka, franka.q0)
    assert m1.n_faces > 100_000  # the Panda's .dae meshes, three arms
    o = franka.visual_model().geometryObjects[0]
    assert viz.object_mesh(o) is viz.object_mesh(o)  # loaded once per process
    m2 = viz.robot_mesh(franka, franka.q0, max_faces=10_000)
    assert 2_000 < m2.n_faces <= 11_000  # about the budget
    np.testing.assert_allclose(m2.vertices.min(axis=0), m1.vertices.min(axis=0), atol=0.03)
    np.testing.assert_allclose(m2.vertices.max(axis=0), m1.vertices.max(axis=0), atol=0.03)
    assert abs(m2.area() / m1.area() - 1.0) < 0.25
    assert np.allclose(np.linalg.norm(m2.normals, axis=1), 1.0)


def test_primitive_shapes_are_tessellated_to_size():
    import coal

    box = mesh._shape_mesh(coal.Box(0.1, 0.2, 0.3))
    assert box.area() == pytest.approx(2 * (0.02 + 0.06 + 0.03), rel=1e-12)
    cyl = mesh._shape_mesh(coal.Cylinder(0.05, 0.4))
    assert cyl.area() == pytest.approx(2 * np.pi * 0.05 * 0.4 + 2 * np.pi * 0.05**2, rel=5e-3)
    sph = mesh._shape_mesh(coal.Sphere(0.1))
    np.testing.assert_allclose(np.linalg.norm(sph.vertices, axis=1), 0.1, atol=1e-12)
    assert sph.area() == pytest.approx(4 * np.pi * 0.01, rel=0.02)
    d = viz.decimate(sph, 0.05)
    assert d.n_faces < sph.n_faces / 2 and np.all(np.linalg.norm(d.vertices, axis=1) < 0.1 + 1e-12)


def _check_robot_pixels(img, uv, far_uv):
    """img (H, W, 3) in [0, 1] on white: the FK points' pixels are drawn on, ``far_uv`` is background."""
    H, W = img.shape[:2]
    ink = img.min(axis=2) < 0.97  # not white
    assert 0.02 < ink.mean() < 0.7, ink.mean()
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < W) & (uv[:, 1] >= 0) & (uv[:, 1] < H)
    assert inside.all()
    hits = [ink[int(v), int(u)] for u, v in uv]
    assert np.mean(hits) >= 0.9, hits
    assert not ink[int(far_uv[1]), int(far_uv[0])]


def _far_pixel(uv_all, W, H):
    """The pixel of a grid farthest from every projected robot point."""
    gx, gy = np.meshgrid(np.linspace(5, W - 6, 40), np.linspace(5, H - 6, 32))
    g = np.column_stack([gx.ravel(), gy.ravel()])
    d = np.min(np.linalg.norm(g[:, None, :] - uv_all[None, ::50, :], axis=2), axis=1)
    best = g[np.argmax(d)]
    assert d.max() > 20
    return best


def _fk_points(s, q):
    sk = viz.skeleton(s, q)
    return np.vstack([sk.joints, sk.end_points])


@needs_pyvista
def test_vtk_renders_the_robot_where_fk_puts_it(franka, tmp_path):
    ok, why = viz.vtk_status()
    assert ok, f"pyvista is installed but VTK cannot render offscreen here: {why}"
    q0 = np.array(franka.q0)
    scene = viz.Scene().robot(franka, q0, "final")
    W, H = 420, 340
    img, cam = backends.vtk_image(scene, view=(35.0, -70.0), width=W, height=H, dpi=100)
    assert img.shape == (H, W, 3) and img.dtype == np.uint8
    uv, depth = cam.project(_fk_points(franka, q0))
    assert np.all(depth > 0)
    uv_mesh, _ = cam.project(viz.robot_mesh(franka, q0).vertices)
    _check_robot_pixels(img / 255.0, uv, _far_pixel(uv_mesh, W, H))
    # the whole figure: fixed size in pixels, not blank
    q1 = np.clip(q0 + 0.15, franka.q_lower, franka.q_upper)
    out = viz.render_scene(_scene(franka, q0, q1), tmp_path / "v.png", backend="vtk", size=(4, 3), dpi=80, title="t")
    import matplotlib.image as mpimg

    png = mpimg.imread(out)
    assert png.shape[:2] == (240, 320)
    assert 0.02 < (png[..., :3].min(axis=2) < 0.97).mean() < 0.7


def test_matplotlib_meshes_render_the_robot_where_fk_puts_it(franka, tmp_path):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d import proj3d

    q0 = np.array(franka.q0)
    scene = viz.Scene().robot(franka, q0, "final")
    fig = Figure(figsize=(4.2, 3.4), dpi=100)
    FigureCanvasAgg(fig)
    ax = backends.mpl_axes(scene, fig, view=(35.0, -70.0), pad=0.05)
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[..., :3] / 255.0
    H, W = img.shape[:2]

    def project(P):
        x, y, _ = proj3d.proj_transform(P[:, 0], P[:, 1], P[:, 2], ax.get_proj())
        u, v = ax.transData.transform(np.column_stack([x, y])).T
        return np.column_stack([u, H - v])

    uv_mesh = project(viz.robot_mesh(franka, q0, max_faces=backends.MPL_MAX_FACES).vertices)
    _check_robot_pixels(img, project(_fk_points(franka, q0)), _far_pixel(uv_mesh, W, H))
    q1 = np.clip(q0 + 0.15, franka.q_lower, franka.q_upper)
    out = viz.render_scene(_scene(franka, q0, q1), tmp_path / "m.png", backend="matplotlib", size=(4, 3), dpi=80)
    import matplotlib.image as mpimg

    png = mpimg.imread(out)
    assert png.shape[:2] == (240, 320)
    assert 0.02 < (png[..., :3].min(axis=2) < 0.97).mean() < 0.7


@pytest.fixture
def fresh_renderer(monkeypatch):
    """Forget the probed renderer and the notices given, for this test only."""
    monkeypatch.setattr(backends, "_STATUS", None)
    monkeypatch.setattr(mesh, "_NOTICED", set())
    monkeypatch.delenv(backends.ENV_RENDERER, raising=False)


def test_auto_falls_back_to_matplotlib_meshes_with_one_notice(fresh_renderer, monkeypatch, tmp_path):
    monkeypatch.setattr(backends, "_STATUS", (False, "no offscreen OpenGL context (test)"))
    with pytest.warns(viz.RenderWarning, match=r"mesh renderer \(VTK\) unavailable: no offscreen OpenGL context"):
        assert backends.resolve_backend("auto") == "matplotlib"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert backends.resolve_backend("auto") == "matplotlib"  # once per process
    with pytest.raises(viz.RendererUnavailableError, match="test"):
        backends.resolve_backend("vtk")
    assert backends.resolve_backend("skeleton") == "skeleton"


def test_environment_variable_replaces_auto(fresh_renderer, monkeypatch):
    monkeypatch.setenv(backends.ENV_RENDERER, "skeleton")
    assert backends.resolve_backend("auto") == "skeleton"
    assert backends.resolve_backend("matplotlib") == "matplotlib"  # an explicit choice wins
    monkeypatch.setenv(backends.ENV_RENDERER, "povray")
    with pytest.raises(InvalidInputError, match="COOP_GA_RENDERER"):
        backends.resolve_backend("auto")
    with pytest.raises(InvalidInputError, match="backend must be one of"):
        backends.resolve_backend("opengl")


def test_user_systems_get_meshes_or_a_skeleton_with_a_notice(fresh_renderer, tmp_path):
    import pinocchio as pin

    urdf = cg.systems.ROBOTS_DIR / "iiwa14" / "iiwa14.urdf"
    from_urdf = cg.systems.from_urdf(urdf, ["iiwa_flange"], name="my_iiwa")
    assert from_urdf.visual_model().ngeoms == 13
    model = pin.buildModelFromUrdf(str(urdf))
    geom = pin.buildGeomFromUrdf(model, str(urdf), pin.GeometryType.VISUAL)
    locked = cg.systems.from_model(
        model, ["iiwa_flange"], locked_joints=["iiwa_joint_7"], visual_model=geom, name="locked"
    )
    assert locked.nq == 6 and locked.visual_model().ngeoms == 13
    np.testing.assert_allclose(
        viz.robot_mesh(locked, locked.q0).vertices.mean(axis=0),
        viz.robot_mesh(from_urdf, np.append(locked.q0, 0.0)).vertices.mean(axis=0),
        atol=1e-12,
    )
    bare = cg.systems.from_model(model, ["iiwa_flange"], name="bare")
    assert bare.visual_model() is None
    with pytest.warns(
        viz.RenderWarning,
        match=r"'bare' has no visual geometry \(built without visual_model=.*\): drawing its skeleton",
    ):
        out = viz.render(bare, bare.q0, (), tmp_path / "bare.png", backend="matplotlib", size=(3, 3), dpi=60)
    assert out.exists()
    with pytest.raises(InvalidInputError, match="exactly one of"):
        cg.systems.system.VisualSource()


@needs_pyvista
def test_headless_vtk_render_prints_nothing(tmp_path):
    """Without a display VTK is never asked for an X window: no "bad X server connection" (or any
    other VTK warning) on stderr, and the render window is EGL or OSMesa."""
    import os
    import subprocess
    import sys

    code = (
        "import coop_ga as cg; from coop_ga import viz; s = cg.systems.load('three_iiwa14');"
        f"viz.render(s, s.q0, (), {str(tmp_path / 'h.png')!r}, backend='vtk', size=(2, 2), dpi=50);"
        "import os; print(os.environ['VTK_DEFAULT_OPENGL_WINDOW'])"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "VTK_DEFAULT_OPENGL_WINDOW")}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == [r.stdout.split()[-1]] and r.stdout.split()[-1] in backends._WINDOWS_HEADLESS
    assert r.stderr.strip() == "", r.stderr
    assert (tmp_path / "h.png").stat().st_size > 1000
