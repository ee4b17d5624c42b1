"""Seeds and target sampling of a sweep (shared with ``benchmarks/robustness.py``).

**Seeds.**  A job's random stream is ``numpy.random.SeedSequence(entropy, spawn_key=key)``.
By default (:func:`seeds`) job i of n gets the i-th child of ``SeedSequence(root).spawn(n)``,
i.e. ``(entropy=root, spawn_key=(i,))``.  A sweep may instead key the streams by *names*
(:func:`name_spawn_key`: crc32 of each string, ints as they are), so a job's stream does not
depend on its position or on which other jobs are in the sweep — the robustness study keys a
target by ``(crc32(system), crc32(kind), crc32(level), index)``, the key
:meth:`~numpy.random.SeedSequence.spawn` would build from positions.

**Displacements** (:func:`draw_displacement`): a translation of fixed norm in a uniformly
random direction, a rotation by a fixed angle about a uniformly random axis, and a scale
``1 ± s`` with a random sign, applied about the centroid of the end points at ``q0``
(:func:`coop_ga.control.displaced_target`).  The levels of the robustness study:

    level    translation  rotation  scale
    small    2 cm         5°        ±5 %
    medium   5 cm         15°       ±15 %
    large    15 cm        35°       ±30 %

**Certification** (:func:`certify`): a displaced target is reachable without limits by
construction, not necessarily inside them; an independent bounded least-squares solve
(``scipy.optimize.least_squares``, ``trf``, bounds = the position limits, from q0) certifies
it iff it ends at ‖e‖ < 1e-6 inside the limits.
"""

from __future__ import annotations

import math
import time
import warnings
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from ..geometry.groups import SimilarityLike

__all__ = [
    "CERT_MAX_NFEV",
    "CERT_TOL",
    "LEVELS",
    "QD_INIT_MAX",
    "Displacement",
    "Level",
    "certify",
    "draw_displacement",
    "name_key",
    "name_spawn_key",
    "seed_sequence",
    "seeds",
]


@dataclass(frozen=True)
class Level:
    """Size of a displacement: translation norm [m], rotation angle [deg], relative scale change."""

    translation_m: float
    angle_deg: float
    scale: float

    def __post_init__(self) -> None:
        # a relative scale change of 1 or more could draw a zero or negative scale
        validation.nonnegative(self.translation_m, "Level.translation_m [m]")
        validation.scalar(self.angle_deg, "Level.angle_deg [deg]", low=0.0, high=180.0)
        s = validation.scalar(self.scale, "Level.scale (a relative scale change)", low=0.0)
        if s >= 1.0:
            raise InvalidInputError(
                f"Level.scale (a relative scale change) must be < 1 (else a scale ≤ 0 can be drawn), got {s:g}"
            )


#: the displacement levels of the robustness study (module docstring)
LEVELS: dict[str, Level] = {
    "small": Level(0.02, 5.0, 0.05),
    "medium": Level(0.05, 15.0, 0.15),
    "large": Level(0.15, 35.0, 0.30),
}
QD_INIT_MAX = 0.2  # [rad/s] initial joint speeds of a moving start ~ U(±QD_INIT_MAX)
CERT_TOL = 1e-6  # certified iff the bounded least-squares solve reaches ‖e‖ < CERT_TOL
CERT_MAX_NFEV = 1000  # trf is slow near active bounds with a rank-deficient J_e (robustness.py)
MESSAGE_CHARS = 300
MAX_SEEDS = 10**6  # the sweep's default job limit (spec.MAX_JOBS): more seeds than jobs serve no sweep


# ============================================================================ seeds
def name_key(name: str) -> int:
    """crc32 of ``name`` (stable across processes and Python versions; ``hash()`` is salted)."""
    return zlib.crc32(name.encode("utf-8"))


def name_spawn_key(values: Sequence[Any]) -> tuple[int, ...]:
    """A spawn key from names and indices: strings → :func:`name_key`, non-negative ints as they are."""
    if isinstance(values, (str, bytes)) or not isinstance(values, Sequence):
        raise InvalidInputError(
            f"values (a seed key) must be a sequence of strings and non-negative ints, got {values!r}"
        )
    out: list[int] = []
    for v in values:
        if isinstance(v, str):
            out.append(name_key(v))
        elif isinstance(v, (int, np.integer)) and not isinstance(v, bool) and int(v) >= 0:
            out.append(int(v))
        else:
            raise InvalidInputError(f"values (a seed key) must be made of strings and non-negative ints, got {v!r}")
    return tuple(out)


def seeds(root: int, n: int) -> list[dict[str, Any]]:
    """The seeds of n jobs: ``SeedSequence(root).spawn(n)`` as plain data ``{"entropy", "spawn_key"}``.

    Raises:
        InvalidInputError: ``root`` or ``n`` not an integer ≥ 0.
    """
    root = validation.integer(root, "root (the sweep's seed)", minimum=0)
    n = validation.integer(n, "n (the number of seeds)", minimum=0)
    if n > MAX_SEEDS:
        raise InvalidInputError(f"n (the number of seeds) must be ≤ {MAX_SEEDS} (a sweep's job limit), got {n}")
    return [
        {"entropy": int(s.entropy), "spawn_key": [int(k) for k in s.spawn_key]}  # type: ignore[arg-type]
        for s in np.random.SeedSequence(int(root)).spawn(int(n))
    ]


def seed_sequence(seed: Any) -> np.random.SeedSequence:
    """A job's ``SeedSequence`` from its plain seed: an int, or ``{"entropy": int, "spawn_key": [int, ...]}``."""
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and int(seed) >= 0:
        return np.random.SeedSequence(int(seed))
    if isinstance(seed, Mapping) and set(seed) <= {"entropy", "spawn_key"} and "entropy" in seed:
        try:
            ent = validation.integer(seed["entropy"], "seed entropy", minimum=0)
            keys = seed.get("spawn_key", ())
            if isinstance(keys, (str, bytes, Mapping)) or not isinstance(keys, Sequence):
                raise InvalidInputError(f"seed spawn_key must be a list of integers ≥ 0, got {keys!r}")
            key = tuple(validation.integer(k, "seed spawn_key entry", minimum=0) for k in keys)
        except InvalidInputError as exc:
            raise InvalidInputError(
                f"{exc}; a seed is an int ≥ 0 or {{'entropy': int, 'spawn_key': [int, ...]}}"
            ) from None
        return np.random.SeedSequence(ent, spawn_key=key)
    raise InvalidInputError(
        f"seed must be a non-negative int or {{'entropy': int, 'spawn_key': [int, ...]}}, got {seed!r}"
    )


# ============================================================================ displacements
@dataclass(frozen=True)
class Displacement:
    """The random part of one target: the displacement and an initial joint velocity."""

    translation: tuple[float, float, float]  # [m], world frame
    axis: tuple[float, float, float]  # unit, world frame
    angle: float  # [rad]
    scale: float  # factor
    qd_init: tuple[float, ...]  # (nv,) [rad/s] (nv = nq without a free flyer), for a moving start


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal(3)
    n = float(np.linalg.norm(v))
    while n < 1e-9:  # measure zero; keeps the direction well defined
        v = rng.standard_normal(3)
        n = float(np.linalg.norm(v))
    return v / n


def draw_displacement(rng: np.random.Generator, level: Level, nq: int, qd_max: float = QD_INIT_MAX) -> Displacement:
    """Draw a displacement of size ``level`` and an initial velocity U(±qd_max)^nq [rad/s].

    The draw order is fixed (direction, axis, scale sign, velocity) so that a stream always gives the same
    target; it is the order of ``benchmarks/robustness.py`` (``draw_target``), whose targets this reproduces.

    Raises:
        InvalidInputError: ``rng`` not a numpy Generator, ``level`` not a :class:`Level` of finite sizes ≥ 0
            (scale < 1), ``nq`` not an integer ≥ 0, ``qd_max`` not finite ≥ 0.
    """
    if not isinstance(rng, np.random.Generator):
        raise InvalidInputError(
            f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got {type(rng).__name__}"
        )
    if not isinstance(level, Level):
        raise InvalidInputError(f"level must be a coop_ga.sweep.Level (e.g. LEVELS['small']), got {level!r}")
    validation.nonnegative(level.translation_m, "level.translation_m [m]")
    validation.scalar(level.angle_deg, "level.angle_deg [deg]", low=0.0, high=180.0)
    validation.scalar(level.scale, "level.scale (relative change)", low=0.0, high=0.99)
    nq = validation.integer(nq, "nq", minimum=0)
    qd_max = validation.nonnegative(qd_max, "qd_max [rad/s]")
    direction = _unit(rng)
    axis = _unit(rng)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    qd = rng.uniform(-qd_max, qd_max, size=nq)
    t = level.translation_m * direction
    return Displacement(
        translation=(float(t[0]), float(t[1]), float(t[2])),
        axis=(float(axis[0]), float(axis[1]), float(axis[2])),
        angle=math.radians(level.angle_deg),
        scale=1.0 + sign * level.scale,
        qd_init=tuple(float(x) for x in qd),
    )


# ============================================================================ certification
def _finite(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _tangent_chart(system: Any, q_init: np.ndarray) -> tuple[Any, Any, np.ndarray, np.ndarray]:
    """A free flyer's configurations as ``q(δ) = q_init ⊕ δ``, δ (nv,) [rad, m]: ``(to_q, dq_ddelta, lo, hi)``.

    ``dq_ddelta(δ)`` (nv, nv) is ``pinocchio.dIntegrate(…, ARG1)``: a velocity at q(δ) per unit δ, so
    ``J_e(q(δ)) dq_ddelta(δ)`` is ∂e/∂δ.  A 1-DOF joint's coordinate is ``q_init_j + δ_j`` exactly, so its position
    limits are the box ``[lower − q_init_j, upper − q_init_j]`` on δ; the flyer's rows are unbounded."""
    import pinocchio as pin

    lim = system.limits
    x = system.limit_coordinates(q_init)
    free = system.limit_index < 0
    lo = np.where(free, -np.inf, np.asarray(lim.lower, dtype=float) - x)
    hi = np.where(free, np.inf, np.asarray(lim.upper, dtype=float) - x)
    return (
        lambda d: system.integrate(q_init, d),
        lambda d: pin.dIntegrate(system.model, q_init, d, pin.ARG1),
        lo,
        hi,
    )


def certify(task: Any, q_init: np.ndarray, target: SimilarityLike) -> dict[str, Any]:
    """Independent bounded least-squares solve of e(q) = 0 inside the position limits.

    ``scipy.optimize.least_squares(e, q_init, jac=J_e, bounds=(lower, upper), method="trf")`` from q_init (nq,) [rad];
    certified iff the final ‖e‖ < :data:`CERT_TOL` and the final q is within the limits.  Returns
    ``{certified, error, violation, nfev, status, reason, time_s}`` (the same as ``benchmarks/robustness.py``).
    With a free flyer (nq ≠ nv) the unknown is δ (nv,) in ``q = q_init ⊕ δ`` (:func:`_tangent_chart`; one chart
    about q_init, not a box on a quaternion), the bounds are the joints' limits and the violation is measured on
    ``System.limit_coordinates``.

    Raises:
        InvalidInputError: ``task`` is not a cooperative task, ``q_init`` not a finite (nq,) vector.
    """
    from scipy.optimize import least_squares

    if not (hasattr(task, "error_and_jacobian") and hasattr(task, "system") and hasattr(task, "nq")):
        raise InvalidInputError(f"task must be a coop_ga cooperative task, got {type(task).__name__}")
    q_init = validation.configuration(q_init, int(task.nq), "q_init")
    system = task.system
    lim = system.limits
    cache: dict[str, Any] = {}
    if system.nq == system.nv:
        lo, hi = np.asarray(lim.lower, dtype=float), np.asarray(lim.upper, dtype=float)
        x0 = np.clip(np.asarray(q_init, dtype=float), lo, hi)  # trf needs a feasible start
        to_q, chain = (lambda q: q), None
    else:
        to_q, chain, lo, hi = _tangent_chart(system, q_init)
        x0 = np.clip(np.zeros(system.nv), lo, hi)

    def both(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # least_squares asks for e and J_e at the same point: one compiled call for both
        if cache.get("q") is None or not np.array_equal(cache["q"], x):
            e, J = task.error_and_jacobian(to_q(x), target)
            cache.update(q=x.copy(), e=e, J=J if chain is None else J @ chain(x))
        return cache["e"], cache["J"]

    t0 = time.perf_counter()
    out: dict[str, Any] = {
        "certified": False,
        "error": None,
        "violation": None,
        "nfev": None,
        "status": None,
        "reason": None,
        "time_s": None,
    }
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sol = least_squares(
                lambda q: both(q)[0],
                x0,
                jac=lambda q: both(q)[1],
                bounds=(lo, hi),
                method="trf",
                ftol=1e-12,
                xtol=1e-12,
                gtol=1e-12,
                max_nfev=CERT_MAX_NFEV,
            )
            q_sol = to_q(sol.x)
            err = float(np.linalg.norm(task.error(q_sol, target)))
        viol = lim.position_violation(system.limit_coordinates(q_sol))
        out.update(error=_finite(err), violation=_finite(viol), nfev=int(sol.nfev), status=int(sol.status))
        if not (math.isfinite(err) and err < CERT_TOL):
            out["reason"] = f"bounded solve ended at ‖e‖ = {err:.3g} ≥ {CERT_TOL:g} (status {sol.status})"
        elif viol > 0.0:
            out["reason"] = f"bounded solve left the limits by {viol:.3g}"
        else:
            out["certified"] = True
    except Exception as exc:  # e.g. DegeneratePrimitiveError along the solve
        out["reason"] = f"{type(exc).__name__}: {str(exc)[:MESSAGE_CHARS]}"
    out["time_s"] = time.perf_counter() - t0
    return out
