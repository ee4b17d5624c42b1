"""Regions over a cooperative primitive's natural coordinates, with residuals and exact Jacobians w.r.t. q.

A target similarity V_Sd is a point; a cooperative task is often a *set*: "the box's centre anywhere in this
box, its normal within 10° of vertical", "the grasp rigid while carrying".  A :class:`Region` is interval
bounds over the coordinates every primitive kind has (:data:`~coop_ga.geometry.kinds.KIND_SPECS`), read in a
frame the user gives (``frame``: world ← region, a 4×4 homogeneous transform):

=================  =====================================================  ===================================
coordinate         what                                                   kinds
=================  =====================================================  ===================================
centre x (3,)      the centre (point, point pair, circle, sphere) or, for  every kind
                   a flat, its point closest to the frame's origin [m]
angle θ (1,)       angle of the axis (direction / normal) from the cone     point pair, line, circle, plane
                   axis ``a`` (region frame) [rad], bound ``[0, θ_max]``
log-scale β (1,)   log of the radius (β = log r, r in metres)              point pair, circle, sphere
=================  =====================================================  ===================================

Read-out and its exact Jacobian through J^G
-------------------------------------------
The compiled task returns, in one call, ``B = log V_Sc = [θ12, θ13, θ23, β, t1, t2, t3]`` and J^G (7×nq,
body frame, Eq 30).  Its chart is the product of exponentials ``V_Sc = T(t) R(θ) D(β)`` (Eq 74–76), so the
read-outs are exact functions of B: the centre (or a flat's point closest to the world origin) ``c = t``,
the radius ``r = e^β`` (1 for kinds without one), the rotation R of the axis-angle vector
``ω = (θ23, −θ13, θ12)``, and the axis ``o = R u`` with u the unit primitive's axis.  A body velocity
``b = J^G q̇`` moves ``V ← V exp(b dt)``, i.e. ``T(c) R D · T(t_b) R(ω_b) D(β_b)``, hence

    ċ = r R t_b,       ȯ = R (ω_b × u),       β̇ = β_b                                                   (R1)

with ``ω_b = (b_23, −b_13, b_12)``: three matrix products per evaluation on top of the compiled J^G, no
finite differences and no decomposition of the versor.  A flat's centre is moved to the point closest to
the frame's origin p0 by the chain rule (plane: ``x = p0 − ((p0 − c)·o) o``; line: ``x = c + ((p0 − c)·o) o``).
Checked against central finite differences for every kind in ``tests/plan/test_regions.py``, and the
read-outs against :func:`~coop_ga.geometry.similarity.primitive_parameters` of the task's primitive.

Residuals
---------
* :class:`Region` (``residual``): ``x − clip(x, lower, upper)``, ``max(θ − θ_max, 0)``,
  ``β − clip(β, lower, upper)``: zero inside, the distance to the bounds outside (a Task Space Region's
  displacement); its Jacobian has the rows of the coordinates outside their bounds.
* :class:`RegionTarget` (``region.target(sample)``): equality to one sampled coordinate tuple
  (``x − x*``, ``o − o*`` in the frame, ``β − β*``) — what a goal sampler projects onto.
* :class:`RigidGrasp`: the rigid grasp of a carried object — the end points' mutual distances held at their
  values at a reference configuration (a rigid triangle for three points, tetrahedron for four; for more, each
  point tied to three earlier ones), or only the scale (``mode="scale"``: ``β − β_ref``, one row, through
  J^G).  End-point Jacobians come from Pinocchio (``LOCAL_WORLD_ALIGNED``).
* :class:`Stack`: residuals stacked (a path constraint and a goal target projected together).

Every residual has ``dim`` rows and ``evaluate(q) → (r (dim,), J (dim, nv))``: q has nq entries and J one
column per velocity, nv (= nq without a free flyer; with one, J^G and Pinocchio's Jacobians are along
Pinocchio's LOCAL base velocity, i.e. along ``q ⊕ v``, :meth:`~coop_ga.systems.System.integrate`).  Degenerate end points raise
the task's :class:`~coop_ga.errors.DegeneratePrimitiveError` (never NaN).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from .. import validation
from ..errors import InvalidInputError

__all__ = [
    "EndPoints",
    "Readout",
    "Region",
    "RegionSample",
    "RegionTarget",
    "Residual",
    "RigidGrasp",
    "Stack",
    "finite_difference_jacobian",
    "readout",
]


class Residual(Protocol):
    """A vector function of q (nq,) with its Jacobian along ``q ⊕ v``: ``dim`` rows, ``nv`` columns."""

    dim: int
    nq: int

    def evaluate(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(r (dim,), ∂r/∂v (dim, nv))`` at q (nq,) (∂r/∂q when nq = nv)."""
        ...


@dataclass(frozen=True)
class Readout:
    """The natural coordinates of a cooperative primitive at q and their Jacobians (world frame).

    centre: (3,) [m] c (a flat's point closest to the world origin); d_centre (3, nq).
    axis: (3,) unit direction / normal, or None; d_axis (3, nq) or None.
    log_scale: β = log r, or None (kinds without a radius); d_log_scale (nq,) or None.
    rotation: (3, 3) R of V_Sc; radius: r (1 for kinds without one).
    """

    centre: np.ndarray
    d_centre: np.ndarray
    axis: np.ndarray | None
    d_axis: np.ndarray | None
    log_scale: float | None
    d_log_scale: np.ndarray | None
    rotation: np.ndarray
    radius: float


def _rotation(w: np.ndarray) -> np.ndarray:
    """Rotation matrix of the axis-angle vector w (3,) (Rodrigues; series below 1e-8 rad)."""
    a = float(math.sqrt(w @ w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if a < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + (math.sin(a) / a) * K + ((1.0 - math.cos(a)) / (a * a)) * (K @ K)


def readout(task: Any, q: np.ndarray) -> Readout:
    """Centre, axis and log-scale of ``task``'s primitive at q (nq,) with their exact Jacobians (R1)."""
    _, B, J = task.evaluate_views(q)
    B = B.reshape(-1)
    spec = task.spec
    R = _rotation(np.array([B[2], -B[1], B[0]]))
    has_r = spec.has_radius
    r = math.exp(float(B[3])) if has_r else 1.0
    c = np.array(B[4:7], dtype=float)
    dc = (r * R) @ J[4:7]
    o = do = None
    if spec.axis is not None:
        u = np.asarray(spec.axis, dtype=float)
        o = R @ u
        w0, w1, w2 = J[2], -J[1], J[0]  # ω_b per joint (rows)
        do = R @ np.vstack((w1 * u[2] - w2 * u[1], w2 * u[0] - w0 * u[2], w0 * u[1] - w1 * u[0]))  # ω_b × u
    beta = float(B[3]) if has_r else None
    dbeta = np.array(J[3], dtype=float) if has_r else None
    return Readout(c, dc, o, do, beta, dbeta, R, r)


def _frame(frame: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(R (3,3), p (3,))`` of a 4×4 homogeneous transform world ← region (None: identity)."""
    if frame is None:
        return np.eye(3), np.zeros(3)
    H = validation.array(frame, "frame", shape=(4, 4))
    R, p = H[:3, :3], H[:3, 3]
    if (
        not np.allclose(R.T @ R, np.eye(3), atol=1e-9)
        or not np.linalg.det(R) > 0
        or not np.allclose(H[3], [0, 0, 0, 1])
    ):
        raise InvalidInputError(
            "frame must be a 4×4 homogeneous transform with a rotation block (orthonormal, det +1) and last "
            f"row (0, 0, 0, 1), got {np.round(H, 4).tolist()}"
        )
    return R.copy(), p.copy()


def _interval(lo: Any, hi: Any, n: int, what: str) -> tuple[np.ndarray, np.ndarray]:
    lo_a = np.broadcast_to(np.asarray(lo, dtype=float), (n,)).copy()
    hi_a = np.broadcast_to(np.asarray(hi, dtype=float), (n,)).copy()
    if np.any(np.isnan(lo_a)) or np.any(np.isnan(hi_a)) or np.any(lo_a > hi_a):
        raise InvalidInputError(
            f"{what}: need lower ≤ upper (±inf for unbounded), got {lo_a.tolist()}, {hi_a.tolist()}"
        )
    return lo_a, hi_a


@dataclass(frozen=True)
class RegionSample:
    """One point of a region: centre (3,) [m] and axis (3,) (unit, or None) in the region frame, log-scale
    β (or None)."""

    centre: np.ndarray
    axis: np.ndarray | None
    log_scale: float | None


class Region:
    """Interval bounds over the natural coordinates of ``task``'s primitive, in ``frame`` (module docstring).

    Args:
        task: a :class:`~coop_ga.cooperative.CooperativeTask` (any kind).
        centre_lower: (3,) or scalar lower bound of the centre in the region frame [m] (−inf: free).
        centre_upper: (3,) or scalar upper bound of the centre in the region frame [m] (+inf: free).
        cone_axis: (3,) axis of the orientation cone in the region frame (kinds with an axis), or None (free).
        cone_angle: half-angle θ_max of the cone [rad], in (0, π].
        log_scale: ``(lower, upper)`` of β = log r (kinds with a radius), or None (free).
        frame: 4×4 homogeneous transform world ← region (None: the world frame).
    """

    def __init__(
        self,
        task: Any,
        centre_lower: Any = -np.inf,
        centre_upper: Any = np.inf,
        *,
        cone_axis: Any = None,
        cone_angle: float = math.pi,
        log_scale: tuple[float, float] | None = None,
        frame: Any = None,
    ) -> None:
        self.task = task
        self.nq, self.nv = int(task.nq), int(task.system.nv)
        spec = task.spec
        self.R, self.p = _frame(frame)
        self.lower, self.upper = _interval(centre_lower, centre_upper, 3, "centre bounds [m]")
        self.cone_axis: np.ndarray | None = None
        self.cone_angle = validation.scalar(cone_angle, "cone_angle [rad]", low=0.0, high=math.pi, low_open=True)
        if cone_axis is not None:
            if spec.axis is None:
                raise InvalidInputError(f"a {task.kind} has no axis: leave cone_axis None")
            a = validation.vector(cone_axis, 3, "cone_axis")
            if not np.linalg.norm(a) > 0:
                raise InvalidInputError("cone_axis must be a non-zero 3-vector")
            self.cone_axis = a / np.linalg.norm(a)
        self.beta: tuple[float, float] | None = None
        if log_scale is not None:
            if not spec.has_radius:
                raise InvalidInputError(f"a {task.kind} has no radius: leave log_scale None")
            lo, hi = _interval(log_scale[0], log_scale[1], 1, "log_scale bounds")
            self.beta = (float(lo[0]), float(hi[0]))
        self.dim = 3 + (self.cone_axis is not None) + (self.beta is not None)

    # ------------------------------------------------------------------ coordinates
    def coordinates(self, q: Any) -> tuple[Readout, np.ndarray, np.ndarray]:
        """``(readout, x (3,), ∂x/∂q (3, nq))``: the read-out and the centre in the region frame (a flat's
        point closest to the frame's origin)."""
        qv = validation.configuration(q, self.nq, "q")
        ro = readout(self.task, qv)
        c, dc = ro.centre, ro.d_centre
        if self.task.spec.flat:
            assert ro.axis is not None and ro.d_axis is not None  # flats have an axis
            o, do = ro.axis, ro.d_axis
            d = self.p - c
            s = float(d @ o)
            ds = -o @ dc + d @ do
            if self.task.spec.axis_role == "normal":  # plane: x = p0 − s o
                c = self.p - s * o
                dc = -np.outer(o, ds) - s * do
            else:  # line: x = c + s o
                c = c + s * o
                dc = dc + np.outer(o, ds) + s * do
        return ro, self.R.T @ (c - self.p), self.R.T @ dc

    def _angle(self, ro: Readout) -> tuple[float, np.ndarray]:
        assert self.cone_axis is not None and ro.axis is not None and ro.d_axis is not None
        a = self.R @ self.cone_axis
        cos = float(np.clip(a @ ro.axis, -1.0, 1.0))
        o = ro.axis
        sin = math.sqrt(
            (a[1] * o[2] - a[2] * o[1]) ** 2 + (a[2] * o[0] - a[0] * o[2]) ** 2 + (a[0] * o[1] - a[1] * o[0]) ** 2
        )
        theta = math.atan2(sin, cos)
        return theta, -(a @ ro.d_axis) / max(sin, 1e-12)

    # ------------------------------------------------------------------ residual
    def evaluate(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """The region residual (dim,) — zero inside, the distance beyond each bound outside — and its exact
        Jacobian (dim, nq) (rows of the coordinates inside their bounds are zero)."""
        ro, x, dx = self.coordinates(q)
        r = np.zeros(self.dim)
        J = np.zeros((self.dim, self.nv))
        xc = np.clip(x, self.lower, self.upper)
        r[:3] = x - xc
        out = x != xc
        J[:3][out] = dx[out]
        k = 3
        if self.cone_axis is not None:
            theta, dtheta = self._angle(ro)
            if theta > self.cone_angle:
                r[k], J[k] = theta - self.cone_angle, dtheta
            k += 1
        if self.beta is not None:
            assert ro.log_scale is not None and ro.d_log_scale is not None
            b = min(max(ro.log_scale, self.beta[0]), self.beta[1])
            if b != ro.log_scale:
                r[k], J[k] = ro.log_scale - b, ro.d_log_scale
        return r, J

    def distance(self, q: Any) -> float:
        """‖residual‖ at q: metres, radians and log-scale in one Euclidean norm (0 inside)."""
        return float(np.linalg.norm(self.evaluate(q)[0]))

    def contains(self, q: Any, tol: float = 1e-9) -> bool:
        """Whether q's primitive lies in the region (every coordinate within ``tol`` of its bounds)."""
        return bool(np.max(np.abs(self.evaluate(q)[0]), initial=0.0) <= tol)

    # ------------------------------------------------------------------ sampling
    def sample(self, rng: np.random.Generator, tries: int = 100) -> RegionSample:
        """A random point of the region: centre uniform in its box, axis uniform on the cone's cap, log-scale
        uniform in its interval (every bounded coordinate must be finite).

        A flat's centre is its point closest to the frame's origin, so it is tied to its axis (a line's lies
        ⟂ to its direction, a plane's along its normal): the sampled centre is projected accordingly, and a
        sample whose projected centre leaves the box is drawn again (up to ``tries`` times; then
        :class:`~coop_ga.errors.InvalidInputError`: the box and the cone hardly intersect)."""
        if not (np.all(np.isfinite(self.lower)) and np.all(np.isfinite(self.upper))):
            raise InvalidInputError("sample() needs finite centre bounds; give centre_lower and centre_upper")
        spec = self.task.spec
        for _ in range(tries):
            x = rng.uniform(self.lower, self.upper)
            o = None if self.cone_axis is None else self._cone_sample(rng)
            if spec.flat and o is not None:
                x = x - (x @ o) * o if spec.axis_role == "direction" else (x @ o) * o
                if np.any(x < self.lower - 1e-12) or np.any(x > self.upper + 1e-12):
                    continue
            b = None if self.beta is None else float(rng.uniform(*self.beta))
            return RegionSample(x, o, b)
        raise InvalidInputError(
            f"no consistent {self.task.kind} in the region after {tries} samples: a flat's closest point to the "
            "frame's origin is tied to its axis; widen the centre bounds or the cone"
        )

    def _cone_sample(self, rng: np.random.Generator) -> np.ndarray:
        """A direction uniform on the cap of the cone (region frame)."""
        assert self.cone_axis is not None
        z = rng.uniform(math.cos(self.cone_angle), 1.0)
        phi = rng.uniform(0.0, 2.0 * math.pi)
        s = math.sqrt(max(1.0 - z * z, 0.0))
        a = self.cone_axis
        e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        return z * a + s * (math.cos(phi) * e1 + math.sin(phi) * e2)

    def target(self, sample: RegionSample) -> RegionTarget:
        """The equality residual to ``sample`` (a goal sampler's projection target)."""
        return RegionTarget(self, sample)


class RegionTarget:
    """Equality to one point of a region: ``[x − x*, o_F − o*, β − β*]`` (the coordinates the region bounds;
    ``o_F`` the axis in the region frame, three rows of rank 2)."""

    def __init__(self, region: Region, sample: RegionSample) -> None:
        self.region, self.sample, self.nq, self.nv = region, sample, region.nq, region.nv
        self.use_axis = region.cone_axis is not None and sample.axis is not None
        self.use_beta = region.beta is not None and sample.log_scale is not None
        self.dim = 3 + 3 * self.use_axis + self.use_beta

    def evaluate(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(r (dim,), J (dim, nq))`` of the equality."""
        ro, x, dx = self.region.coordinates(q)
        rs, Js = [x - self.sample.centre], [dx]
        if self.use_axis:
            assert ro.axis is not None and ro.d_axis is not None and self.sample.axis is not None
            Rt = self.region.R.T
            rs.append(Rt @ ro.axis - self.sample.axis)
            Js.append(Rt @ ro.d_axis)
        if self.use_beta:
            assert ro.log_scale is not None and ro.d_log_scale is not None and self.sample.log_scale is not None
            rs.append(np.array([ro.log_scale - self.sample.log_scale]))
            Js.append(ro.d_log_scale[None, :])
        return np.concatenate(rs), np.vstack(Js)


def _rigid_pairs(n: int) -> tuple[tuple[int, int], ...]:
    """Pairs that make n points a rigid body: all of them for n ≤ 4, else each point tied to three earlier
    ones (3n − 6 independent distances)."""
    return tuple((j, i) for i in range(1, n) for j in range(max(0, i - 3), i))


class EndPoints:
    """The end points of ``frames`` of ``system`` by Pinocchio: ``(P (n, 3) [m], [J_i (3, nq)])`` world frame
    (``LOCAL_WORLD_ALIGNED``; the Jacobians only when asked).  One Pinocchio data per object (not shared
    between threads)."""

    def __init__(self, system: Any, frames: Sequence[str]) -> None:
        import pinocchio as pin

        self._pin, self._model = pin, system.model
        self._data = self._model.createData()
        self._fids = [self._model.getFrameId(f) for f in frames]

    def __call__(self, q: np.ndarray, jacobians: bool = False) -> tuple[np.ndarray, list[np.ndarray]]:
        pin, model, data = self._pin, self._model, self._data
        if jacobians:
            pin.computeJointJacobians(model, data, q)
        else:
            pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        P = np.array([data.oMf[f].translation for f in self._fids])
        if not jacobians:
            return P, []
        return P, [pin.getFrameJacobian(model, data, f, pin.LOCAL_WORLD_ALIGNED)[:3] for f in self._fids]


class RigidGrasp:
    """The rigid grasp of a carried object as an equality path constraint (module docstring).

    Args:
        task: the cooperative task whose end points hold the object.
        q_ref: (nq,) the grasp configuration; its distances (or scale) are held.
        mode: ``"distances"`` (default; the end points' mutual distances, :func:`_rigid_pairs`) or ``"scale"``
            (β = log r only; kinds with a radius).
    """

    def __init__(self, task: Any, q_ref: Any, mode: str = "distances") -> None:
        self.task, self.nq, self.nv = task, int(task.nq), int(task.system.nv)
        self.mode = validation.choice(mode, ("distances", "scale"), "mode")
        q0 = validation.configuration(q_ref, self.nq, "q_ref")
        self.end_points = EndPoints(task.system, task.end_frames)
        if self.mode == "scale":
            if not task.spec.has_radius:
                raise InvalidInputError(f"a {task.kind} has no scale: use mode='distances'")
            self.pairs: tuple[tuple[int, int], ...] = ()
            self.reference = np.array([float(readout(task, q0).log_scale)])  # type: ignore[arg-type]
        else:
            self.pairs = _rigid_pairs(len(task.end_frames))
            if not self.pairs:
                raise InvalidInputError(f"a {task.kind} task has one end point: no grasp distances to hold")
            self.reference = self._distances(q0)[0]
        self.dim = len(self.reference)

    def points(self, q: np.ndarray, jacobians: bool = False) -> tuple[np.ndarray, list[np.ndarray]]:
        """End points (n, 3) [m] and, with ``jacobians``, their (3, nq) world Jacobians (:class:`EndPoints`)."""
        return self.end_points(q, jacobians)

    def _distances(self, q: np.ndarray, jacobian: bool = False) -> tuple[np.ndarray, np.ndarray]:
        P, Js = self.points(q, jacobian)
        d = np.empty(len(self.pairs))
        J = np.zeros((len(self.pairs), self.nv))
        for k, (i, j) in enumerate(self.pairs):
            v = P[i] - P[j]
            d[k] = float(np.linalg.norm(v))
            if jacobian:
                J[k] = (v / d[k]) @ (Js[i] - Js[j])
        return d, J

    def value(self, q: Any) -> np.ndarray:
        """The residual alone (dim,) (no Jacobian: one forward kinematics)."""
        if self.mode == "scale":
            return self.evaluate(q)[0]
        qv = validation.configuration(q, self.nq, "q")
        self.task.evaluate_views(qv)  # the degeneracy guard
        return self._distances(qv, False)[0] - self.reference

    def evaluate(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(r (dim,), J (dim, nq))``: distances (or log-scale) minus their reference values."""
        qv = validation.configuration(q, self.nq, "q")
        if self.mode == "scale":
            ro = readout(self.task, qv)
            assert ro.log_scale is not None and ro.d_log_scale is not None
            return np.array([ro.log_scale]) - self.reference, ro.d_log_scale[None, :].copy()
        self.task.evaluate_views(qv)  # the degeneracy guard of the task holds on the path too
        d, J = self._distances(qv, True)
        return d - self.reference, J


class Stack:
    """Residuals stacked row-wise (same nq)."""

    def __init__(self, parts: Sequence[Any]) -> None:
        if not parts:
            raise InvalidInputError("Stack needs at least one residual")
        self.parts = tuple(parts)
        self.nq = int(self.parts[0].nq)
        self.nv = int(getattr(self.parts[0], "nv", self.nq))
        if any(int(p.nq) != self.nq or int(getattr(p, "nv", p.nq)) != self.nv for p in self.parts):
            raise InvalidInputError(f"Stack: residuals of different nq {[p.nq for p in self.parts]}")
        self.dim = sum(int(p.dim) for p in self.parts)

    def value(self, q: Any) -> np.ndarray:
        """The stacked residuals alone."""
        return np.concatenate([p.value(q) if hasattr(p, "value") else p.evaluate(q)[0] for p in self.parts])

    def evaluate(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(r, J)`` of every part, stacked."""
        out = [p.evaluate(q) for p in self.parts]
        return np.concatenate([r for r, _ in out]), np.vstack([J for _, J in out])


def finite_difference_jacobian(
    residual: Any, q: Any, h: float = 1e-6, central: bool = False, system: Any = None
) -> np.ndarray:
    """∂r/∂q (dim, nq) by forward (or central) differences of ``residual.evaluate`` — the reference and the
    ablation of the exact Jacobian (``nq`` or ``2 nq`` extra evaluations).  A residual of a free flyer
    (``nv ≠ nq``) needs its ``system``: the differences are then along ``q ⊕ (±h e_i)`` (nv columns)."""
    qv = validation.configuration(q, residual.nq, "q")
    nv = int(getattr(residual, "nv", residual.nq))
    if nv != residual.nq:
        if system is None or int(system.nv) != nv:
            raise InvalidInputError(
                f"the residual has nq = {residual.nq}, nv = {nv} (a free flyer): pass its system= so that the "
                "differences move q by system.integrate"
            )
        r0 = residual.evaluate(qv)[0]
        step = [system.integrate(qv, h * e) for e in np.eye(nv)]
        if central:
            back = [system.integrate(qv, -h * e) for e in np.eye(nv)]
            return np.array(
                [(residual.evaluate(a)[0] - residual.evaluate(b)[0]) / (2 * h) for a, b in zip(step, back)]
            ).T
        return np.array([(residual.evaluate(a)[0] - r0) / h for a in step]).T
    r0 = residual.evaluate(qv)[0]
    J = np.empty((len(r0), len(qv)))
    for i in range(len(qv)):
        e = np.zeros(len(qv))
        e[i] = h
        if central:
            J[:, i] = (residual.evaluate(qv + e)[0] - residual.evaluate(qv - e)[0]) / (2 * h)
        else:
            J[:, i] = (residual.evaluate(qv + e)[0] - r0) / h
    return J
