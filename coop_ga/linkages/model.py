"""Planar closed-loop linkages: rigid links moved by planar motors, joints as CGA residuals, and a
Newton solver stepping in the Lie algebra (seed 004, §3).

Model
-----
A :class:`Linkage` is a set of rigid :class:`Link` s, each a named set of points given in the
world frame at a *reference configuration* (its body frame is the world frame there), and
joints between link points:

* :class:`Revolute` — two link points coincide: the residual is the difference of the
  Euclidean parts of ``M_a up(p) M̃_a`` and ``M_b up(q) M̃_b`` (2 rows, [m]).  It is zero exactly
  at coincidence and smooth, with a full-rank Jacobian there.  The inner product
  ``x_a·x_b = −½|p − q|²`` is zero at coincidence too, but quadratically, so its Jacobian
  vanishes where Newton needs it;
* :class:`Prismatic` — a point of one link slides on the line through two points of another
  (the guide), and the slider keeps its orientation relative to the guide (a block in a slot):
  the residual is ``x · π`` with ``π = n + δ e∞`` the guide line's dual (IPNS) vector moved by
  the guide's motor — the signed distance [m] to the line — and the e12 part of ``M̃_g M_s``
  (``−sin(Δθ/2)``, the relative rotation): 2 rows.

One link is the ground (motor 1), one the crank, driven by an angle φ about its pivot: its motor
is :func:`~coop_ga.linkages.planar.rotation_about` (pivot, φ − φ_ref).  The others are unknown.

**Seed 004 error (§3.2):** the seed's rigid-bar constraint ``x_i ∧ x_j = 0`` does not express a
bar of length L: for two conformal (null) points ``x_i ∧ x_j = 0`` iff they are proportional,
i.e. the *same* point — it is a coincidence constraint.  The bar condition is
``x_i · x_j = −½ L²`` (``x_i·x_j = −½|p_i − p_j|²``).  Here bar lengths are a *property* of the
links: every point of a link is moved by the same motor, which preserves distances, so no bar
constraint is needed (and lengths hold to round-off: tested to 1e-12).  Likewise the seed's
pin ``x_j ∧ x_fixed = 0`` is a coincidence (correct, but with the rank-deficient Jacobian of a
quadratic residual if written as an inner product; we use the Euclidean difference).

Solver
------
The unknowns are the motors of the moving links.  At a Newton iterate each is updated by a
twist ξ_k = (ω, v1, v2) in the Lie algebra, ``M_k ← exp(ξ_k) M_k`` (Eq (1) of
:mod:`~coop_ga.linkages.planar`; seed 004 §3.3).  The residuals F and their Jacobian
J = ∂F/∂ξ at ξ = 0 come from one CasADi graph of the CGA expressions (automatic
differentiation, compiled once per linkage).  The step solves ``J ξ = −F`` (exactly constrained
linkages; damped Levenberg–Marquardt, λ = ‖F‖², when the linkage is redundant), with
backtracking on ‖F‖.

Tracking the crank (seed 004 §3.4, with what the seed lacks): from the last solution a
*predictor* follows the tangent of the solution curve (``J ξ = −∂F/∂φ Δφ``), Newton corrects.  A
step is rejected and halved when Newton does not reach the tolerance, when the corrector moves
far compared with the predictor (a jump), or when the sign of det J changes (for the square,
exactly constrained case: det J vanishes only at singular configurations, so a sign change
without passing one is a jump onto the other assembly branch).  Below ``min_step`` the crank
angle is reported as the end of the motion, with the smallest singular value of J there: a
toggle (dead-centre) position if it is ≈ 0, an unassemblable one otherwise.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from .. import validation
from ..algebra.multivector import Multivector
from ..errors import CoopGAError, InvalidInputError
from .planar import PLANAR_BLADES, apply_point, compose, motor, motor_exp, rotation_about

__all__ = ["Link", "Linkage", "LinkageError", "LinkageMotion", "Prismatic", "Revolute"]

IDENTITY = (1.0, 0.0, 0.0, 0.0)


@dataclass
class _TrackState:
    """Where :meth:`Linkage.track` is: motors, crank angle, max|F|, the Jacobian data there (J, ∂F/∂φ, σ_min,
    sign det J), the Newton iterations and substeps of the current angle, and the substeps left."""

    m: np.ndarray
    phi: float
    here: tuple[np.ndarray, np.ndarray, float, int]
    budget: int
    r: float = 0.0
    iters: int = 0
    subs: int = 0


class LinkageError(CoopGAError, ValueError):
    """A linkage is ill-formed, or cannot be assembled at a crank angle (message says where)."""


#: coordinates [m] beyond this are refused (their squares, in the conformal points, must not overflow)
MAX_COORDINATE = 1e150
#: :meth:`Linkage.track`'s default bound on the crank substeps of one call (bounded work: ~1 ms each)
MAX_SUBSTEPS = 100_000
#: :meth:`Linkage.newton` refuses a larger ``max_iter``
MAX_NEWTON_ITERATIONS = 10_000


def _name(x: Any, what: str) -> str:
    if not isinstance(x, str) or not x:
        raise InvalidInputError(f"{what} must be a non-empty name (str), got {x!r}")
    return x


def _names(x: Any, n: int, what: str) -> tuple[str, ...]:
    if isinstance(x, str) or not isinstance(x, Sequence) or len(x) != n:
        form = "(link, point)" if n == 2 else "(link, point, point)"
        raise InvalidInputError(f"{what} must be a tuple {form} of names, got {x!r}")
    return tuple(_name(v, f"{what}[{i}]") for i, v in enumerate(x))


def _planar_point(p: Any, what: str) -> tuple[float, float]:
    a = validation.vector(p, 2, what)
    if float(np.max(np.abs(a))) > MAX_COORDINATE:
        raise InvalidInputError(f"{what} = {a.tolist()} is beyond ±{MAX_COORDINATE:g} m")
    return (float(a[0]), float(a[1]))


@dataclass(frozen=True)
class Link:
    """A rigid link: ``points`` maps names to planar points (2,) [m], world frame at the reference.

    The points are checked (finite 2-vectors) and stored as ``{name: (x, y)}`` (a new dict)."""

    name: str
    points: Mapping[str, Any]

    def __post_init__(self) -> None:
        _name(self.name, "Link.name")
        if not isinstance(self.points, Mapping) or not self.points:
            raise InvalidInputError(
                f"Link.points of {self.name!r} must be a non-empty dict {{name: (x, y)}} [m], got {self.points!r}"
            )
        pts = {
            _name(k, f"a point name of link {self.name!r}"): _planar_point(v, f"points[{k!r}] of link {self.name!r}")
            for k, v in self.points.items()
        }
        object.__setattr__(self, "points", pts)


@dataclass(frozen=True)
class Revolute:
    """Link points ``a = (link, point)`` and ``b = (link, point)`` coincide."""

    a: tuple[str, str]
    b: tuple[str, str]

    def __post_init__(self) -> None:
        object.__setattr__(self, "a", _names(self.a, 2, "Revolute a"))
        object.__setattr__(self, "b", _names(self.b, 2, "Revolute b"))


@dataclass(frozen=True)
class Prismatic:
    """Point ``slider = (link, point)`` slides on the line through ``guide = (link, p, q)``, the
    slider link keeping its orientation relative to the guide link."""

    slider: tuple[str, str]
    guide: tuple[str, str, str]

    def __post_init__(self) -> None:
        object.__setattr__(self, "slider", _names(self.slider, 2, "Prismatic slider"))
        object.__setattr__(self, "guide", _names(self.guide, 3, "Prismatic guide"))


@dataclass
class LinkageMotion:
    """A tracked crank motion.  Arrays cover the solved prefix of the requested crank angles.

    crank_angles (T,) [rad]; points (T, P, 2) [m] world positions of ``point_names``
    (``"link.point"``); residual (T,) max |F| [m]; iterations (T,) Newton iterations summed over
    the substeps; substeps (T,); sigma_min (T,) smallest singular value of J; det_sign (T,).
    ``complete`` is False when the motion stopped before the last requested angle; then
    ``stop_angle`` [rad] is where it stopped and ``message`` says why (a toggle position when
    ``stop_sigma_min`` ≈ 0).
    """

    crank_angles: np.ndarray
    points: np.ndarray
    point_names: tuple[str, ...]
    residual: np.ndarray
    iterations: np.ndarray
    substeps: np.ndarray
    sigma_min: np.ndarray
    det_sign: np.ndarray
    motors: np.ndarray
    complete: bool
    requested: int
    stop_angle: float | None = None
    stop_sigma_min: float | None = None
    message: str = "ok"
    extra: dict[str, Any] = field(default_factory=dict)

    def point(self, name: str) -> np.ndarray:
        """(T, 2) trajectory of ``"link.point"``."""
        if not isinstance(name, str) or name not in self.point_names:
            raise InvalidInputError(f"name {name!r} is not a point; the points are {list(self.point_names)}")
        return self.points[:, self.point_names.index(name)]


def _sequence(x: Any, kind: type | tuple[type, ...], what: str) -> tuple[Any, ...]:
    """A list/tuple of ``kind`` objects (a new tuple)."""
    names = kind.__name__ if isinstance(kind, type) else " or ".join(k.__name__ for k in kind)
    if isinstance(x, (str, bytes)) or not isinstance(x, Sequence):
        raise InvalidInputError(f"{what} must be a list of {names}, got {x!r}")
    bad = [type(v).__name__ for v in x if not isinstance(v, kind)]
    if bad:
        raise InvalidInputError(f"{what} must be a list of {names}, got {bad}")
    return tuple(x)


def _kabsch2(P: np.ndarray, Q: np.ndarray) -> tuple[float, np.ndarray]:
    """Rotation angle and translation of the rigid motion best mapping points P (n, 2) onto Q."""
    if len(P) == 1:
        return 0.0, Q[0] - P[0]
    pc, qc = P.mean(0), Q.mean(0)
    A, B = P - pc, Q - qc
    s = float(np.sum(A[:, 0] * B[:, 1] - A[:, 1] * B[:, 0]))
    c = float(np.sum(A[:, 0] * B[:, 0] + A[:, 1] * B[:, 1]))
    th = float(np.arctan2(s, c))
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    return th, qc - R @ pc


class Linkage:
    """A planar closed-loop linkage driven by one crank (see the module docstring).

    links: the rigid links (points in world coordinates at the reference configuration).
    joints: :class:`Revolute` / :class:`Prismatic` joints.  ground: the fixed link's name.
    crank: the driven link's name; ``pivot`` the name of its point that coincides with a ground
    point of the same name (the crank bearing), ``tip`` a crank point defining the crank angle
    φ = atan2 of (tip − pivot) [rad].

    Raises :class:`LinkageError` for unknown names, a crank pivot off the ground, or a
    joint set that is not square after the crank is driven (Grübler: 3(n − 1) − 2j ≠ 1); pass
    ``allow_redundant=True`` for over- or under-constrained linkages (Gauss–Newton then).
    """

    def __init__(
        self,
        links: Sequence[Link],
        joints: Sequence[Revolute | Prismatic],
        *,
        ground: str = "ground",
        crank: str = "crank",
        pivot: str = "O",
        tip: str = "A",
        name: str = "linkage",
        allow_redundant: bool = False,
    ) -> None:
        self.name = _name(name, "name")
        for what, v in (("ground", ground), ("crank", crank), ("pivot", pivot), ("tip", tip)):
            _name(v, what)
        if not isinstance(allow_redundant, (bool, np.bool_)):
            raise InvalidInputError(f"allow_redundant must be True or False, got {allow_redundant!r}")
        links = _sequence(links, Link, "links")
        self.links = {link.name: link for link in links}
        if len(self.links) != len(links):
            raise LinkageError(f"links: link names must be unique, got {[link.name for link in links]}")
        for n in (ground, crank):
            if n not in self.links:
                raise LinkageError(f"no link {n!r}; links are {list(self.links)}")
        self.ground, self.crank = ground, crank
        self.joints = _sequence(joints, (Revolute, Prismatic), "joints")
        for j in self.joints:
            refs = (
                [j.a, j.b]
                if isinstance(j, Revolute)
                else [j.slider, (j.guide[0], j.guide[1]), (j.guide[0], j.guide[2])]
            )
            for ln, pn in refs:
                if ln not in self.links or pn not in self.links[ln].points:
                    raise LinkageError(f"joint {j} refers to an unknown point {ln}.{pn}")
            if isinstance(j, Prismatic):
                gp = self.links[j.guide[0]].points
                if np.hypot(*np.subtract(gp[j.guide[1]], gp[j.guide[2]])) <= 1e-12:
                    raise LinkageError(
                        f"the guide points {j.guide[1]!r} and {j.guide[2]!r} of link {j.guide[0]!r} coincide: a "
                        "Prismatic guide needs two distinct points (a line)"
                    )
        cp, gp = self.links[crank].points, self.links[ground].points
        if pivot not in cp or pivot not in gp or not np.allclose(cp[pivot], gp[pivot], atol=1e-12):
            raise LinkageError(
                f"the crank pivot {pivot!r} must be a point of both {crank!r} and {ground!r}, at one place"
            )
        if tip not in cp:
            raise LinkageError(f"the crank tip {tip!r} is not a point of {crank!r}")
        self.pivot = np.asarray(cp[pivot], float)
        d = np.asarray(cp[tip], float) - self.pivot
        self.crank_radius = float(np.hypot(*d))
        if not self.crank_radius > 1e-12:
            raise LinkageError(
                f"the crank tip {tip!r} coincides with the pivot {pivot!r}: the crank angle is undefined"
            )
        self.reference_angle = float(np.arctan2(d[1], d[0]))
        self.tip = tip
        self.moving = tuple(n for n in self.links if n not in (ground, crank))
        self.n_unknowns = 3 * len(self.moving)
        self.n_residuals = sum(2 for _ in self.joints)
        self.grubler_dof = 3 * (len(self.links) - 1) - 2 * (len(self.joints) + 1)  # + the crank bearing
        if not allow_redundant and self.n_unknowns != self.n_residuals:
            raise LinkageError(
                f"{name}: {len(self.links)} links and {len(self.joints) + 1} joints (incl. the crank bearing) give "
                f"Grübler mobility {self.grubler_dof}, not 1; pass allow_redundant=True to solve it by Gauss–Newton"
            )
        self.point_names = tuple(f"{ln}.{pn}" for ln, link in self.links.items() for pn in link.points)
        self._lock = threading.Lock()
        self._fns: tuple[ca.Function, ca.Function, ca.Function] | None = None

    # ------------------------------------------------------------------ the CGA graph
    def _motors(self, m: Any, phi: Any) -> dict[str, list[Any]]:
        out: dict[str, list[Any]] = {self.ground: list(IDENTITY)}
        out[self.crank] = rotation_about(self.pivot, phi - self.reference_angle)
        for k, n in enumerate(self.moving):
            out[n] = [m[4 * k + i] for i in range(4)]
        return out

    def _world(self, M: dict[str, list[Any]], ln: str, pn: str) -> tuple[Any, Any]:
        return apply_point(M[ln], self.links[ln].points[pn])

    def residual_expr(self, m: Any, phi: Any) -> list[Any]:
        """The stacked joint residuals (2 per joint) for moving-link motors ``m`` (4 n,) and crank angle φ."""
        M = self._motors(m, phi)
        F: list[Any] = []
        for j in self.joints:
            if isinstance(j, Revolute):
                xa, xb = self._world(M, *j.a), self._world(M, *j.b)
                F += [xa[0] - xb[0], xa[1] - xb[1]]
            else:
                gl, gp, gq = j.guide
                p = np.asarray(self.links[gl].points[gp], float)
                q = np.asarray(self.links[gl].points[gq], float)
                u = (q - p) / np.linalg.norm(q - p)
                n = np.array([-u[1], u[0]])
                # dual line (IPNS) π = n + δ e∞: x·π = n·x − δ, the signed distance
                pi = Multivector.from_names({"e1": n[0], "e2": n[1], "einf": float(n @ p)})
                G = Multivector.from_names({b: M[gl][i] for i, b in enumerate(PLANAR_BLADES)})
                S = Multivector.from_names({b: M[j.slider[0]][i] for i, b in enumerate(PLANAR_BLADES)})
                pw = G * pi * G.reverse()
                x = self._world(M, *j.slider)
                X = Multivector.from_names(
                    {"e0": 1.0, "e1": x[0], "e2": x[1], "einf": 0.5 * (x[0] * x[0] + x[1] * x[1])}
                )
                F += [(X | pw)["1"], (G.reverse() * S)["e12"]]
        return F

    def _functions(self) -> tuple[ca.Function, ca.Function, ca.Function]:
        with self._lock:
            if self._fns is None:
                nm = len(self.moving)
                m = ca.SX.sym("m", 4 * nm)
                xi = ca.SX.sym("xi", 3 * nm)
                phi = ca.SX.sym("phi")
                moved = []
                for k in range(nm):
                    moved += compose(
                        motor_exp([xi[3 * k], xi[3 * k + 1], xi[3 * k + 2]]), [m[4 * k + i] for i in range(4)]
                    )
                mm = ca.vertcat(*moved)
                F = ca.vertcat(*self.residual_expr(mm, phi))
                J = ca.jacobian(F, xi)
                Fphi = ca.jacobian(F, phi)
                zero = ca.DM.zeros(3 * nm)
                F0, J0, Fp0 = (ca.substitute(e, xi, zero) for e in (F, J, Fphi))
                fj = ca.Function("linkage_FJ", [m, phi], [F0, J0, Fp0])
                # retraction: exp(ξ) M, renormalised (c² + s² = 1 is the motor condition in the plane)
                norms = []
                for k in range(nm):
                    c, s = mm[4 * k], mm[4 * k + 1]
                    r = ca.sqrt(c * c + s * s)
                    norms += [mm[4 * k + i] / r for i in range(4)]
                retract = ca.Function("linkage_retract", [m, xi], [ca.vertcat(*norms)])
                M = self._motors(m, phi)
                pts = []
                for ln, link in self.links.items():
                    for pn in link.points:
                        pts += list(self._world(M, ln, pn))
                points = ca.Function("linkage_points", [m, phi], [ca.vertcat(*pts)])
                self._fns = (fj, retract, points)
            return self._fns

    # ------------------------------------------------------------------ numerics
    # ------------------------------------------------------------------ argument checks
    def _motors_arg(self, motors: Any, what: str = "motors") -> np.ndarray:
        """Moving-link motors (4 n,): finite, each with a non-zero rotation part (c, s) (a new array)."""
        m = validation.vector(motors, 4 * len(self.moving), f"{what} (4 planar motor coefficients per moving link)")
        if m.size and float(np.max(np.abs(m))) > MAX_COORDINATE:
            raise InvalidInputError(f"{what} has coefficients beyond ±{MAX_COORDINATE:g}")
        rot = np.hypot(m[0::4], m[1::4])
        bad = np.flatnonzero(~(rot > 1e-12))
        if bad.size:
            raise InvalidInputError(
                f"{what}: the motor of link {self.moving[int(bad[0])]!r} has a zero rotation part (c = s = 0), so it "
                "is no rigid motion; start from identity_motors() or motors_from_points()"
            )
        return m

    @staticmethod
    def _newton_args(tol: Any, max_iter: Any) -> tuple[float, int]:
        t = validation.positive(tol, "tol")
        k = validation.integer(max_iter, "max_iter", minimum=1)
        if k > MAX_NEWTON_ITERATIONS:
            raise InvalidInputError(f"max_iter = {k} is above {MAX_NEWTON_ITERATIONS} Newton iterations")
        return t, k

    def residual(self, motors: np.ndarray, phi: float) -> tuple[np.ndarray, np.ndarray]:
        """F (r,) [m] and J = ∂F/∂ξ (r, 3 n) at moving-link motors ``motors`` (4 n,) and crank angle φ [rad]."""
        m, ph = self._motors_arg(motors), validation.scalar(phi, "phi")
        fj = self._functions()[0]
        F, J, _ = fj(m, ph)
        return np.asarray(F).ravel(), np.asarray(J)

    def positions(self, motors: np.ndarray, phi: float) -> np.ndarray:
        """World positions (P, 2) [m] of every link point (order :attr:`point_names`)."""
        m, ph = self._motors_arg(motors), validation.scalar(phi, "phi")
        return np.asarray(self._functions()[2](m, ph)).reshape(-1, 2)

    def identity_motors(self) -> np.ndarray:
        """The moving links' motors (4 n,) of the reference configuration."""
        return np.tile(np.array(IDENTITY), len(self.moving))

    def motors_from_points(self, guess: Mapping[str, Mapping[str, Sequence[float]]]) -> np.ndarray:
        """Moving-link motors (4 n,) that best place each link's points on ``guess[link][point]``
        (a least-squares rigid fit per link; links absent from ``guess`` stay at the reference)."""
        if not isinstance(guess, Mapping):
            raise InvalidInputError(f"guess must be a dict {{link: {{point: (x, y)}}}} [m], got {guess!r}")
        for ln, pts in guess.items():
            if ln not in self.moving:
                raise InvalidInputError(f"guess: {ln!r} is not a moving link; the moving links are {list(self.moving)}")
            if not isinstance(pts, Mapping) or not pts:
                raise InvalidInputError(f"guess[{ln!r}] must be a non-empty dict {{point: (x, y)}}, got {pts!r}")
            unknown = [k for k in pts if k not in self.links[ln].points]
            if unknown:
                raise InvalidInputError(
                    f"guess[{ln!r}]: unknown point(s) {unknown}; the points of {ln!r} are {list(self.links[ln].points)}"
                )
        out = []
        for n in self.moving:
            if n in guess:
                names = list(guess[n])
                P = np.array([self.links[n].points[k] for k in names], float)
                Q = np.array([_planar_point(guess[n][k], f"guess[{n!r}][{k!r}]") for k in names], float)
                th, t = _kabsch2(P, Q)
                out += list(motor(th, t))
            else:
                out += list(IDENTITY)
        return np.array(out, float)

    def newton(
        self, motors: np.ndarray, phi: float, *, tol: float = 1e-12, max_iter: int = 30
    ) -> tuple[np.ndarray, int, float, bool]:
        """Newton in the Lie algebra from ``motors`` at crank angle φ: (motors, iterations, max|F|, converged)."""
        m = self._motors_arg(motors)
        phi = validation.scalar(phi, "phi")
        tol, max_iter = self._newton_args(tol, max_iter)
        return self._newton(m, phi, tol, max_iter)

    def _newton(self, m: np.ndarray, phi: float, tol: float, max_iter: int) -> tuple[np.ndarray, int, float, bool]:
        fj, retract, _ = self._functions()
        out = fj(m, phi)  # F and J in one call; J of an accepted iterate is reused for the next step
        F = np.asarray(out[0]).ravel()
        J = np.asarray(out[1])
        r = float(np.max(np.abs(F))) if F.size else 0.0
        for it in range(max_iter):
            if r <= tol:
                return m, it, r, True
            if J.shape[0] == J.shape[1]:
                xi = -np.linalg.lstsq(J, F, rcond=None)[0]
            else:
                # redundant (over- or under-constrained): Levenberg–Marquardt with λ = ‖F‖² (Yamashita &
                # Fukushima 2001: quadratic convergence where the residual vanishes), floored for a rank-
                # deficient JᵀJ
                JtJ = J.T @ J
                lam = max(float(F @ F), 1e-14 * float(np.trace(JtJ)))
                xi = -np.linalg.solve(JtJ + lam * np.eye(J.shape[1]), J.T @ F)
            t = 1.0
            for _ in range(12):  # backtracking: never accept a step that increases ‖F‖
                m_new = np.asarray(retract(m, t * xi)).ravel()
                out = fj(m_new, phi)
                F_new = np.asarray(out[0]).ravel()
                if np.linalg.norm(F_new) < np.linalg.norm(F) or np.linalg.norm(F_new) <= tol:
                    break
                t *= 0.5
            else:
                return m, it + 1, r, False
            m, F, J = m_new, F_new, np.asarray(out[1])
            r = float(np.max(np.abs(F)))
        return m, max_iter, r, r <= tol

    def _jacobian_info(self, m: np.ndarray, phi: float) -> tuple[np.ndarray, np.ndarray, float, int]:
        fj = self._functions()[0]
        _, J, Fp = fj(m, phi)
        J = np.asarray(J)
        sv = np.linalg.svd(J, compute_uv=False)
        sign = int(np.sign(np.linalg.det(J))) if J.shape[0] == J.shape[1] else 0
        return J, np.asarray(Fp).ravel(), float(sv.min()) if sv.size else 0.0, sign

    def track(
        self,
        crank_angles: Sequence[float] | np.ndarray,
        motors: np.ndarray | None = None,
        *,
        tol: float = 1e-12,
        max_iter: int = 30,
        guard: bool = True,
        min_step: float = 1e-7,
        max_step: float = np.deg2rad(5.0),
        max_substeps: int = MAX_SUBSTEPS,
    ) -> LinkageMotion:
        """Drive the crank through ``crank_angles`` (T,) [rad] from the assembled ``motors`` (4 n,).

        ``motors`` must satisfy the joints at ``crank_angles[0]`` up to what Newton fixes (default:
        the reference configuration).  ``guard=True`` (default) uses the predictor, adaptive
        substeps of at most ``max_step`` [rad] (halved down to ``min_step`` [rad]) and the branch checks of
        the module docstring; ``guard=False`` is the plain method of seed 004 §3.4 (Newton from the last
        solution at each requested angle, no substeps, no checks) — kept to show its branch jumps.

        Bounded work: a motion that needs more than ``max_substeps`` substeps (the crank range over
        ``max_step``, or the number of angles unguarded) is refused before it starts
        (:class:`~coop_ga.errors.InvalidInputError` naming the range and the limit), and a motion whose
        halved substeps exceed it stops there (``complete=False``, ``message`` says so).
        """
        angles, m = self._track_args(crank_angles, motors)
        tol, max_iter = self._newton_args(tol, max_iter)
        if not isinstance(guard, (bool, np.bool_)):
            raise InvalidInputError(f"guard must be True or False, got {guard!r}")
        min_step = validation.positive(min_step, "min_step [rad]")
        max_step = validation.positive(max_step, "max_step [rad]")
        if min_step > max_step:
            raise InvalidInputError(f"min_step = {min_step:g} rad must be ≤ max_step = {max_step:g} rad")
        max_substeps = validation.integer(max_substeps, "max_substeps", minimum=1)
        with np.errstate(over="ignore"):
            span = float(np.sum(np.abs(np.diff(angles))))
        need = (
            (math.ceil(span / max_step - 1e-9) if math.isfinite(span / max_step) else math.inf)
            if guard
            else angles.size - 1
        )
        if need > max_substeps:
            raise InvalidInputError(
                f"crank_angles span {span:.6g} rad ({span / (2 * math.pi):.4g} turns): "
                + (f"at least {need} substeps of max_step = {max_step:.4g} rad" if guard else f"{need} Newton solves")
                + f", above the limit max_substeps = {max_substeps}; track a shorter range (several calls from the "
                "last motors), or raise max_step or max_substeps"
            )
        rows: dict[str, list[Any]] = {k: [] for k in ("pos", "res", "it", "sub", "smin", "sign", "m")}
        m, it0, r, ok = self._newton(m, float(angles[0]), tol, max_iter)
        if not ok:
            _, _, s0, _ = self._jacobian_info(m, float(angles[0]))
            return self._motion(
                angles,
                rows,
                False,
                float(angles[0]),
                s0,
                f"cannot assemble at φ = {angles[0]:.6g} rad (max|F| = {r:.2e} m)",
            )
        here = self._jacobian_info(m, float(angles[0]))  # J, ∂F/∂φ, σ_min, sign(det J) at the current solution
        self._append(rows, m, float(angles[0]), r, it0, 1, here[2], here[3])
        state = _TrackState(m=m, phi=float(angles[0]), here=here, budget=max_substeps)
        stop: float | None = None
        stop_s: float | None = None
        message = "ok"
        for target in angles[1:]:
            if guard:
                fail = self._guarded_step(state, float(target), tol, max_iter, min_step, max_step)
            else:
                fail = self._plain_step(state, float(target), tol, max_iter)
            if fail is not None:
                stop, stop_s, message = state.phi, fail[0], fail[1]
                break
            self._append(rows, state.m, state.phi, state.r, state.iters, state.subs, state.here[2], state.here[3])
        complete = len(rows["pos"]) == angles.size
        return self._motion(angles, rows, complete, stop, stop_s, message)

    def _track_args(self, crank_angles: Any, motors: Any) -> tuple[np.ndarray, np.ndarray]:
        angles = validation.array(crank_angles, "crank_angles [rad]")
        if angles.ndim != 1 or angles.size == 0:
            raise InvalidInputError(f"crank_angles must be a non-empty 1-D array [rad], got shape {angles.shape}")
        m = self.identity_motors() if motors is None else self._motors_arg(motors)
        return angles, m

    def _plain_step(self, st: _TrackState, target: float, tol: float, max_iter: int) -> tuple[float | None, str] | None:
        """Seed 004 §3.4: Newton from the last solution at the next angle; (σ_min, message) if it fails."""
        st.m, k, st.r, ok = self._newton(st.m, target, tol, max_iter)
        st.iters, st.subs, st.phi = k, 1, target
        if not ok:
            return None, f"Newton did not converge at φ = {st.phi:.6g} rad (max|F| = {st.r:.2e} m)"
        st.here = self._jacobian_info(st.m, st.phi)
        return None

    def _guarded_step(
        self, st: _TrackState, target: float, tol: float, max_iter: int, min_step: float, max_step: float
    ) -> tuple[float | None, str] | None:
        """Predictor–corrector substeps from ``st.phi`` to ``target`` (module docstring); ``st`` is updated in
        place.  None when the target is reached, else (σ_min there, the message of the stop)."""
        st.iters, st.subs = 0, 0
        sign = st.here[3]
        h = float(np.clip(target - st.phi, -max_step, max_step))
        while abs(target - st.phi) > 1e-15:
            if st.budget <= 0:
                return st.here[2], (
                    f"stopped at φ = {st.phi:.8g} rad, {abs(target - st.phi):.4g} rad short of the next angle: the "
                    "substeps (halved near a difficult configuration) reached max_substeps; raise max_substeps"
                )
            st.budget -= 1
            h = float(np.sign(target - st.phi) * min(abs(h), abs(target - st.phi)))
            J, Fp = st.here[0], st.here[1]  # unchanged while a step is halved: computed once per accepted point
            xi_pred = -np.linalg.lstsq(J, Fp * h, rcond=None)[0]
            m_pred = np.asarray(self._functions()[1](st.m, xi_pred)).ravel()
            m_new, k, r, ok = self._newton(m_pred, st.phi + h, tol, max_iter)
            st.iters += k
            if ok:
                # the corrector's size compared with the predictor's: a jump is large
                out2 = self._functions()[0](m_pred, st.phi + h)
                J2, F2 = np.asarray(out2[1]), np.asarray(out2[0]).ravel()
                corr = float(np.linalg.norm(np.linalg.lstsq(J2, F2, rcond=None)[0]))
                pred = float(np.linalg.norm(xi_pred))
                there = self._jacobian_info(m_new, st.phi + h)
                ok = corr <= 0.3 * pred + 1e-9 and (sign == 0 or there[3] == sign)
            if ok:
                st.m, st.phi, st.r, st.subs, st.here = m_new, st.phi + h, r, st.subs + 1, there
                sign = there[3]
                h = float(np.sign(h) * min(2.0 * abs(h), max_step))
                continue
            h *= 0.5
            if abs(h) < min_step:
                s_stop = st.here[2]
                # σ_min of a fold behaves like √(distance to it): ~1e-4 at min_step = 1e-7 rad
                kind = (
                    "a toggle (dead-centre) position: the constraint Jacobian is singular there"
                    if s_stop < 1e-3
                    else "Newton fails although the Jacobian is regular (try a smaller min_step)"
                )
                return s_stop, (
                    f"the crank cannot pass φ = {st.phi:.8g} rad ({np.rad2deg(st.phi):.4f}°): smallest singular value "
                    f"of the constraint Jacobian {s_stop:.2e}, {kind}"
                )
        return None

    def _append(
        self, rows: dict[str, list[Any]], m: np.ndarray, phi: float, r: float, it: int, sub: int, smin: float, sign: int
    ) -> None:
        rows["pos"].append(self.positions(m, phi))
        rows["res"].append(r)
        rows["it"].append(it)
        rows["sub"].append(sub)
        rows["smin"].append(smin)
        rows["sign"].append(sign)
        rows["m"].append(m.copy())

    def _motion(
        self,
        angles: np.ndarray,
        rows: dict[str, list[Any]],
        complete: bool,
        stop: float | None,
        stop_s: float | None,
        message: str,
    ) -> LinkageMotion:
        T = len(rows["pos"])
        P = len(self.point_names)
        return LinkageMotion(
            crank_angles=angles[:T].copy(),
            points=np.array(rows["pos"]).reshape(T, P, 2),
            point_names=self.point_names,
            residual=np.array(rows["res"], float),
            iterations=np.array(rows["it"], int),
            substeps=np.array(rows["sub"], int),
            sigma_min=np.array(rows["smin"], float),
            det_sign=np.array(rows["sign"], int),
            motors=np.array(rows["m"]).reshape(T, 4 * len(self.moving)),  # (T = 0: cannot assemble at the start)
            complete=complete,
            requested=int(angles.size),
            stop_angle=stop,
            stop_sigma_min=stop_s,
            message=message,
        )
