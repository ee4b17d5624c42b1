"""Clearances of a multi-chain system: every capsule against every obstacle, and against the other
capsules, with their Jacobians w.r.t. q, on numpy (fast, for a controller loop) and CasADi (exact AD).

:class:`CollisionModel` holds a :class:`~coop_ga.systems.System`, its capsules
(:func:`~coop_ga.collision.capsules.fit_capsules` by default) and obstacles
(:class:`~coop_ga.collision.distance.Sphere` / :class:`~coop_ga.collision.distance.Plane`, or
anything :func:`~coop_ga.collision.distance.as_obstacle` accepts).  Its distances, in this order:

1. **capsule–obstacle**, obstacle-major: for obstacle k, every capsule (label
   ``"<link> – sphere k"`` / ``"<link> – plane k"``, or the obstacle's name);
2. **capsule–capsule** (``self_collision=True``; label ``"<link A> – <link B>"``), all pairs except
   * two capsules on the *same rigid body* (same parent joint, or both fixed to the world): their
     distance is constant — always excluded;
   * pairs the robot's SRDF disables (``srdf=True``: ``<disable_collisions>`` of the SRDF next to
     each robot's URDF, e.g. example-robot-data's ``panda.srdf``: "Adjacent", "Never" and
     "Default" pairs such as Panda link5–link7, whose capsules are 5 mm apart at q0 and touch
     as soon as the wrist bends);
   * *adjacent* bodies (``exclude_adjacent=True``): one body is the direct kinematic parent of
     the other — they share a joint (Panda link3–link4, link6–hand, link0–link1) and their
     capsules overlap at the joint by construction.  An arm's world-fixed base is adjacent only
     to the first link of *its* arm (bases mounted on the universe separately are told apart by
     their frame path);
   * pairs whose capsules already overlap at ``system.q0`` (clearance ≤ 0;
     ``exclude_overlapping=True``): q0 is the system's nominal collision-free pose, so such a
     pair is a modelling artefact of the conservative capsules (Allegro's neighbouring finger
     bases, G1's pelvis and hip links).
   :attr:`CollisionModel.excluded` lists every excluded pair with its reason, and
   :attr:`CollisionModel.inter_branch` marks the rows between different branches of the
   kinematic tree (neither body an ancestor of the other: arm–arm, hand–hand).

Every distance is a signed clearance [m] (negative: penetration depth) minus ``margin``.  The
formulas are those of :mod:`coop_ga.collision.distance` (Eq 1–2, Lumelsky segment–segment); the
Jacobian row of a pair follows from its witness points x (on A) and y (on B or the obstacle)
and the unit normal n = (x − y)/|x − y| (the envelope theorem, module docstring of
:mod:`~coop_ga.collision.distance`):

    ∂d/∂q = nᵀ (J_x − J_y),   J_x = (1 − s) J_a + s J_b                              (3)

with J_a the (3, nq) world-frame Jacobian of a capsule end: ``J_v + ω × a`` from Pinocchio's
world-frame joint Jacobians (``computeJointJacobians``, the columns of the joints supporting the
capsule's frame).  For a plane, n is its normal and x the closer end.

:meth:`CollisionModel.casadi` builds the same distance code on CasADi SX, with the capsule
frames placed by the motor kinematics of :class:`coop_ga.kinematics.KinematicTree` (equal to
Pinocchio's ``oMf`` to ~1e-15), so its AD Jacobian equals Eq (3) wherever d is differentiable
(checked in ``tests/collision/test_model.py``, together with central finite differences).

Speed (three_franka, 21 DOF, 33 capsules, one sphere: 33 obstacle + 420 self distances; one
Pinocchio ``computeJointJacobians`` and ~150 vectorised numpy operations per call, measured on
the shared 2-core machine by ``python -m coop_ga.collision.model``): ``distances`` ≈ 0.2 ms
(0.4–0.5 ms under load), ``distances_and_jacobian`` ≈ 0.35 ms (0.7 ms under load); the CasADi
SX function with its AD Jacobian, interpreted, ≈ 1.2 ms.  ``tests/collision/test_model.py``
prints the numbers of its run.

Trajectories (the iLQR's clearance cost): :meth:`CollisionModel.trajectory_ends` places every capsule at K
configurations in one call of generated C (the motor kinematics of :meth:`CollisionModel.casadi` mapped over K;
~1.5 µs a configuration for three_franka), :meth:`CollisionModel.lower_bounds` bounds every distance by the
capsules' bounding spheres (a broad phase: a capsule lies inside its sphere), and
:meth:`CollisionModel.close_pairs` / :meth:`CollisionModel.close_pairs_and_jacobian` compute exactly, all at once,
only the (configuration, pair) entries whose bound is below a cutoff — the same numbers as :meth:`distances` and
Eq (3) (tested), at ~1.5 ms for 100 configurations of the obstacle scene against ~40 ms knot by knot.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..errors import CoopGAError, InvalidInputError
from .capsules import Capsule, check_system, fit_capsules
from .distance import (
    Plane,
    Sphere,
    _capsule_capsule_distance,
    _capsule_plane_distance,
    _capsule_sphere_distance,
    as_obstacle,
)

__all__ = ["CollisionModel"]

Body = tuple[str, int]


def _cols(X: np.ndarray) -> tuple[Any, Any, Any]:
    return (X[..., 0], X[..., 1], X[..., 2])


def _unit(w: np.ndarray) -> np.ndarray:
    """Rows of w (k, 3) normalised; zero rows stay zero."""
    n = np.linalg.norm(w, axis=-1, keepdims=True)
    return np.divide(w, n, out=np.zeros_like(w), where=n > 0.0)


def _capsules(system: Any, capsules: Any) -> tuple[Capsule, ...]:
    """The capsules argument: None (fit to the system's meshes) or a sequence of :class:`Capsule`."""
    if capsules is None:
        return tuple(fit_capsules(system))
    if isinstance(capsules, (str, Capsule)) or not isinstance(capsules, Iterable):
        raise InvalidInputError(f"capsules must be a list of collision.Capsule (or None: fitted), got {capsules!r}")
    out = tuple(capsules)
    if not all(isinstance(c, Capsule) for c in out):
        raise InvalidInputError(f"capsules must be collision.Capsule objects, got {[type(c).__name__ for c in out]}")
    return out


def _flags(**flags: Any) -> None:
    for name, value in flags.items():
        if not isinstance(value, (bool, np.bool_)):
            raise InvalidInputError(f"{name} must be True or False, got {value!r}")


def _obstacles(obstacles: Any) -> tuple[Sphere | Plane, ...]:
    """The obstacles argument (one obstacle, or an iterable of :func:`as_obstacle` inputs), errors naming the
    offending one."""
    from ..geometry.primitives import Primitive

    if isinstance(obstacles, (Sphere, Plane, dict, Primitive)):
        obstacles = [obstacles]  # one obstacle
    if isinstance(obstacles, str) or not isinstance(obstacles, Iterable):
        raise InvalidInputError(
            f"obstacles must be a list of collision.Sphere / collision.Plane (or primitives, dicts), got {obstacles!r}"
        )
    out = []
    for k, x in enumerate(obstacles):
        try:
            out.append(as_obstacle(x))
        except CoopGAError as exc:
            raise type(exc)(f"obstacles[{k}]: {exc}") from None
    return tuple(out)


class CollisionModel:
    """Signed clearances of ``system``'s capsules from obstacles and from each other (module docstring).

    Args:
        system: a :class:`coop_ga.systems.System`.
        obstacles: spheres / planes (:func:`~coop_ga.collision.distance.as_obstacle` inputs), world frame.
        capsules: the robot's capsules; default :func:`~coop_ga.collision.capsules.fit_capsules` (collision meshes).
        self_collision: include capsule–capsule pairs.
        exclude_adjacent: drop pairs of directly connected bodies.
        margin: subtracted from every distance [m] (≥ 0: a safety distance).
        exclude_overlapping: drop the pairs that overlap at ``system.q0``.
        srdf: drop the pairs a robot's SRDF disables (``<disable_collisions>``; module docstring).

    Attributes:
        labels: one per distance; ``kinds``: ``"obstacle"`` / ``"self"`` per distance;
        pairs: (n, 2) int — (capsule, obstacle) for obstacle rows, (capsule, capsule) for self rows;
        inter_branch: (n,) bool — self rows between different branches (arm–arm); False elsewhere;
        n_obstacle_rows: the obstacle rows come first (``2 × n_capsules`` for two obstacles);
        excluded: ``(label, reason)`` of every capsule pair left out.
    """

    def __init__(
        self,
        system: Any,
        obstacles: Iterable[Any] = (),
        capsules: Sequence[Capsule] | None = None,
        self_collision: bool = True,
        exclude_adjacent: bool = True,
        margin: float = 0.0,
        exclude_overlapping: bool = True,
        srdf: bool = True,
    ) -> None:
        import pinocchio as pin

        self.system = check_system(system)
        _flags(self_collision=self_collision, exclude_adjacent=exclude_adjacent, exclude_overlapping=exclude_overlapping,
               srdf=srdf)  # fmt: skip
        self.margin = validation.nonnegative(margin, "margin [m]")
        model = system.model
        self._model = model
        self._data = model.createData()
        self.capsules: tuple[Capsule, ...] = _capsules(system, capsules)
        self.obstacles: tuple[Sphere | Plane, ...] = _obstacles(obstacles)
        self.nq = int(model.nq)
        #: Jacobian columns: one per velocity (nv = nq, or nq − 1 with a free flyer: its LOCAL [v; ω])
        self.nv = int(model.nv)

        nc = len(self.capsules)
        self._layout_capsules(model, str(system.name))
        self._joints_used = sorted(set(int(j) for j in self._joint))
        self._jpos = np.array([self._joints_used.index(int(j)) for j in self._joint], int)
        self._pin = pin
        # the last broad-phase result (obstacles, margin, Q, cutoff, pairs, geometry): a solver asks for the close pairs
        # of the trajectory it just evaluated again, with their Jacobians (:meth:`_close`); the obstacles are part of
        # the key (a receding horizon moves them by assigning a new tuple, which the kept reference keeps distinct)
        self._last_close: tuple[Any, ...] | None = None

        # ---- obstacle rows
        labels: list[str] = []
        kinds: list[str] = []
        pairs: list[tuple[int, int]] = []
        for k, ob in enumerate(self.obstacles):
            oname = ob.name or (f"sphere {k}" if isinstance(ob, Sphere) else f"plane {k}")
            for i, c in enumerate(self.capsules):
                labels.append(f"{c.link} – {oname}")
                kinds.append("obstacle")
                pairs.append((i, k))
        self.n_obstacle_rows = len(pairs)

        # ---- self pairs
        self.excluded: list[tuple[str, str]] = []
        self_pairs: list[tuple[int, int]] = []
        inter: list[bool] = [False] * len(pairs)
        if self_collision and nc > 1:
            cand = self._self_candidates(system, exclude_adjacent, srdf)
            d0 = self._clearance_at_q0(system, cand) if exclude_overlapping and cand else np.full(len(cand), np.inf)
            for (i, j, same_branch), dd in zip(cand, d0):
                lab = f"{self.capsules[i].link} – {self.capsules[j].link}"
                if dd <= 0.0:
                    where = "same branch" if same_branch else "different branches"
                    self.excluded.append((lab, f"overlapping at q0 ({where}, clearance {dd:.4f} m)"))
                    continue
                self_pairs.append((i, j))
                inter.append(not same_branch)
                labels.append(lab)
                kinds.append("self")
                pairs.append((i, j))
        self._si = np.array([p[0] for p in self_pairs], int)
        self._sj = np.array([p[1] for p in self_pairs], int)
        self.labels: tuple[str, ...] = tuple(labels)
        self.kinds: tuple[str, ...] = tuple(kinds)
        self.pairs = np.array(pairs, int).reshape(-1, 2)
        self.inter_branch = np.array(inter, bool)
        self._casadi: Any = None
        self._casadi_jac: Any = None
        self._ends_functions: dict[int, Any] = {}  # trajectory_ends: one compiled function per K

    # ------------------------------------------------------------------ structure
    @property
    def n(self) -> int:
        """Number of distances."""
        return len(self.labels)

    def _layout_capsules(self, model: Any, system_name: str) -> None:
        """Per capsule: its frame id, parent joint, ends in the parent joint's frame [m], radius [m] and the
        joint-velocity columns that move it (the joints supporting its parent joint)."""
        nc = len(self.capsules)
        self._fid = np.zeros(nc, int)
        self._joint = np.zeros(nc, int)
        self._a_j = np.zeros((nc, 3))
        self._b_j = np.zeros((nc, 3))
        self._radius = np.array([c.radius for c in self.capsules], float)
        self._mask = np.zeros((nc, self.nv), bool)
        for i, c in enumerate(self.capsules):
            if not model.existFrame(c.frame):
                raise InvalidInputError(f"capsules: frame '{c.frame}' is not a frame of system '{system_name}'")
            fid = model.getFrameId(c.frame)
            f = model.frames[fid]
            self._fid[i], self._joint[i] = fid, int(f.parentJoint)
            Rf, tf = np.asarray(f.placement.rotation), np.asarray(f.placement.translation)
            self._a_j[i] = Rf @ c.a + tf
            self._b_j[i] = Rf @ c.b + tf
            for j in model.supports[int(f.parentJoint)]:
                if j > 0:  # every velocity of the joint (six for a free flyer)
                    self._mask[i, model.idx_vs[j] : model.idx_vs[j] + model.nvs[j]] = True

    def _self_candidates(self, system: Any, exclude_adjacent: bool, srdf: bool) -> list[tuple[int, int, bool]]:
        """The capsule pairs (i < j) that may collide, with whether they share a branch; the others go to
        :attr:`excluded` with the reason (same rigid body, the SRDF, adjacent links)."""
        nc = len(self.capsules)
        paths = [self._body_path(int(f)) for f in self._fid]
        disabled = _srdf_disabled(system) if srdf else {}
        cand: list[tuple[int, int, bool]] = []
        for i in range(nc):
            for j in range(i + 1, nc):
                lab = f"{self.capsules[i].link} – {self.capsules[j].link}"
                pi, pj = paths[i], paths[j]
                if pi[0] == pj[0] or (pi[0][0] == "w" and pj[0][0] == "w"):
                    self.excluded.append((lab, "same rigid body"))  # (all world-fixed bodies are one)
                    continue
                why = disabled.get(frozenset((self.capsules[i].frame, self.capsules[j].frame)))
                if why is not None:
                    self.excluded.append((lab, f"SRDF disable_collisions ({why})"))
                    continue
                adjacent = (len(pj) > 1 and pj[1] == pi[0]) or (len(pi) > 1 and pi[1] == pj[0])
                if exclude_adjacent and adjacent:
                    self.excluded.append((lab, "adjacent links (share a joint)"))
                    continue
                cand.append((i, j, pi[0] in pj or pj[0] in pi))
        return cand

    def _clearance_at_q0(self, system: Any, cand: list[tuple[int, int, bool]]) -> np.ndarray:
        """Clearance (len(cand),) [m] of each candidate capsule pair at ``system.q0``."""
        A, B, _ = self._ends(np.asarray(system.q0, float), jac=False)
        I = np.array([c[0] for c in cand])
        J = np.array([c[1] for c in cand])
        d0, _, _ = _capsule_capsule_distance(
            _cols(A[I]), _cols(B[I]), self._radius[I], _cols(A[J]), _cols(B[J]), self._radius[J]
        )
        return np.atleast_1d(np.asarray(d0, float))

    def _body_path(self, fid: int) -> list[Body]:
        """Rigid bodies from the frame's body to the world: ``("j", joint id)`` for a moving body, and
        last ``("w", root frame id)``: the world-fixed body it hangs from, named by the frame just
        below the universe on its frame path (bases attached to the universe separately get different
        ids; a frame path broken by ``buildReducedModel`` ends at the locked joint's frame)."""
        frames, model = self._model.frames, self._model
        path: list[Body] = []
        f = fid
        for _ in range(len(frames) + 1):
            j = int(frames[f].parentJoint)
            if j == 0:
                while f != 0 and int(frames[f].parentFrame) not in (0, f):
                    f = int(frames[f].parentFrame)
                path.append(("w", f))
                return path
            path.append(("j", j))
            g = f
            while int(frames[g].parentJoint) == j and int(frames[g].parentFrame) != g:
                g = int(frames[g].parentFrame)
            if int(frames[g].parentJoint) == j:  # no frame above: follow the joint tree
                parent = int(model.parents[j])
                if parent == 0:
                    path.append(("w", 0))
                    return path
                g = next(k for k in range(len(frames)) if int(frames[k].parentJoint) == parent)
            f = g
        return path  # pragma: no cover - a frame tree always ends at the universe

    # ------------------------------------------------------------------ numeric kinematics
    def _ends(self, q: np.ndarray, jac: bool = True) -> tuple[np.ndarray, np.ndarray, Any]:
        """World capsule ends A, B (nc, 3) [m] and the world-frame joint Jacobian (6, nq) ([v at the
        world origin; ω], Pinocchio's ``data.J``; None without ``jac``)."""
        pin, model, data = self._pin, self._model, self._data
        if jac:
            pin.computeJointJacobians(model, data, q)
        else:
            pin.forwardKinematics(model, data, q)
        oMi = data.oMi
        H = np.array([oMi[j].homogeneous for j in self._joints_used])[self._jpos]  # (nc, 4, 4)
        R, t = H[:, :3, :3], H[:, :3, 3]
        A = np.einsum("cij,cj->ci", R, self._a_j) + t
        B = np.einsum("cij,cj->ci", R, self._b_j) + t
        return A, B, (np.asarray(data.J) if jac else None)

    def _rows(self, J6: np.ndarray, cap: np.ndarray, x: np.ndarray, n: np.ndarray) -> np.ndarray:
        """``nᵀ J_x`` (k, nq) for witness points x (k, 3) [m] on capsules ``cap`` (k,) and unit normals n:
        ``J_x = J_v + ω × x`` restricted to the joints supporting the capsule, so
        ``nᵀ J_x = (nᵀ J_v + (x × n)ᵀ J_ω) ⊙ mask``.  J6: one (6, nq) Jacobian, or one per row (k, 6, nq)."""
        xn = np.empty_like(n)
        xn[:, 0] = x[:, 1] * n[:, 2] - x[:, 2] * n[:, 1]
        xn[:, 1] = x[:, 2] * n[:, 0] - x[:, 0] * n[:, 2]
        xn[:, 2] = x[:, 0] * n[:, 1] - x[:, 1] * n[:, 0]
        if J6.ndim == 3:
            return (np.einsum("ki,kij->kj", n, J6[:, :3]) + np.einsum("ki,kij->kj", xn, J6[:, 3:])) * self._mask[cap]
        return (n @ J6[:3] + xn @ J6[3:]) * self._mask[cap]

    def capsule_segments(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """World segment ends ``(A, B)``, each (n_capsules, 3) [m], at q (for drawing)."""
        A, B, _ = self._ends(self._q(q), jac=False)
        return A, B

    def _q(self, q: Any) -> np.ndarray:
        if type(q) is np.ndarray and q.shape == (self.nq,) and q.dtype == np.float64 and np.isfinite(q).all():
            return q
        return self.system.check_q(q, warn_limits=False)

    # ------------------------------------------------------------------ distances
    def _eval(self, q: np.ndarray, jac: bool) -> tuple[np.ndarray, np.ndarray | None]:
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow (a huge prismatic q) is refused below
            return self._eval_unchecked(q, jac)

    def _eval_unchecked(self, q: np.ndarray, jac: bool) -> tuple[np.ndarray, np.ndarray | None]:
        A, B, J6 = self._ends(q, jac)
        rows = np.arange(self.n)
        g = self._geometry(A[None], B[None], np.zeros(self.n, int), rows)
        dist = g[0]
        if not np.all(np.isfinite(dist)):
            raise InvalidInputError(
                f"q places a capsule where its distances overflow (|q| up to {float(np.max(np.abs(q))):.3g}); "
                "this configuration is far outside any workspace"
            )
        if not jac:
            return dist, None
        return dist, self._jacobian_rows(J6, g)

    def _geometry(
        self, A: np.ndarray, B: np.ndarray, kk: np.ndarray, rows: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Distances of the given (configuration, row) pairs and what their Jacobian rows (Eq 3) need.

        A, B: (K, nc, 3) capsule ends at K configurations [m]; kk (P,): the configuration of each pair; rows (P,):
        its row (the order of :attr:`labels`).  Returns ``(d (P,) [m] (minus the margin), x (P, 3) the witness
        point on the first capsule, y (P, 3) the one on the second capsule (self rows), n (P, 3) the unit normal,
        ci (P,) the first capsule, cj (P,) the second one (−1: an obstacle))``.
        """
        r = self._radius
        P = len(rows)
        d, X, Y, N = np.empty(P), np.empty((P, 3)), np.zeros((P, 3)), np.empty((P, 3))
        ci, cj = np.empty(P, int), np.full(P, -1)
        nc, nob = len(self.capsules), self.n_obstacle_rows
        obs = rows < nob
        for k, ob in enumerate(self.obstacles):
            sel = np.flatnonzero(obs & (rows // max(nc, 1) == k))
            if not sel.size:
                continue
            c = rows[sel] % nc
            a, b = A[kk[sel], c], B[kk[sel], c]
            ci[sel] = c
            if isinstance(ob, Sphere):
                dd, t = _capsule_sphere_distance(_cols(a), _cols(b), r[c], ob)
                x = a + np.broadcast_to(np.asarray(t, float), (len(sel),))[:, None] * (b - a)
                N[sel] = _unit(x - ob.center)
            else:
                dd, t = _capsule_plane_distance(_cols(a), _cols(b), r[c], ob)
                x = np.where(np.broadcast_to(np.asarray(t, float), (len(sel),))[:, None] > 0.5, b, a)
                N[sel] = ob.normal
            d[sel], X[sel] = dd, x
        sel = np.flatnonzero(~obs)
        if sel.size:
            p = rows[sel] - nob
            i, j = self._si[p], self._sj[p]
            ks = kk[sel]
            dd, _, (x, y) = _capsule_capsule_distance(
                _cols(A[ks, i]), _cols(B[ks, i]), r[i], _cols(A[ks, j]), _cols(B[ks, j]), r[j]
            )
            d[sel] = dd
            X[sel] = np.stack(x, axis=-1).reshape(-1, 3)
            Y[sel] = np.stack(y, axis=-1).reshape(-1, 3)
            N[sel] = _unit(X[sel] - Y[sel])
            ci[sel], cj[sel] = i, j
        return d - self.margin, X, Y, N, ci, cj

    def _jacobian_rows(self, J6: np.ndarray, geometry: tuple[np.ndarray, ...]) -> np.ndarray:
        """∂d/∂q (P, nq) of pairs (:meth:`_geometry`'s output) from Pinocchio's ``data.J`` at their configuration:
        one (6, nq) for all, or (P, 6, nq), one per pair: ``nᵀ (J_x − J_y)`` (Eq 3)."""
        _, X, Y, N, ci, cj = geometry
        J = self._rows(J6, ci, X, N)
        two = np.flatnonzero(cj >= 0)
        if two.size:
            J[two] -= self._rows(J6[two] if J6.ndim == 3 else J6, cj[two], Y[two], N[two])
        return J

    # ------------------------------------------------------------------ trajectories
    def trajectory_ends(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World capsule ends ``(A, B)``, each (K, nc, 3) [m], of K configurations Q (K, nq) at once.

        One call of generated C (the motor kinematics of :meth:`casadi`, mapped over K configurations, compiled
        once per K and cached on disk; the CasADi VM without a compiler): ~1.5 µs per configuration for
        three_franka, against ~26 µs for a Pinocchio forward-kinematics call from Python.
        """
        Q = np.asarray(Q, float)
        K = Q.shape[0]
        f = self._ends_functions.get(K)
        if f is None:
            f = self._ends_functions[K] = self._ends_function(K)
        E = f(Q.T)
        E = np.asarray(E[0] if isinstance(E, (list, tuple)) else E).T.reshape(K, -1, 6)
        return E[..., :3], E[..., 3:]

    def _ends_function(self, K: int) -> Any:
        import casadi as ca

        from ..codegen import CompiledFunction

        q = ca.SX.sym("q", self.nq)
        A, B = self._symbolic_ends(q)
        e = ca.vertcat(*[v for a, b in zip(A, B) for v in (*a, *b)]) if A else ca.SX.zeros(0, 1)
        f = ca.Function("capsule_ends", [q], [e])
        return CompiledFunction(f.map(K), check_finite=False)

    def lower_bounds(self, A: np.ndarray, B: np.ndarray) -> np.ndarray:
        """Lower bounds (K, n) [m] of every distance at K configurations (capsule ends A, B (K, nc, 3)): the
        distances of the capsules' bounding spheres (centre: the segment's midpoint, radius: half its length plus
        the capsule's radius), minus the margin.  A capsule lies inside its sphere, so a distance is never below
        its bound: a broad phase."""
        C = 0.5 * (A + B)
        rho = 0.5 * np.linalg.norm(B - A, axis=-1) + self._radius  # (K, nc)
        out = []
        for ob in self.obstacles:
            if isinstance(ob, Sphere):
                out.append(np.linalg.norm(C - ob.center, axis=-1) - rho - ob.radius)
            else:
                out.append(C @ ob.normal - ob.offset - rho)
        if len(self._si):
            i, j = self._si, self._sj
            out.append(np.linalg.norm(C[:, i] - C[:, j], axis=-1) - rho[:, i] - rho[:, j])
        K = A.shape[0]
        return (np.concatenate(out, axis=1) if out else np.zeros((K, 0))) - self.margin

    def _candidates(self, A: np.ndarray, B: np.ndarray, cutoff: float) -> np.ndarray:
        """(K, n) bool: :meth:`lower_bounds` < cutoff, computed on squared distances (no square roots)."""
        C = 0.5 * (A + B)
        W = B - A
        rho = 0.5 * np.sqrt(np.einsum("kci,kci->kc", W, W)) + self._radius
        out = []
        for ob in self.obstacles:
            if isinstance(ob, Sphere):
                D = C - ob.center
                reach = np.maximum(cutoff + self.margin + rho + ob.radius, 0.0)
                out.append(np.einsum("kci,kci->kc", D, D) < reach * reach)
            else:
                out.append(C @ ob.normal - ob.offset - rho - self.margin < cutoff)
        if len(self._si):
            D = C[:, self._si] - C[:, self._sj]
            reach = np.maximum(cutoff + self.margin + rho[:, self._si] + rho[:, self._sj], 0.0)
            out.append(np.einsum("kpi,kpi->kp", D, D) < reach * reach)
        return np.concatenate(out, axis=1) if out else np.zeros((A.shape[0], 0), bool)

    def close_pairs(self, Q: Any, cutoff: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every (configuration, row) of a trajectory Q (K, nq) whose distance is below ``cutoff`` [m]:
        ``(k (P,), row (P,), d (P,) [m])``, exact; the others are skipped by :meth:`lower_bounds` (one batched
        kinematics call, :meth:`trajectory_ends`), so only the close pairs are computed exactly, all at once."""
        kk, rows, g = self._close(Q, cutoff)
        return kk, rows, g[0]

    def close_pairs_and_jacobian(self, Q: Any, cutoff: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`close_pairs` and the Jacobian rows ``∂d/∂q`` (P, nq) of those pairs (Eq 3): one Pinocchio
        ``computeJointJacobians`` per configuration that has a close pair, the witness points from the batch."""
        kk, rows, g = self._close(Q, cutoff)
        pin, model, data = self._pin, self._model, self._data
        Qa = np.asarray(Q, float)
        knots, idx = np.unique(kk, return_inverse=True)
        J6 = np.empty((knots.size, 6, self.nv))
        for i, k in enumerate(knots):
            pin.computeJointJacobians(model, data, Qa[k])
            J6[i] = data.J
        return kk, rows, g[0], self._jacobian_rows(J6[idx], g)

    def _close(self, Q: Any, cutoff: float) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
        hot = type(Q) is np.ndarray and Q.dtype == np.float64 and Q.ndim == 2 and np.isfinite(Q.sum())
        Q = Q if hot else validation.array(Q, "Q")
        if Q.ndim != 2 or Q.shape[1] != self.nq:
            raise InvalidInputError(f"Q must be a (K, {self.nq}) array of configurations, got shape {Q.shape}")
        last = self._last_close
        if (
            last is not None
            and last[0] is self.obstacles
            and last[1] == self.margin
            and cutoff <= last[3]
            and last[2].shape == Q.shape
            and np.array_equal(last[2], Q)
        ):
            # the same trajectory and scene with a cutoff no larger: the pairs below it are among the last ones (exact)
            kk, rows, g = last[4], last[5], last[6]
        else:
            A, B = self.trajectory_ends(Q)
            kk, rows = np.nonzero(self._candidates(A, B, cutoff))
            g = self._geometry(A, B, kk, rows)
            self._last_close = (self.obstacles, self.margin, Q.copy(), float(cutoff), kk, rows, g)
        keep = g[0] < cutoff
        return kk[keep], rows[keep], tuple(x[keep] for x in g)

    def rows_and_jacobian(self, q: Any, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(d (m,) [m], ∂d/∂q (m, nq))`` of the given rows (indices into :attr:`labels`) at one configuration q:
        the rows of :meth:`distances_and_jacobian`, without computing the others."""
        qq = self._q(q)
        rows = np.asarray(rows, int).reshape(-1)
        A, B, J6 = self._ends(qq, True)
        g = self._geometry(A[None], B[None], np.zeros(len(rows), int), rows)
        return g[0], self._jacobian_rows(J6, g)

    def distances(self, q: Any) -> np.ndarray:
        """Signed clearances (n,) [m] at q (nq,); a batch q (..., nq) gives (..., n)."""
        Q = validation.array(q, "q")
        if Q.ndim >= 2 and Q.shape[-1] == self.nq:
            flat = Q.reshape(-1, self.nq)
            out = np.stack([self._eval(self._q(qq), False)[0] for qq in flat]) if len(flat) else np.zeros((0, self.n))
            return out.reshape(*Q.shape[:-1], self.n)
        return self._eval(self._q(q), False)[0]

    def distances_and_jacobian(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(d (n,) [m], ∂d/∂q (n, nq) [m/rad or m/m])`` at q (nq,) — Eq (3) of the module docstring."""
        d, J = self._eval(self._q(q), True)
        assert J is not None
        return d, J

    def min_clearance(self, q: Any, kind: str | None = None) -> float:
        """The smallest distance at q [m] (``inf`` if there are none); a batch q (..., nq) gives (...).

        ``kind``: None (all rows), ``"obstacle"``, ``"self"`` or ``"inter_branch"`` (arm–arm rows)."""
        d = self.distances(q)
        if kind is not None:
            d = d[..., self.mask(kind)]
        if d.shape[-1] == 0:
            return float("inf") if d.ndim == 1 else np.full(d.shape[:-1], np.inf)  # type: ignore[return-value]
        return float(d.min()) if d.ndim == 1 else d.min(axis=-1)

    def mask(self, kind: str) -> np.ndarray:
        """(n,) bool rows of ``kind``: ``"obstacle"``, ``"self"`` or ``"inter_branch"``."""
        if kind == "inter_branch":
            return self.inter_branch.copy()
        if kind in ("obstacle", "self"):
            return np.array([k == kind for k in self.kinds], bool)
        raise InvalidInputError(f"kind must be 'obstacle', 'self' or 'inter_branch', got {kind!r}")

    def closest(self, q: Any) -> tuple[str, float]:
        """``(label, distance [m])`` of the smallest distance at one configuration q (nq,) (``("", inf)`` for a
        model without distances)."""
        d = self._eval(self._q(q), False)[0]
        if not len(d):
            return "", float("inf")
        k = int(np.argmin(d))
        return self.labels[k], float(d[k])

    # ------------------------------------------------------------------ CasADi
    def symbolic(self, q: Any) -> Any:
        """The distances (n,) [m] as an SX column of the SX column q (nq,): to embed in a larger graph."""
        from ..algebra import backend as Bk

        if not Bk.is_symbolic(q) or q.numel() != self.nq:
            raise InvalidInputError(
                f"q must be a CasADi SX column of {self.nq} entries (casadi.SX.sym('q', {self.nq})); got "
                f"{type(q).__name__}{'' if not Bk.is_symbolic(q) else f' of shape {q.shape}'} — use distances() for numbers"
            )
        return self._symbolic(q)

    def _symbolic_ends(self, q: Any) -> tuple[list[tuple[Any, Any, Any]], list[tuple[Any, Any, Any]]]:
        """The capsule ends A, B (one SX 3-tuple per capsule) of the SX column q, by the motor kinematics."""
        from ..geometry.groups import motor_rotor_translation, rotor_matrix
        from ..kinematics import KinematicTree

        tree = KinematicTree(self._model, [c.frame for c in self.capsules]) if self.capsules else None
        A: list[tuple[Any, Any, Any]] = []
        B: list[tuple[Any, Any, Any]] = []
        if tree is not None:
            for M, c in zip(tree.frame_motors(q), self.capsules):
                R, t = motor_rotor_translation(M)
                Rm = rotor_matrix(R)

                def place(p: np.ndarray, Rm: Any = Rm, t: Any = t) -> tuple[Any, Any, Any]:
                    return tuple(t[r] + sum(Rm[r][k] * float(p[k]) for k in range(3)) for r in range(3))

                A.append(place(c.a))
                B.append(place(c.b))
        return A, B

    def _symbolic(self, q: Any) -> Any:
        """The distances as an SX column (n,) of the SX column q (nq,)."""
        import casadi as ca

        A, B = self._symbolic_ends(q)
        out: list[Any] = []
        for ob in self.obstacles:
            for i, c in enumerate(self.capsules):
                if isinstance(ob, Sphere):
                    d, _ = _capsule_sphere_distance(A[i], B[i], c.radius, ob)
                else:
                    d, _ = _capsule_plane_distance(A[i], B[i], c.radius, ob)
                out.append(d)
        for i, j in zip(self._si, self._sj):
            d, _, _ = _capsule_capsule_distance(A[i], B[i], float(self._radius[i]), A[j], B[j], float(self._radius[j]))
            out.append(d)
        return (ca.vertcat(*out) if out else ca.SX.zeros(0, 1)) - self.margin

    def casadi(self) -> Any:
        """``casadi.Function("collision_distances", [q (nq,)], [d (n,)])``: the same distance code on SX
        (built once); ``casadi.jacobian`` of it is the exact ∂d/∂q."""
        if self._casadi is None:
            import casadi as ca

            q = ca.SX.sym("q", self.nq)
            self._casadi = ca.Function("collision_distances", [q], [self._symbolic(q)], ["q"], ["d"])
        return self._casadi

    def casadi_jacobian(self) -> Any:
        """``casadi.Function("collision_distances_jac", [q], [d (n,), J (n, nq)])`` by CasADi AD."""
        if self._casadi_jac is None:
            import casadi as ca

            q = ca.SX.sym("q", self.nq)
            d = self._symbolic(q)
            self._casadi_jac = ca.Function("collision_distances_jac", [q], [d, ca.jacobian(d, q)], ["q"], ["d", "J"])
        return self._casadi_jac

    def __repr__(self) -> str:
        return (
            f"CollisionModel({self.system.name!r}, capsules={len(self.capsules)}, obstacles={len(self.obstacles)}, "
            f"distances={self.n}, excluded={len(self.excluded)})"
        )


def _srdf_path(urdf: Path) -> Path | None:
    """The SRDF next to a URDF: ``<dir>/../srdf/<name>.srdf`` or ``<dir>/<name>.srdf``, or None."""
    for cand in (urdf.parent.parent / "srdf" / f"{urdf.stem}.srdf", urdf.with_suffix(".srdf")):
        if cand.is_file():
            return cand
    return None


def _srdf_disabled(system: Any) -> dict[frozenset[str], str]:
    """``{frozenset({frame A, frame B}): reason}`` of the ``<disable_collisions>`` pairs in the SRDFs of
    the system's robots (one per :class:`~coop_ga.systems.VisualSource` with a URDF), link names
    carrying that robot's prefix.  Pairs are only ever disabled within one robot."""
    import xml.etree.ElementTree as ET

    out: dict[frozenset[str], str] = {}
    for src in getattr(system, "visuals", ()):
        if src.urdf is None:
            continue
        path = _srdf_path(Path(src.urdf))
        if path is None:
            continue
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as e:
            raise InvalidInputError(f"SRDF {path} could not be parsed: {e}") from e
        for el in root.iter("disable_collisions"):
            a, b = el.get("link1"), el.get("link2")
            if a and b:
                out[frozenset((src.prefix + a, src.prefix + b))] = el.get("reason", "") or "disabled"
    return out


def _benchmark(system_name: str = "three_franka", reps: int = 200) -> dict[str, float]:
    """µs per call of :meth:`CollisionModel.distances` and :meth:`~CollisionModel.distances_and_jacobian`."""
    from .. import systems

    s = systems.load(system_name)
    cm = CollisionModel(s, [Sphere(np.array([0.0, 0.0, 0.5]), 0.1)])
    q = s.q0
    out: dict[str, float] = {"n": float(cm.n)}
    for name, f in (("distances_us", cm.distances), ("distances_and_jacobian_us", cm.distances_and_jacobian)):
        f(q)
        t0 = time.perf_counter()
        for _ in range(reps):
            f(q)
        out[name] = 1e6 * (time.perf_counter() - t0) / reps
    return out


if __name__ == "__main__":  # pragma: no cover
    print(_benchmark())
