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

import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from ..algebra.multivector import Multivector
from ..errors import CoopGAError, InvalidInputError
from .planar import PLANAR_BLADES, apply_point, compose, motor, motor_exp, rotation_about

__all__ = ["Link", "Linkage", "LinkageError", "LinkageMotion", "Prismatic", "Revolute"]

IDENTITY = (1.0, 0.0, 0.0, 0.0)


class LinkageError(CoopGAError, ValueError):
    """A linkage is ill-formed, or cannot be assembled at a crank angle (message says where)."""


@dataclass(frozen=True)
class Link:
    """A rigid link: ``points`` maps names to planar points (2,) [m], world frame at the reference."""

    name: str
    points: Mapping[str, Any]


@dataclass(frozen=True)
class Revolute:
    """Link points ``a = (link, point)`` and ``b = (link, point)`` coincide."""

    a: tuple[str, str]
    b: tuple[str, str]


@dataclass(frozen=True)
class Prismatic:
    """Point ``slider = (link, point)`` slides on the line through ``guide = (link, p, q)``, the
    slider link keeping its orientation relative to the guide link."""

    slider: tuple[str, str]
    guide: tuple[str, str, str]


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
        try:
            return self.points[:, self.point_names.index(name)]
        except ValueError:
            raise InvalidInputError(f"no point {name!r}; the points are {list(self.point_names)}") from None


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
        self.name = name
        self.links = {link.name: link for link in links}
        if len(self.links) != len(links):
            raise LinkageError("link names must be unique")
        for n in (ground, crank):
            if n not in self.links:
                raise LinkageError(f"no link {n!r}; links are {list(self.links)}")
        self.ground, self.crank = ground, crank
        self.joints = tuple(joints)
        for j in self.joints:
            refs = (
                [j.a, j.b]
                if isinstance(j, Revolute)
                else [j.slider, (j.guide[0], j.guide[1]), (j.guide[0], j.guide[2])]
            )
            for ln, pn in refs:
                if ln not in self.links or pn not in self.links[ln].points:
                    raise LinkageError(f"joint {j} refers to an unknown point {ln}.{pn}")
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
    def residual(self, motors: np.ndarray, phi: float) -> tuple[np.ndarray, np.ndarray]:
        """F (r,) [m] and J = ∂F/∂ξ (r, 3 n) at moving-link motors ``motors`` (4 n,) and crank angle φ [rad]."""
        fj = self._functions()[0]
        F, J, _ = fj(motors, phi)
        return np.asarray(F).ravel(), np.asarray(J)

    def positions(self, motors: np.ndarray, phi: float) -> np.ndarray:
        """World positions (P, 2) [m] of every link point (order :attr:`point_names`)."""
        return np.asarray(self._functions()[2](motors, phi)).reshape(-1, 2)

    def identity_motors(self) -> np.ndarray:
        """The moving links' motors (4 n,) of the reference configuration."""
        return np.tile(np.array(IDENTITY), len(self.moving))

    def motors_from_points(self, guess: Mapping[str, Mapping[str, Sequence[float]]]) -> np.ndarray:
        """Moving-link motors (4 n,) that best place each link's points on ``guess[link][point]``
        (a least-squares rigid fit per link; links absent from ``guess`` stay at the reference)."""
        out = []
        for n in self.moving:
            if n in guess:
                names = list(guess[n])
                P = np.array([self.links[n].points[k] for k in names], float)
                Q = np.array([guess[n][k] for k in names], float)
                th, t = _kabsch2(P, Q)
                out += list(motor(th, t))
            else:
                out += list(IDENTITY)
        return np.array(out, float)

    def newton(
        self, motors: np.ndarray, phi: float, *, tol: float = 1e-12, max_iter: int = 30
    ) -> tuple[np.ndarray, int, float, bool]:
        """Newton in the Lie algebra from ``motors`` at crank angle φ: (motors, iterations, max|F|, converged)."""
        fj, retract, _ = self._functions()
        m = np.asarray(motors, float).copy()
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
    ) -> LinkageMotion:
        """Drive the crank through ``crank_angles`` (T,) [rad] from the assembled ``motors`` (4 n,).

        ``motors`` must satisfy the joints at ``crank_angles[0]`` up to what Newton fixes (default:
        the reference configuration).  ``guard=True`` (default) uses the predictor, adaptive
        substeps of at most ``max_step`` and the branch checks of the module docstring;
        ``guard=False`` is the plain method of seed 004 §3.4 (Newton from the last solution at
        each requested angle, no substeps, no checks) — kept to show its branch jumps.
        """
        angles = np.asarray(crank_angles, float).ravel()
        if angles.size == 0 or not np.all(np.isfinite(angles)):
            raise InvalidInputError("crank_angles must be a non-empty finite array [rad]")
        m = self.identity_motors() if motors is None else np.asarray(motors, float).copy()
        if m.shape != (4 * len(self.moving),):
            raise InvalidInputError(f"motors must have shape ({4 * len(self.moving)},), got {m.shape}")
        rows: dict[str, list[Any]] = {k: [] for k in ("pos", "res", "it", "sub", "smin", "sign", "m")}
        m, it0, r, ok = self.newton(m, float(angles[0]), tol=tol, max_iter=max_iter)
        stop: float | None = None
        stop_s: float | None = None
        message = "ok"
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
        smin, sign = here[2], here[3]
        self._append(rows, m, float(angles[0]), r, it0, 1, smin, sign)
        phi = float(angles[0])
        for target in angles[1:]:
            iters, subs = 0, 0
            if not guard:
                m, k, r, ok = self.newton(m, float(target), tol=tol, max_iter=max_iter)
                iters, subs, phi = k, 1, float(target)
                if not ok:
                    stop, message = phi, f"Newton did not converge at φ = {phi:.6g} rad (max|F| = {r:.2e} m)"
                    break
                here = self._jacobian_info(m, phi)
                smin, sign = here[2], here[3]
                self._append(rows, m, phi, r, iters, subs, smin, sign)
                continue
            h = float(np.clip(target - phi, -max_step, max_step))
            failed = False
            while abs(target - phi) > 1e-15:
                h = float(np.sign(target - phi) * min(abs(h), abs(target - phi)))
                J, Fp = here[0], here[1]  # unchanged while a step is halved: computed once per accepted point
                xi_pred = -np.linalg.lstsq(J, Fp * h, rcond=None)[0]
                m_pred = np.asarray(self._functions()[1](m, xi_pred)).ravel()
                m_new, k, r, ok = self.newton(m_pred, phi + h, tol=tol, max_iter=max_iter)
                iters += k
                accept = ok
                if accept:
                    # the corrector's size compared with the predictor's: a jump is large
                    out2 = self._functions()[0](m_pred, phi + h)
                    J2, F2 = np.asarray(out2[1]), np.asarray(out2[0]).ravel()
                    corr = float(np.linalg.norm(np.linalg.lstsq(J2, F2, rcond=None)[0]))
                    pred = float(np.linalg.norm(xi_pred))
                    there = self._jacobian_info(m_new, phi + h)
                    accept = corr <= 0.3 * pred + 1e-9 and (sign == 0 or there[3] == sign)
                if accept:
                    m, phi, subs = m_new, phi + h, subs + 1
                    here = there
                    smin, sign = here[2], here[3]
                    h = float(np.sign(h) * min(2.0 * abs(h), max_step))
                else:
                    h *= 0.5
                    if abs(h) < min_step:
                        failed = True
                        break
            if failed:
                s_stop = here[2]
                stop, stop_s = phi, s_stop
                # σ_min of a fold behaves like √(distance to it): ~1e-4 at min_step = 1e-7 rad
                kind = (
                    "a toggle (dead-centre) position: the constraint Jacobian is singular there"
                    if s_stop < 1e-3
                    else "Newton fails although the Jacobian is regular (try a smaller min_step)"
                )
                message = (
                    f"the crank cannot pass φ = {phi:.8g} rad ({np.rad2deg(phi):.4f}°): smallest singular value of the "
                    f"constraint Jacobian {s_stop:.2e}, {kind}"
                )
                break
            self._append(rows, m, phi, r, iters, subs, smin, sign)
        complete = len(rows["pos"]) == angles.size
        return self._motion(angles, rows, complete, stop, stop_s, message)

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
            motors=np.array(rows["m"]).reshape(T, -1),
            complete=complete,
            requested=int(angles.size),
            stop_angle=stop,
            stop_sigma_min=stop_s,
            message=message,
        )
