"""One 3D figure per registered system: link skeleton at q0 and the primitive through its end points.

    python paper_figures/systems.py [--out paper_figures/systems] [--only NAME ...]

For every system (``coop_ga.systems.names()``) this draws, at the system's ``q0``:

* the actuated skeleton: joint origins (Pinocchio ``data.oMi``) connected parent → child,
  each root joint connected to the body it hangs from, and every end frame connected to
  its joint (end points as red markers, labelled);
* locked/fixed structure (e.g. a G1's locked legs, the Panda's link0) as grey dots;
* the primitive through the end points: 2 points → the segment, 3 → the circle (sampled
  from ``coop_ga.center/radius/normal``), 4 → a sphere wireframe (skipped with a note
  when the points are coplanar), more → the circles through consecutive triples (and the
  sphere of the first four if it is well defined).

Output: ``<out>/<name>.png`` (headless, matplotlib Agg), equal axis scales.
"""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

#: camera (elevation, azimuth) per system; default (22, −60)
VIEWS = {
    "three_franka": (35, -70),
    "three_iiwa14": (35, -70),
    "g1_arms": (15, -35),
    "g1_torso_arms": (15, -35),
    "franka_and_g1": (35, -120),
    "two_g1": (15, -70),
    "three_finger_hand": (50, -25),
    "allegro": (20, -20),
    "hexapod": (40, -60),
}


def skeleton(system, q):
    """(segments, fixed points) of the model at q: segments as (a, b, kind) with kind 'joint'/'end'/'fixed'."""
    import pinocchio as pin

    m = system.model
    d = m.createData()
    pin.forwardKinematics(m, d, q)
    pin.updateFramePlacements(m, d)
    segs = []
    for j in range(1, m.njoints):
        b = d.oMi[j].translation
        p = m.parents[j]
        if p > 0:
            a = d.oMi[p].translation
        else:  # root joint: start at the body it hangs from (the JOINT frame's parent frame)
            fid = m.getFrameId(m.names[j], pin.FrameType.JOINT)
            a = d.oMf[m.frames[fid].parentFrame].translation if fid < len(m.frames) else b
        segs.append((a, b, "joint"))
    for f in system.end_frames:
        fid = m.getFrameId(f)
        segs.append((d.oMi[m.frames[fid].parentJoint].translation, d.oMf[fid].translation, "end"))
    fixed, seen = [], set()
    for i, f in enumerate(m.frames):
        if f.parentJoint != 0 or f.type != pin.FrameType.BODY or i == 0:
            continue
        fixed.append(d.oMf[i].translation.copy())
        pf = m.frames[f.parentFrame]  # FIXED_JOINT frame → its parent body (skip self-references)
        if pf.parentFrame not in (f.parentFrame, 0) and (i, pf.parentFrame) not in seen:
            seen.add((i, pf.parentFrame))
            segs.append((d.oMf[pf.parentFrame].translation, d.oMf[i].translation, "fixed"))
    return segs, np.array(fixed).reshape(-1, 3)


def circle_samples(X, n: int = 200) -> np.ndarray:
    import coop_ga as cg

    c = np.asarray(cg.center(X), float)
    r = float(cg.radius(X))
    nrm = np.asarray(cg.normal(X), float)
    nrm = nrm / np.linalg.norm(nrm)
    u = np.cross(nrm, [1.0, 0.0, 0.0] if abs(nrm[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(nrm, u)
    t = np.linspace(0.0, 2 * np.pi, n)
    return c + r * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))


def draw_primitive(ax, P: np.ndarray) -> tuple[list[np.ndarray], str]:
    """Draw the primitive through the points; returns (drawn points for the limits, caption)."""
    import coop_ga as cg

    k = len(P)
    drawn: list[np.ndarray] = []
    notes = []

    def circle(idx, color):
        pts = P[list(idx)]
        w = float(cg.well_definedness("circle", pts))
        if w < 1e-6:
            notes.append(f"circle {idx} collinear: skipped")
            return
        X = cg.circle(*pts)
        S = circle_samples(X)
        ax.plot(S[:, 0], S[:, 1], S[:, 2], color=color, lw=1.6)
        c, nrm = np.asarray(cg.center(X), float), np.asarray(cg.normal(X), float)
        r = float(cg.radius(X))
        ax.quiver(*c, *(0.5 * r * nrm / np.linalg.norm(nrm)), color=color, lw=1.2, arrow_length_ratio=0.25)
        drawn.append(S)
        notes.append(f"circle r = {r:.3f} m (wd {w:.2f})")

    if k == 2:
        ax.plot(P[:, 0], P[:, 1], P[:, 2], color="tab:blue", lw=2.0)
        notes.append(f"point pair / line, |b − a| = {np.linalg.norm(P[1] - P[0]):.3f} m")
    elif k == 3:
        circle((0, 1, 2), "tab:blue")
    else:
        if k > 4:
            for s in range(0, k - 2, 3):
                circle((s, s + 1, s + 2), ["tab:blue", "tab:green"][(s // 3) % 2])
        w = float(cg.well_definedness("sphere", P[:4]))
        if w < 1e-6:
            notes.append(f"sphere of the first 4 points degenerate (coplanar, wd {w:.1e}): not drawn")
        else:
            X = cg.sphere(*P[:4])
            c, r = np.asarray(cg.center(X), float), float(cg.radius(X))
            uu, vv = np.meshgrid(np.linspace(0, 2 * np.pi, 25), np.linspace(0, np.pi, 13))
            xs = c[0] + r * np.cos(uu) * np.sin(vv)
            ys = c[1] + r * np.sin(uu) * np.sin(vv)
            zs = c[2] + r * np.cos(vv)
            ax.plot_wireframe(xs, ys, zs, color="tab:blue", lw=0.4, alpha=0.5)
            drawn.append(np.stack([xs.ravel(), ys.ravel(), zs.ravel()], axis=1))
            notes.append(f"sphere r = {r:.3f} m (wd {w:.2f})")
    return drawn, "; ".join(notes)


def set_equal(ax, pts: np.ndarray) -> None:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    c, h = 0.5 * (lo + hi), 0.5 * max(hi - lo) * 1.05 + 1e-3
    ax.set_xlim(c[0] - h, c[0] + h)
    ax.set_ylim(c[1] - h, c[1] + h)
    ax.set_zlim(c[2] - h, c[2] + h)
    ax.set_box_aspect((1, 1, 1))


def figure(system, out: Path) -> Path:
    segs, fixed = skeleton(system, system.q0)
    P = system.end_points(system.q0)
    fig = plt.figure(figsize=(7, 7))
    ax = fig.add_subplot(projection="3d")
    style = {"joint": dict(color="0.15", lw=2.0), "end": dict(color="0.15", lw=1.2, ls="--"),
             "fixed": dict(color="0.6", lw=1.0)}
    for a, b, kind in segs:
        ax.plot([a[0], b[0]], [a[1], b[1]], [a[2], b[2]], **style[kind])
    J = np.array([b for _, b, kind in segs if kind == "joint"])
    ax.scatter(J[:, 0], J[:, 1], J[:, 2], s=12, color="0.15", depthshade=False)
    if len(fixed):
        ax.scatter(fixed[:, 0], fixed[:, 1], fixed[:, 2], s=6, color="0.6", depthshade=False)
    ax.scatter(P[:, 0], P[:, 1], P[:, 2], s=50, color="tab:red", depthshade=False, zorder=5)
    for p, lab in zip(P, system.labels):
        ax.text(p[0], p[1], p[2], f"  {lab}", fontsize=8, color="tab:red")
    drawn, note = draw_primitive(ax, P)
    allpts = np.vstack([J, P, *([fixed] if len(fixed) else []), *[np.vstack([a, b]) for a, b, _ in segs], *drawn])
    set_equal(ax, allpts)
    ax.view_init(*VIEWS.get(system.name, (22, -60)))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    caption = "\n".join(textwrap.wrap(note, 90))
    ax.set_title(f"{system.name}: {system.nq} DOF, {system.n_chains} end points at q0\n{caption}", fontsize=9)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{system.name}.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("paper_figures/systems"), help="output directory")
    ap.add_argument("--only", nargs="*", metavar="NAME", help="draw only these systems")
    args = ap.parse_args(argv)

    from coop_ga import systems

    for name in args.only or systems.names():
        print(figure(systems.load(name), args.out))


if __name__ == "__main__":
    main()
