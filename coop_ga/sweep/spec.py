"""Job specifications: plain, picklable data, and sweep specs (JSON/YAML) that expand into jobs.

A **job** is a plain dict (or a :class:`Job`, converted with :meth:`Job.to_dict`)::

    {"system": "three_franka",          # a registry name, or a from_urdf recipe (below)
     "kind": "circle",                   # point, point_pair, line, circle, plane, sphere
     "points": None,                     # optional: end-point indices (coop_ga.cooperative_task)
     "controller": "gauss_newton",       # gauss_newton | diff_ik | ilqr | ilqr_moving | impedance (gn, diffik)
     "options": {},                      # keyword overrides of the controller's options dataclass
     "target": {"translation": [0.05, 0, 0], "angle": 0.2, "axis": [0, 0, 1], "scale": 1.1},
     "start": None,                      # optional: {"spread": rad, "qd_max": rad/s} random start about q0
     "certify": False,                   # certify the target (bounded least squares) before solving
     "seed": 3,                          # an int, or {"entropy": int, "spawn_key": [int, ...]}
     "tags": {}}                         # free fields copied into the record (for grouping)

``system`` as a recipe: ``{"urdf": path, "end_frames": [...], "locked_joints": [...], "name": ...,
"q0": [...]}`` (:func:`coop_ga.systems.from_urdf`).

``target`` is relative to the system's ``q0``, one of:

* a fixed displacement ``{"translation": (3,) m, "axis": (3,), "angle": rad, "scale": factor}`` (all optional;
  ``{}`` is the primitive at q0), through :func:`coop_ga.control.displaced_target`;
* a sampled displacement ``{"sampler": "displacement", "level": "small"|"medium"|"large"}`` or with explicit
  sizes ``{"sampler": "displacement", "translation": m, "angle_deg": deg, "scale": s}`` (:mod:`.targets`);
* explicit similarity coefficients ``{"coeffs": [12 floats]}`` (:meth:`coop_ga.Similarity.from_coeffs`).

A **sweep spec** (a JSON or YAML file, or a dict) expands into jobs (:func:`expand`)::

    {"name": "...", "description": "...", "seed": 0,
     "base": {<job fields shared by every job>},
     "grid": {"system": ["three_franka", ...] | "all", "kind": [...] | "all",
              "target.level": ["small", "medium"], "options.K": [5, 25], "sample": 20,
              "controller": ["ilqr", "gn"]},
     "seeding": "spawn" | {"by": ["system", "kind", "level", "sample"]},
     "summary_by": ["controller", "level"],          # grouping of the CLI's summary table
     "summary_fields": ["iterations", "seconds"],    # fields with quantiles in it
     "histogram": "iterations",                      # the field of the figure's histograms
     "fast": {<a spec fragment merged over this one by --fast>}}

The grid is the Cartesian product in the order of its keys (the first key varies slowest).  A key
that is a job field sets it; ``options.X`` / ``target.X`` / ``start.X`` set one entry of that field; ``sample``
(an int n) is range(n); every grid key's value is also written to the record as a tag named by its last
component (``level``, ``K``, ``sample``, ...).  Seeds: ``"spawn"`` (default) gives job i the i-th child of
``SeedSequence(seed).spawn(n)``; ``{"by": [names]}`` keys the stream by those tags' values
(:func:`.targets.name_spawn_key`), so jobs sharing them (several controllers on one target, several gains on one
start) share their random target/start.
"""

from __future__ import annotations

import copy
import hashlib
import importlib
import itertools
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from ..errors import InvalidInputError
from .targets import LEVELS, name_spawn_key, seed_sequence, seeds

__all__ = [
    "CONTROLLERS",
    "JOB_FIELDS",
    "RESERVED_RECORD_FIELDS",
    "InvalidJobError",
    "Job",
    "expand",
    "job_hash",
    "load_spec",
    "normalize_job",
    "ready_specs",
    "sweep_hash",
]


class InvalidJobError(InvalidInputError):
    """A job or sweep specification is malformed (raised before any job runs)."""


#: controller names → canonical names (``gn``/``diffik`` are the robustness study's names)
CONTROLLERS: dict[str, str] = {
    "gauss_newton": "gauss_newton",
    "gn": "gauss_newton",
    "diff_ik": "diff_ik",
    "diffik": "diff_ik",
    "ilqr": "ilqr",
    "ilqr_moving": "ilqr_moving",
    "impedance": "impedance",
}
JOB_FIELDS = ("system", "kind", "points", "controller", "options", "target", "start", "certify", "seed", "tags")
_TARGET_KEYS = {"translation", "axis", "angle", "scale"}
_SAMPLER_KEYS = {"sampler", "level", "translation", "angle_deg", "scale", "qd_max"}
_START_KEYS = {"spread", "qd_max", "q"}
#: record fields a tag may not overwrite
RESERVED_RECORD_FIELDS = frozenset(
    {
        "job",
        "job_hash",
        "status",
        "converged",
        "error",
        "iterations",
        "seconds",
        "message",
        "exception",
        "exception_type",
        "reason",
        "system",
        "kind",
        "controller",
    }
)


@dataclass(frozen=True)
class Job:
    """One job (see the module docstring); ``Job(...).to_dict()`` is the plain form the executors ship."""

    system: Any
    kind: str
    controller: str
    target: Mapping[str, Any] = field(default_factory=dict)
    options: Mapping[str, Any] = field(default_factory=dict)
    points: Sequence[int] | None = None
    start: Mapping[str, Any] | None = None
    certify: bool = False
    seed: Any = 0
    tags: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The normalized plain dict of this job."""
        return normalize_job({k: getattr(self, k) for k in JOB_FIELDS})


def _plain(x: Any, what: str) -> Any:
    """Deep-copy ``x`` into JSON-able plain data (tuples → lists, numpy scalars/arrays → Python)."""
    if x is None or isinstance(x, (bool, str)):
        return x
    if isinstance(x, int):
        return int(x)
    if isinstance(x, float):
        if not math.isfinite(x):
            raise InvalidJobError(f"{what}: non-finite number {x!r}")
        return float(x)
    if hasattr(x, "tolist") and callable(x.tolist):  # numpy scalar or array
        return _plain(x.tolist(), what)
    if isinstance(x, Mapping):
        out = {}
        for k, v in x.items():
            if not isinstance(k, str):
                raise InvalidJobError(f"{what}: keys must be strings, got {k!r}")
            out[k] = _plain(v, f"{what}.{k}")
        return out
    if isinstance(x, (list, tuple)):
        return [_plain(v, f"{what}[{i}]") for i, v in enumerate(x)]
    raise InvalidJobError(f"{what}: expected plain data (numbers, strings, lists, dicts), got {type(x).__name__}")


def normalize_job(job: Mapping[str, Any] | Job) -> dict[str, Any]:
    """Check a job's structure and return its plain, normalized dict (defaults filled in).

    Structure only: a well-formed job naming an unknown system, a bad option value or an unreachable target is
    *not* rejected here — it runs and is recorded as failed.  Raises :class:`InvalidJobError` for a non-mapping,
    unknown fields, a missing system/kind/controller, an unknown controller, a malformed target, start or seed.
    """
    if isinstance(job, Job):
        return job.to_dict()
    if not isinstance(job, Mapping):
        raise InvalidJobError(f"a job must be a dict or a coop_ga.sweep.Job, got {type(job).__name__}")
    unknown = set(job) - set(JOB_FIELDS)
    if unknown:
        raise InvalidJobError(f"unknown job field(s) {sorted(unknown)}; the fields are {list(JOB_FIELDS)}")
    for k in ("system", "kind", "controller"):
        if k not in job:
            raise InvalidJobError(f"a job needs {k!r} (got fields {sorted(job)})")
    j = _plain(dict(job), "job")
    if not isinstance(j["system"], (str, dict)):
        raise InvalidJobError(f"job.system must be a registry name or a from_urdf recipe dict, got {j['system']!r}")
    if isinstance(j["system"], dict) and not {"urdf", "end_frames"} <= set(j["system"]):
        raise InvalidJobError(f"a system recipe needs 'urdf' and 'end_frames', got {sorted(j['system'])}")
    if not isinstance(j["kind"], str):
        raise InvalidJobError(f"job.kind must be a string, got {j['kind']!r}")
    if j["controller"] not in CONTROLLERS:
        raise InvalidJobError(f"unknown controller {j['controller']!r}; choose one of {list(CONTROLLERS)}")
    j.setdefault("points", None)
    j["options"] = j.get("options") or {}
    j["target"] = j.get("target") or {}
    j.setdefault("start", None)
    j.setdefault("certify", False)
    j.setdefault("seed", 0)
    j["tags"] = j.get("tags") or {}
    for k in ("options", "target", "tags"):
        if not isinstance(j[k], dict):
            raise InvalidJobError(f"job.{k} must be a dict, got {j[k]!r}")
    t = j["target"]
    if "sampler" in t:
        if t["sampler"] != "displacement" or set(t) - _SAMPLER_KEYS:
            raise InvalidJobError(
                f"a sampled target is {{'sampler': 'displacement', 'level': ...}} or with "
                f"'translation', 'angle_deg', 'scale'; got {t!r}"
            )
        if "level" in t and t["level"] not in LEVELS:
            raise InvalidJobError(f"unknown target level {t['level']!r}; choose one of {list(LEVELS)}")
        if "level" not in t and not {"translation", "angle_deg", "scale"} <= set(t):
            raise InvalidJobError(f"a displacement sampler needs 'level' or all of translation/angle_deg/scale: {t!r}")
    elif "coeffs" in t:
        if set(t) != {"coeffs"}:
            raise InvalidJobError(f"a coefficient target is {{'coeffs': [12 numbers]}} alone, got {sorted(t)}")
    elif set(t) - _TARGET_KEYS:
        raise InvalidJobError(
            f"unknown target field(s) {sorted(set(t) - _TARGET_KEYS)}; a fixed target has {sorted(_TARGET_KEYS)}"
        )
    if j["controller"] == "ilqr_moving" and t.get("sampler") != "displacement":
        raise InvalidJobError("controller 'ilqr_moving' takes its initial velocity from a sampled displacement target")
    if j["start"] is not None and (not isinstance(j["start"], dict) or set(j["start"]) - _START_KEYS):
        raise InvalidJobError(
            f"job.start must be None or a dict with keys in {sorted(_START_KEYS)}, got {j['start']!r}"
        )
    if not isinstance(j["certify"], bool):
        raise InvalidJobError(f"job.certify must be True or False, got {j['certify']!r}")
    try:
        seed_sequence(j["seed"])
    except (InvalidInputError, TypeError, ValueError) as exc:
        raise InvalidJobError(f"job.seed: {exc}") from None
    bad = set(j["tags"]) & RESERVED_RECORD_FIELDS
    if bad:
        raise InvalidJobError(f"tag name(s) {sorted(bad)} are record fields; rename them")
    if j["points"] is not None:
        j["points"] = [int(p) for p in j["points"]]
    return j


def _canonical(x: Any) -> str:
    return json.dumps(x, sort_keys=True, separators=(",", ":"), allow_nan=False)


def job_hash(job: Mapping[str, Any]) -> str:
    """A short hash of a normalized job (16 hex digits; same job → same hash in every process)."""
    return hashlib.sha256(_canonical(job).encode()).hexdigest()[:16]


def sweep_hash(jobs: Iterable[Mapping[str, Any]]) -> str:
    """A hash of a whole sweep (the ordered job hashes)."""
    h = hashlib.sha256()
    for j in jobs:
        h.update(job_hash(j).encode())
    return h.hexdigest()[:16]


# ============================================================================ sweep specs
_SPEC_KEYS = {
    "name",
    "description",
    "seed",
    "base",
    "grid",
    "seeding",
    "summary_by",
    "summary_fields",
    "histogram",
    "fast",
    "jobs",
}


def _merge(a: Any, b: Any) -> Any:
    """Deep merge: dicts recursively, anything else replaced by ``b``."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = dict(a)
        for k, v in b.items():
            out[k] = _merge(out[k], v) if k in out else copy.deepcopy(v)
        return out
    return copy.deepcopy(b)


def ready_specs() -> dict[str, Path]:
    """The specs shipped as package data (``coop_ga/sweep/specs/*.json``), by name."""
    d = resources.files("coop_ga.sweep") / "specs"
    out: dict[str, Path] = {}
    for p in sorted(d.iterdir(), key=lambda x: x.name):
        if p.name.endswith((".json", ".yaml", ".yml")):
            out[p.name.rsplit(".", 1)[0]] = Path(str(p))
    return out


def load_spec(source: str | Path | Mapping[str, Any], *, fast: bool = False) -> dict[str, Any]:
    """A sweep spec from a dict, a ``.json``/``.yaml`` file or a ready spec's name; ``fast`` merges its ``fast`` part.

    YAML needs PyYAML (installed with the ``dask`` extra); without it a ``.yaml`` file raises
    :class:`InvalidJobError` saying so.
    """
    if isinstance(source, Mapping):
        spec = _plain(source, "spec")
    else:
        path = Path(source)
        if not path.exists() and str(source) in ready_specs():
            path = ready_specs()[str(source)]
        if not path.is_file():
            raise InvalidJobError(f"no spec file {str(source)!r}; ready specs: {sorted(ready_specs())}")
        text = path.read_text()
        if path.suffix in (".yaml", ".yml"):
            try:  # imported by name: PyYAML ships no type information
                yaml = importlib.import_module("yaml")
            except ImportError:
                raise InvalidJobError(
                    f"{path} is YAML, which needs PyYAML: pip install pyyaml (or use the JSON form)"
                ) from None
            spec = yaml.safe_load(text)
        else:
            try:
                spec = json.loads(text)
            except json.JSONDecodeError as exc:
                raise InvalidJobError(f"{path} is not valid JSON: {exc}") from None
        spec = _plain(spec, str(path))
    if not isinstance(spec, dict):
        raise InvalidJobError(f"a sweep spec is a mapping, got {type(spec).__name__}")
    unknown = set(spec) - _SPEC_KEYS
    if unknown:
        raise InvalidJobError(f"unknown spec field(s) {sorted(unknown)}; the fields are {sorted(_SPEC_KEYS)}")
    if fast and spec.get("fast"):
        spec = _merge({k: v for k, v in spec.items() if k != "fast"}, spec["fast"])
    return spec


def _grid_values(key: str, values: Any) -> list[Any]:
    if key == "sample":
        if not isinstance(values, int) or isinstance(values, bool) or values < 1:
            raise InvalidJobError(f"grid 'sample' is a count ≥ 1, got {values!r}")
        return list(range(values))
    if values == "all" and key in ("system", "kind"):
        from .. import systems
        from ..geometry import KINDS

        return list(systems.names()) if key == "system" else list(KINDS)
    if not isinstance(values, list) or not values:
        raise InvalidJobError(f"grid {key!r} must be a non-empty list, got {values!r}")
    return values


def expand(spec: str | Path | Mapping[str, Any], *, fast: bool = False) -> list[dict[str, Any]]:
    """The normalized jobs of a sweep spec (module docstring), in grid order.

    A spec may also list explicit ``"jobs"`` (each merged over ``base``); then a ``grid`` is not allowed.
    """
    s = load_spec(spec, fast=fast)
    base = s.get("base", {})
    root = s.get("seed", 0)
    if not isinstance(root, int) or isinstance(root, bool) or root < 0:
        raise InvalidJobError(f"spec seed must be a non-negative int, got {root!r}")
    raw: list[tuple[dict[str, Any], dict[str, Any]]] = []  # (job, tags from the grid)
    if "jobs" in s:
        if "grid" in s:
            raise InvalidJobError("a spec has either 'jobs' or a 'grid', not both")
        raw = [(_merge(base, j), {}) for j in s["jobs"]]
    else:
        grid = s.get("grid", {})
        if not isinstance(grid, dict):
            raise InvalidJobError(f"spec grid must be a mapping, got {grid!r}")
        keys = list(grid)
        axes = [_grid_values(k, grid[k]) for k in keys]
        for combo in itertools.product(*axes):
            job = copy.deepcopy(base)
            tags: dict[str, Any] = {}
            for k, v in zip(keys, combo):
                parts = k.split(".")
                if parts[0] == "sample":
                    pass
                elif len(parts) == 1 and parts[0] in JOB_FIELDS:
                    job[parts[0]] = copy.deepcopy(v)
                elif len(parts) == 2 and parts[0] in ("options", "target", "start", "tags"):
                    sub = job.get(parts[0]) or {}
                    sub[parts[1]] = copy.deepcopy(v)
                    job[parts[0]] = sub
                else:
                    raise InvalidJobError(f"grid key {k!r}: a job field, options.X, target.X, start.X or sample")
                if parts[-1] not in ("system", "kind", "controller"):
                    tags[parts[-1]] = v
            raw.append((job, tags))
    seeding = s.get("seeding", "spawn")
    spawned = seeds(root, len(raw)) if seeding == "spawn" else None
    if spawned is None and not (isinstance(seeding, dict) and isinstance(seeding.get("by"), list)):
        raise InvalidJobError(f"seeding is 'spawn' or {{'by': [tag names]}}, got {seeding!r}")
    jobs = []
    for i, (job, tags) in enumerate(raw):
        job["tags"] = {**tags, **(job.get("tags") or {})}
        if "seed" not in job:
            if spawned is not None:
                job["seed"] = spawned[i]
            else:
                assert isinstance(seeding, dict)
                vals = []
                for name in seeding["by"]:
                    src = job["tags"] if name in job["tags"] else job
                    if name not in src:
                        raise InvalidJobError(f"seeding by {name!r}: job {i} has no such field or tag")
                    vals.append(src[name])
                job["seed"] = {"entropy": root, "spawn_key": list(name_spawn_key(vals))}
        jobs.append(normalize_job(job))
    return jobs
