"""Job specifications: plain, picklable data, and sweep specs (JSON/YAML) that expand into jobs.

A **job** is a plain dict (or a :class:`Job`, converted with :meth:`Job.to_dict`)::

    {"system": "three_franka",          # a registry name, or a from_urdf recipe (below)
     "kind": "circle",                   # point, point_pair, line, circle, plane, sphere
     "points": None,                     # optional: end-point indices (coop_ga.cooperative_task)
     "controller": "gauss_newton",       # a registered solver (coop_ga.control.SOLVERS) or ilqr_moving
     "options": {},                      # keyword overrides of the controller's options dataclass
     "target": {"translation": [0.05, 0, 0], "angle": 0.2, "axis": [0, 0, 1], "scale": 1.1},
     "start": None,                      # optional: {"spread": rad, "qd_max": rad/s} random start about q0
     "certify": False,                   # certify the target (bounded least squares) before solving
     "free_flyer": False,                # True: the registry's free-flyer variant, load(system, free_flyer=True)
     "seed": 3,                          # an int, or {"entropy": int, "spawn_key": [int, ...]}
     "tags": {}}                         # free fields copied into the record (for grouping)

``system`` as a recipe: ``{"urdf": path, "end_frames": [...], "locked_joints": [...], "name": ...,
"q0": [...]}`` (:func:`coop_ga.systems.from_urdf`).

``free_flyer: True`` puts the base on a free flyer (nq ≠ nv): with a registry name, the system is
``coop_ga.systems.load(name, free_flyer=True)`` (a name without a variant fails as a job, naming those that
have one); with a recipe it becomes the recipe's own ``"free_flyer": True`` (``from_urdf(..., free_flyer=True)``).
``False`` (the default) is dropped from the normalized job, so jobs without it keep their hash.

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
     "timeout": 60 | "auto",                         # the CLI's default per-job timeout [s] (run(timeout=))
     "fast": {<a spec fragment merged over this one by --fast>}}

The grid is the Cartesian product in the order of its keys (the first key varies slowest).  A key
that is a job field sets it; ``options.X`` / ``target.X`` / ``start.X`` set one entry of that field; ``sample``
(an int n) is range(n); every grid key's value is also written to the record as a tag named by its last
component (``level``, ``K``, ``sample``, ...).  Seeds: ``"spawn"`` (default) gives job i the i-th child of
``SeedSequence(seed).spawn(n)``; ``{"by": [names]}`` keys the stream by those tags' values
(:func:`.targets.name_spawn_key`), so jobs sharing them (several controllers on one target, several gains on one
start) share their random target/start.

**Hostile or careless specs** are refused with :class:`InvalidJobError` before anything large is built: a file
over :data:`MAX_SPEC_BYTES`; YAML is read with ``yaml.SafeLoader`` (no Python objects), with at most
:data:`MAX_YAML_ALIASES` aliases, no recursive alias, at most :data:`MAX_SPEC_NODES` values once the aliases are
expanded (an alias bomb — "billion laughs" — is refused from its size, computed on the shared node graph) and a
nesting depth of at most :data:`MAX_SPEC_DEPTH`; a spec that expands to more than ``max_jobs`` jobs (default
:data:`MAX_JOBS`) is refused from the product of its grid sizes (:func:`count_jobs`), before a job is made.
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

from .. import validation
from ..errors import InvalidInputError
from .targets import LEVELS, name_spawn_key, seed_sequence, seeds

__all__ = [
    "CONTROLLERS",
    "JOB_FIELDS",
    "MAX_JOBS",
    "MAX_SPEC_BYTES",
    "MAX_SPEC_DEPTH",
    "MAX_SPEC_NODES",
    "MAX_YAML_ALIASES",
    "RESERVED_RECORD_FIELDS",
    "InvalidJobError",
    "Job",
    "count_jobs",
    "expand",
    "job_hash",
    "load_spec",
    "normalize_job",
    "ready_specs",
    "sweep_hash",
]


class InvalidJobError(InvalidInputError):
    """A job or sweep specification is malformed (raised before any job runs)."""


#: the sweep-only variant of iLQR that starts from the sampled displacement's joint velocity
MOVING_ILQR = "ilqr_moving"


def _controllers() -> dict[str, str]:
    """Controller names → canonical solver names, read from :data:`coop_ga.control.SOLVERS`: every runner of
    the ``reach`` signature that needs no problem data beyond its options (names and aliases, e.g. ``gn``,
    ``diffik``), plus :data:`MOVING_ILQR`."""
    from ..control.registry import SOLVERS

    out = {MOVING_ILQR: MOVING_ILQR}
    for e in SOLVERS.values():
        if e.signature == "reach" and not e.required:
            out.update(dict.fromkeys((e.name, *e.aliases), e.name))
    return out


#: controller names → canonical names (from the solver registry; ``gn``/``diffik`` are the robustness study's)
CONTROLLERS: dict[str, str] = _controllers()
#: default limit of the jobs a spec may expand into (``expand(max_jobs=)``, ``--max-jobs``)
MAX_JOBS = 10**6
MAX_SPEC_BYTES = 8 * 2**20  # a spec file's size limit [bytes]
MAX_YAML_ALIASES = 100  # YAML aliases (``*name``) allowed in one spec
MAX_SPEC_NODES = 10**6  # values in a spec once its YAML aliases are expanded
MAX_SPEC_DEPTH = 64  # nesting depth of a spec or a job
JOB_FIELDS = (
    "system",
    "kind",
    "points",
    "controller",
    "options",
    "target",
    "start",
    "certify",
    "free_flyer",
    "seed",
    "tags",
)
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
        "free_flyer",
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
    free_flyer: bool = False
    seed: Any = 0
    tags: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The normalized plain dict of this job."""
        return normalize_job({k: getattr(self, k) for k in JOB_FIELDS})


def _plain(x: Any, what: str, depth: int = 0) -> Any:
    """Deep-copy ``x`` into JSON-able plain data (tuples → lists, numpy scalars/arrays → Python)."""
    if depth > MAX_SPEC_DEPTH:
        raise InvalidJobError(f"nested deeper than {MAX_SPEC_DEPTH} levels (or contains itself): {what[:150]}…")
    if x is None or isinstance(x, (bool, str)):
        return x
    if isinstance(x, int):
        return int(x)
    if isinstance(x, float):
        if not math.isfinite(x):
            raise InvalidJobError(f"{what}: non-finite number {x!r}; jobs and specs hold finite numbers only")
        return float(x)
    if hasattr(x, "tolist") and callable(x.tolist):  # numpy scalar or array
        return _plain(x.tolist(), what, depth)
    if isinstance(x, Mapping):
        out = {}
        for k, v in x.items():
            if not isinstance(k, str):
                raise InvalidJobError(f"{what}: keys must be strings, got {k!r}")
            out[k] = _plain(v, f"{what}.{k}", depth + 1)
        return out
    if isinstance(x, (list, tuple)):
        return [_plain(v, f"{what}[{i}]", depth + 1) for i, v in enumerate(x)]
    raise InvalidJobError(f"{what}: expected plain data (numbers, strings, lists, dicts), got {type(x).__name__}")


def _num(x: Any, what: str, **bounds: Any) -> float:
    """A real number in bounds (:func:`coop_ga.validation.scalar`), as an :class:`InvalidJobError`."""
    try:
        return validation.scalar(x, what, **bounds)
    except InvalidInputError as exc:
        raise InvalidJobError(str(exc)) from None


def _vec(x: Any, n: int, what: str) -> list[float]:
    try:
        return [float(v) for v in validation.vector(x, n, what)]
    except InvalidInputError as exc:
        raise InvalidJobError(str(exc)) from None


def _check_target(t: dict[str, Any]) -> None:
    """A target's structure and values (module docstring): fixed, sampled or coefficients."""
    if "sampler" in t:
        if t["sampler"] != "displacement" or set(t) - _SAMPLER_KEYS:
            raise InvalidJobError(
                f"a sampled target is {{'sampler': 'displacement', 'level': ...}} or with "
                f"'translation', 'angle_deg', 'scale'; got {t!r}"[:400]
            )
        if "level" in t and (not isinstance(t["level"], str) or t["level"] not in LEVELS):
            raise InvalidJobError(f"unknown target level {t['level']!r}; choose one of {list(LEVELS)}")
        if "level" not in t and not {"translation", "angle_deg", "scale"} <= set(t):
            raise InvalidJobError(f"a displacement sampler needs 'level' or all of translation/angle_deg/scale: {t!r}")
        for k, hi in (("translation", None), ("angle_deg", 180.0), ("scale", 0.99), ("qd_max", None)):
            if k in t:  # sizes: |translation| [m], angle [deg], relative scale change, |q̇| [rad/s]
                _num(t[k], f"job.target.{k}", low=0.0, high=hi)
    elif "coeffs" in t:
        if set(t) != {"coeffs"}:
            raise InvalidJobError(f"a coefficient target is {{'coeffs': [12 numbers]}} alone, got {sorted(t)}")
        _vec(t["coeffs"], 12, "job.target.coeffs")
    elif set(t) - _TARGET_KEYS:
        raise InvalidJobError(
            f"unknown target field(s) {sorted(set(t) - _TARGET_KEYS)}; a fixed target has {sorted(_TARGET_KEYS)}"
        )
    else:
        if "translation" in t:
            _vec(t["translation"], 3, "job.target.translation [m]")
        if "axis" in t and sum(v * v for v in _vec(t["axis"], 3, "job.target.axis")) < 1e-24:
            raise InvalidJobError("job.target.axis must be a nonzero 3-vector (the rotation axis)")
        if "angle" in t:
            _num(t["angle"], "job.target.angle [rad]")
        if "scale" in t:
            _num(t["scale"], "job.target.scale (a factor)", low=0.0, low_open=True)


def _check_start(st: Any) -> None:
    if st is None:
        return
    if not isinstance(st, dict) or set(st) - _START_KEYS:
        raise InvalidJobError(f"job.start must be None or a dict with keys in {sorted(_START_KEYS)}, got {st!r}"[:400])
    for k in ("spread", "qd_max"):
        if k in st:
            _num(st[k], f"job.start.{k}", low=0.0)
    if "q" in st:
        try:
            validation.array(st["q"], "job.start.q [rad or m]")
        except InvalidInputError as exc:
            raise InvalidJobError(str(exc)) from None


def _check_points(points: Any) -> list[int] | None:
    if points is None:
        return None
    if not isinstance(points, list) or not points:
        raise InvalidJobError(f"job.points must be None or a non-empty list of end-point indices, got {points!r}")
    for p in points:
        if isinstance(p, bool) or not isinstance(p, int) or p < 0:
            raise InvalidJobError(f"job.points must hold end-point indices (integers ≥ 0), got {points!r}")
    return list(points)


def _check_names(j: dict[str, Any]) -> None:
    """system (a name or a from_urdf recipe), kind and controller."""
    from ..geometry import KINDS

    if not isinstance(j["system"], (str, dict)):
        raise InvalidJobError(f"job.system must be a registry name or a from_urdf recipe dict, got {j['system']!r}")
    if isinstance(j["system"], dict) and not {"urdf", "end_frames"} <= set(j["system"]):
        raise InvalidJobError(f"a system recipe needs 'urdf' and 'end_frames', got {sorted(j['system'])}")
    if not isinstance(j["kind"], str) or j["kind"] not in KINDS:
        raise InvalidJobError(f"unknown job.kind {j['kind']!r}; choose one of {list(KINDS)}")
    if not isinstance(j["controller"], str) or j["controller"] not in CONTROLLERS:
        raise InvalidJobError(f"unknown controller {j['controller']!r}; choose one of {list(CONTROLLERS)}")


def normalize_job(job: Mapping[str, Any] | Job) -> dict[str, Any]:
    """Check a job's structure and values and return its plain, normalized dict (defaults filled in).

    Structure and value ranges only: a well-formed job naming an unknown system, a bad option value or an
    unreachable target is *not* rejected here — it runs and is recorded as failed.

    Raises:
        InvalidJobError: a non-mapping, unknown fields, a missing system/kind/controller, an unknown kind or
            controller, NaN/inf anywhere, a malformed or out-of-range target, start, points or seed.
    """
    if isinstance(job, Job):
        return job.to_dict()
    if not isinstance(job, Mapping):
        raise InvalidJobError(f"a job must be a dict or a coop_ga.sweep.Job, got {type(job).__name__}")
    unknown = set(job) - set(JOB_FIELDS)
    if unknown:
        raise InvalidJobError(f"unknown job field(s) {sorted(map(str, unknown))}; the fields are {list(JOB_FIELDS)}")
    for k in ("system", "kind", "controller"):
        if k not in job:
            raise InvalidJobError(f"a job needs {k!r} (got fields {sorted(job)})")
    j = _plain(dict(job), "job")
    _check_names(j)
    j["points"] = _check_points(j.get("points"))
    for k in ("options", "target", "tags"):
        j[k] = {} if j.get(k) is None else j[k]
        if not isinstance(j[k], dict):
            raise InvalidJobError(f"job.{k} must be a dict, got {j[k]!r}"[:300])
    j.setdefault("start", None)
    j.setdefault("certify", False)
    j.setdefault("seed", 0)
    _check_target(j["target"])
    if j["controller"] == "ilqr_moving" and j["target"].get("sampler") != "displacement":
        raise InvalidJobError("controller 'ilqr_moving' takes its initial velocity from a sampled displacement target")
    _check_start(j["start"])
    if not isinstance(j["certify"], bool):
        raise InvalidJobError(f"job.certify must be True or False, got {j['certify']!r}")
    _fold_free_flyer(j)
    try:
        seed_sequence(j["seed"])
    except (InvalidInputError, TypeError, ValueError, OverflowError) as exc:
        raise InvalidJobError(f"job.seed: {exc}") from None
    bad = set(j["tags"]) & RESERVED_RECORD_FIELDS
    if bad:
        raise InvalidJobError(f"tags: name(s) {sorted(bad)} are record fields; rename them")
    return j


def _fold_free_flyer(j: dict[str, Any]) -> None:
    """Normalize ``free_flyer`` (module docstring): dropped when False, moved into a recipe, kept for a name."""
    ff = j.pop("free_flyer", False)
    if not isinstance(ff, bool):
        raise InvalidJobError(f"job.free_flyer must be True or False, got {ff!r}")
    if ff and isinstance(j["system"], dict):
        j["system"] = {**j["system"], "free_flyer": True}
    elif ff:
        j["free_flyer"] = True


def _canonical(x: Any) -> str:
    return json.dumps(x, sort_keys=True, separators=(",", ":"), allow_nan=False)


def job_hash(job: Mapping[str, Any]) -> str:
    """A short hash of a normalized job (16 hex digits; same job → same hash in every process).

    Raises:
        InvalidJobError: ``job`` is not a mapping of plain, finite data.
    """
    if not isinstance(job, Mapping):
        raise InvalidJobError(f"job_hash takes a (normalized) job dict, got {type(job).__name__}")
    try:
        return hashlib.sha256(_canonical(job).encode()).hexdigest()[:16]
    except (TypeError, ValueError) as exc:
        raise InvalidJobError(f"job_hash: the job is not plain finite data ({exc}); use normalize_job(job)") from None


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
    "timeout",
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


def _yaml_node_check(root: Any, what: str) -> None:
    """Refuse a composed YAML graph whose expansion is too large, too deep or cyclic (alias bombs).

    Aliases make the node graph a DAG (or a cycle); its expanded size is counted with one pass over the shared
    nodes (memoized), never by expanding it.
    """
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[Any, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        k = id(node)
        kids = [c for pair in node.value for c in pair] if node.id == "mapping" else (
            node.value if node.id == "sequence" else [])  # fmt: skip
        if done:
            on_path.discard(k)
            size[k] = 1 + sum(size[id(c)] for c in kids)
            depth[k] = 1 + max((depth[id(c)] for c in kids), default=0)
            if size[k] > MAX_SPEC_NODES or depth[k] > MAX_SPEC_DEPTH:
                raise InvalidJobError(
                    f"{what}: the spec expands to more than {MAX_SPEC_NODES} values or nests deeper than "
                    f"{MAX_SPEC_DEPTH} levels once its aliases are expanded (an alias bomb?); write it out plainly"
                )
            continue
        if k in size:
            continue
        if k in on_path:
            raise InvalidJobError(f"{what}: a YAML alias refers to a node that contains it (a cycle); remove it")
        on_path.add(k)
        stack.append((node, True))
        stack.extend((c, False) for c in kids if id(c) not in size)


def _load_yaml(path: Path, text: str) -> Any:
    """YAML through ``yaml.SafeLoader`` with aliases counted (:data:`MAX_YAML_ALIASES`) and the expanded size
    checked (:func:`_yaml_node_check`) before any Python object is built."""
    try:  # imported by name: PyYAML ships no type information
        yaml = importlib.import_module("yaml")
    except ImportError:
        raise InvalidJobError(
            f"{path} is YAML, which needs PyYAML: pip install pyyaml (or use the JSON form)"
        ) from None

    class Loader(yaml.SafeLoader):  # type: ignore[name-defined]
        aliases = 0

        def compose_node(self, parent: Any, index: Any) -> Any:
            if self.check_event(yaml.AliasEvent):
                self.aliases += 1
                if self.aliases > MAX_YAML_ALIASES:
                    raise InvalidJobError(
                        f"{path}: more than {MAX_YAML_ALIASES} YAML aliases (*name); write the spec out plainly"
                    )
            return super().compose_node(parent, index)

    loader = Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _yaml_node_check(node, str(path))
        return loader.construct_document(node)
    except yaml.YAMLError as exc:
        raise InvalidJobError(f"{path} is not valid YAML: {str(exc)[:300]}") from None
    except RecursionError:
        raise InvalidJobError(f"{path}: nested too deeply (limit {MAX_SPEC_DEPTH} levels)") from None
    finally:
        loader.dispose()


def _read_spec_file(source: str | Path) -> Any:
    path = Path(source)
    if not path.exists() and str(source) in ready_specs():
        path = ready_specs()[str(source)]
    if not path.is_file():
        raise InvalidJobError(f"no spec file {str(source)!r}; ready specs: {sorted(ready_specs())}")
    n = path.stat().st_size
    if n > MAX_SPEC_BYTES:
        raise InvalidJobError(f"{path} is {n} bytes, over the {MAX_SPEC_BYTES}-byte limit of a spec; use a grid")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InvalidJobError(f"cannot read the spec {path}: {exc}") from None
    if path.suffix in (".yaml", ".yml"):
        return _plain(_load_yaml(path, text), str(path))
    try:
        return _plain(json.loads(text), str(path))
    except json.JSONDecodeError as exc:
        raise InvalidJobError(f"{path} is not valid JSON: {exc}") from None
    except RecursionError:
        raise InvalidJobError(f"{path}: nested too deeply (limit {MAX_SPEC_DEPTH} levels)") from None


def load_spec(source: str | Path | Mapping[str, Any], *, fast: bool = False) -> dict[str, Any]:
    """A sweep spec from a dict, a ``.json``/``.yaml`` file or a ready spec's name; ``fast`` merges its ``fast`` part.

    Files are read safely (module docstring).  YAML needs PyYAML (installed with the ``dask`` extra).

    Raises:
        InvalidJobError: no such file or ready spec; a file too large, invalid, an alias bomb, too deep; not a
            mapping; unknown fields; a bad ``timeout``; YAML without PyYAML.
    """
    if not isinstance(fast, bool):
        raise InvalidJobError(f"fast must be True or False, got {fast!r}")
    try:
        if isinstance(source, Mapping):
            spec = _plain(source, "spec")
        elif isinstance(source, (str, Path)):
            spec = _read_spec_file(source)
        else:
            raise InvalidJobError(
                f"a spec is a dict, a .json/.yaml path or a ready spec's name, got {type(source).__name__}"
            )
        if not isinstance(spec, dict):
            raise InvalidJobError(f"a sweep spec is a mapping, got {type(spec).__name__}")
    except InvalidJobError as e:  # name the argument: the message alone may only name a file
        raise InvalidJobError(f"source: {e}") from None
    unknown = set(spec) - _SPEC_KEYS
    if unknown:
        raise InvalidJobError(f"unknown spec field(s) {sorted(unknown)}; the fields are {sorted(_SPEC_KEYS)}")
    if fast and spec.get("fast"):
        if not isinstance(spec["fast"], dict):
            raise InvalidJobError(f"spec 'fast' must be a mapping merged over the spec, got {spec['fast']!r}"[:300])
        spec = _merge({k: v for k, v in spec.items() if k != "fast"}, spec["fast"])
    t = spec.get("timeout")
    if t is not None and t != "auto":
        _num(t, "spec timeout [s] (or 'auto')", low=0.0, low_open=True)
    return spec


def _axis_size(key: str, values: Any) -> int:
    """How many values grid axis ``key`` has (``sample``: the count itself; nothing is built)."""
    if key == "sample":
        if not isinstance(values, int) or isinstance(values, bool) or values < 1:
            raise InvalidJobError(f"grid 'sample' is a count ≥ 1, got {values!r}")
        return values
    if values == "all" and key in ("system", "kind"):
        return len(_all_values(key))
    if not isinstance(values, list) or not values:
        raise InvalidJobError(f"grid {key!r} must be a non-empty list, got {values!r}"[:300])
    return len(values)


def _all_values(key: str) -> list[Any]:
    from .. import systems
    from ..geometry import KINDS

    return list(systems.names()) if key == "system" else list(KINDS)


def _grid_values(key: str, values: Any) -> list[Any]:
    if key == "sample":
        return list(range(values))
    if values == "all" and key in ("system", "kind"):
        return _all_values(key)
    return list(values)


def _grid(s: Mapping[str, Any]) -> dict[str, Any]:
    grid = s.get("grid", {})
    if not isinstance(grid, dict):
        raise InvalidJobError(f"spec grid must be a mapping, got {grid!r}"[:300])
    return grid


def count_jobs(spec: str | Path | Mapping[str, Any], *, fast: bool = False) -> int:
    """The number of jobs :func:`expand` would make: the product of the grid's axis sizes (or the ``jobs`` listed),
    computed without making any.

    Raises:
        InvalidJobError: as :func:`load_spec`, or a malformed grid axis.
    """
    s = load_spec(spec, fast=fast)
    if "jobs" in s:
        if not isinstance(s["jobs"], list):
            raise InvalidJobError(f"spec 'jobs' must be a list of jobs, got {type(s['jobs']).__name__}")
        return len(s["jobs"])
    return math.prod(_axis_size(k, v) for k, v in _grid(s).items())


def _grid_jobs(base: dict[str, Any], grid: dict[str, Any]) -> list[tuple[dict[str, Any], dict[str, Any]]]:
    """(job, tags from the grid) for every point of the grid, in order (the first key varies slowest)."""
    keys = list(grid)
    axes = [_grid_values(k, grid[k]) for k in keys]
    raw: list[tuple[dict[str, Any], dict[str, Any]]] = []
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
            if parts[-1] not in ("system", "kind", "controller", "free_flyer"):
                tags[parts[-1]] = v
        raw.append((job, tags))
    return raw


def _seeded(raw: list[tuple[dict[str, Any], dict[str, Any]]], root: int, seeding: Any) -> list[dict[str, Any]]:
    """The jobs with their tags merged and their seeds set (module docstring), normalized."""
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
                    if not isinstance(name, str) or name not in src:
                        raise InvalidJobError(f"seeding by {name!r}: job {i} has no such field or tag")
                    vals.append(src[name])
                try:
                    job["seed"] = {"entropy": root, "spawn_key": list(name_spawn_key(vals))}
                except InvalidInputError as exc:
                    raise InvalidJobError(f"seeding by {seeding['by']}: {exc}") from None
        jobs.append(normalize_job(job))
    return jobs


def expand(
    spec: str | Path | Mapping[str, Any], *, fast: bool = False, max_jobs: int = MAX_JOBS
) -> list[dict[str, Any]]:
    """The normalized jobs of a sweep spec (module docstring), in grid order.

    A spec may also list explicit ``"jobs"`` (each merged over ``base``); then a ``grid`` is not allowed.

    Args:
        spec: a dict, a ``.json``/``.yaml`` path or a ready spec's name.
        fast: merge the spec's ``fast`` fragment (a few jobs).
        max_jobs: refuse a spec of more jobs than this (counted first, :func:`count_jobs`).

    Raises:
        InvalidJobError: as :func:`load_spec`; more than ``max_jobs`` jobs; a malformed grid, seeding or job.
    """
    if isinstance(max_jobs, bool) or not isinstance(max_jobs, int) or max_jobs < 1:
        raise InvalidJobError(f"max_jobs must be an integer ≥ 1, got {max_jobs!r}")
    s = load_spec(spec, fast=fast)
    n = count_jobs(s)
    if n > max_jobs:
        raise InvalidJobError(
            f"the spec expands to {n} jobs, more than max_jobs={max_jobs}; shrink its grid (or 'sample'), or raise "
            "the limit: expand(..., max_jobs=N), python -m coop_ga.sweep --max-jobs N"
        )
    base = s.get("base", {})
    if not isinstance(base, dict):
        raise InvalidJobError(f"spec 'base' must be a mapping of job fields, got {base!r}"[:300])
    root = s.get("seed", 0)
    if not isinstance(root, int) or isinstance(root, bool) or root < 0:
        raise InvalidJobError(f"spec seed must be a non-negative int, got {root!r}")
    raw: list[tuple[dict[str, Any], dict[str, Any]]]
    if "jobs" in s:
        if "grid" in s:
            raise InvalidJobError("a spec has either 'jobs' or a 'grid', not both")
        raw = [(_merge(base, j), {}) for j in s["jobs"]]
    else:
        raw = _grid_jobs(base, _grid(s))
    return _seeded(raw, root, s.get("seeding", "spawn"))
