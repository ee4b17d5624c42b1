"""Helpers shared by tests (kept out of conftest so they can be imported)."""

from __future__ import annotations

import numpy as np


def proportionality(A, B) -> tuple[float, float]:
    """(λ, relative residual) of the least-squares fit A ≈ λ B of two numeric multivectors."""
    a, b = A.to_dense(), B.to_dense()
    lam = float(a @ b / (b @ b))
    return lam, float(np.linalg.norm(a - lam * b) / max(np.linalg.norm(a), 1e-300))


def central_difference(f, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Jacobian of f at x by central differences; f returns an array."""
    x = np.asarray(x, dtype=float)
    f0 = np.asarray(f(x))
    J = np.zeros((f0.size, x.size))
    for i in range(x.size):
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        J[:, i] = (np.asarray(f(xp)).ravel() - np.asarray(f(xm)).ravel()) / (2 * h)
    return J


def script_main(script):
    """``main`` of an experiment/benchmark script given by path (the runner's own loader, one place)."""
    from paper_figures import load_script

    return load_script(script)


def strict_json(text: str) -> dict:
    """JSON that refuses NaN/Infinity constants (our outputs are strict: NaN is written as null)."""
    import json

    def refuse(name: str) -> float:
        raise AssertionError(f"non-strict JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def read_metrics(out, name: str = "metrics.json") -> dict:
    """``out/name`` read with :func:`strict_json`."""
    from pathlib import Path

    return strict_json((Path(out) / name).read_text())


#: keys of wall-clock numbers: they belong in timing.json, never in a committed metrics.json
WALL_CLOCK_KEYS = ("tick_time_s", "solve_time_s", "filter_time_s", "tick_median_s", "mpc_overruns", "overruns",
                   "wall_s", "load_average")  # fmt: skip


def wall_clock_keys(obj: object, path: str = "") -> list[str]:
    """Every key of :data:`WALL_CLOCK_KEYS` in a metrics tree, with its path."""
    if isinstance(obj, dict):
        return [f"{path}.{k}" for k in obj if k in WALL_CLOCK_KEYS] + [
            x for k, v in obj.items() for x in wall_clock_keys(v, f"{path}.{k}")
        ]
    if isinstance(obj, list):
        return [x for i, v in enumerate(obj) for x in wall_clock_keys(v, f"{path}[{i}]")]
    return []


def assert_same_mujoco_xml(actual: str, expected: str, rtol: float = 1e-9, atol: float = 1e-12) -> None:
    """Two MJCF texts name the same model: the same elements and attributes in the same order, equal strings, and
    numbers equal to ``rtol``/``atol``.  Not byte equality: the scene's fitted capsules and inertias come from
    LAPACK (numpy, MuJoCo's compiler), whose last bits depend on the CPU's vector units (seen: a capsule's
    half-length 0.10125000000000001 on one machine, 0.10125000000000006 on another)."""
    import xml.etree.ElementTree as ET

    def walk(a: ET.Element, b: ET.Element, where: str) -> None:
        here = f"{where}/{a.tag}[{a.get('name', '')}]"
        assert a.tag == b.tag, f"{here}: element {a.tag} vs {b.tag}"
        assert list(a.attrib) == list(b.attrib), f"{here}: attributes {list(a.attrib)} vs {list(b.attrib)}"
        for key, va in a.attrib.items():
            ta, tb = va.split(), b.attrib[key].split()
            try:
                xa, xb = np.array(ta, dtype=float), np.array(tb, dtype=float)
            except ValueError:
                assert va == b.attrib[key], f"{here}@{key}: {va!r} vs {b.attrib[key]!r}"
                continue
            assert xa.shape == xb.shape, f"{here}@{key}: {va!r} vs {b.attrib[key]!r}"
            np.testing.assert_allclose(xa, xb, rtol=rtol, atol=atol, err_msg=f"{here}@{key}")
        assert len(a) == len(b), f"{here}: {len(a)} vs {len(b)} children"
        for ca, cb in zip(a, b, strict=True):
            walk(ca, cb, here)

    walk(ET.fromstring(actual), ET.fromstring(expected), "")
