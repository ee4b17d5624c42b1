"""The cooperative wrench: end-point forces → the wrench on the cooperative primitive (§3.5, §3.11).

The paper maps task wrenches to joint torques by ``τ = J^Gᵀ 𝒲`` (Eq 52) with ``J^G = G(p) J_p``
(:mod:`coop_ga.cooperative.graph`: ``G = −2 Ṽ ∂V/∂p``, 7 × 3n, maps the stacked end-point
velocities ṗ to the body-frame similarity twist b = G ṗ, Eq 30/33).  For a statically held object
the end points therefore exert the point forces ``F = Gᵀ 𝒲`` (3n).  This module goes the other
way: from measured point forces F it computes the wrench on the primitive, and splits it into what
moves the held object and what squeezes it.

Conventions
-----------
* ``points`` p (n, 3) [m], world frame: the task's end points, in the task's order.
* ``forces`` F (n, 3) [N], world frame: the force each end point exerts **on the object** (with
  :class:`coop_ga.sim.Simulation`, ``−sim.end_forces()``: those are the forces on the robot);
  ``torques`` T (n, 3) [N m]: pure torques the end bodies exert on the object (``−end_wrenches[:, 3:]``,
  about the end points; zero for point contacts).
* A similarity wrench 𝒲 (7,) is dual to the body twist ``b = [θ12, θ13, θ23, β, t1, t2, t3]``
  (docs/conventions.md): ``𝒲ᵀ b`` is a power [W].  Its rows: torques about the primitive's body axes
  (𝒲_12 about body z, −𝒲_13 about body y, 𝒲_23 about body x) [N m]; 𝒲_β, the dilation "force" [N m]
  (the work per unit of ln r); 𝒲_t = r Rᵀ f [N m]: the body translation rows of J^G are velocities in
  units of the radius r (``b_t = Rᵀ ċ / r``), so their dual is the force times r.  All seven are
  therefore in joules, which is why the 7-vectors are comparable.
* The primitive's centre c (3,), radius r and rotation R come from ``V_Sc = T(c) R D(ln r)``
  (``log V = [θ, ln r, c]``); for a line / plane, c is the point closest to the world origin.

The split (what each part means)
--------------------------------
Let ``A(p)`` (3n × 6) map a rigid twist ξ = (v at c, ω) of the held object to the end-point
velocities ``ṗ_i = v + ω × (p_i − c)``; its transpose is the grasp matrix: ``w = Aᵀ F`` is the
Euclidean wrench (force, torque about c) the end points exert on the object.

* **External** (moves the object): ``w = [Σ F_i, Σ (p_i − c) × F_i + T_i]`` (6,), world frame, and the
  similarity wrench that does the same work on every rigid motion of the object,
  ``𝒲_ext = argmin ‖𝒲‖ s.t. (G A)ᵀ 𝒲 = w`` (G A (7 × 6) maps a rigid twist to the primitive's twist).
  Rigid motions never dilate (the β row of G A is 0), so ``𝒲_ext`` has no e0∞ component.  The rigid
  motions that leave the primitive unchanged (a circle's spin about its axis, a sphere's rotations,
  a line's slide and spin, a plane's in-plane slides and spin) have no similarity wrench: the part
  of w along them is returned as ``unresolved`` (e.g. the torque about a circle's axis: the
  cooperative circle cannot turn an object about its axis, a controller must do that in J^G's
  nullspace).
* **Internal** (squeezes, does no work on any rigid motion): ``F_int = F − A (AᵀA)⁺ Aᵀ F`` (n, 3),
  the minimum-norm decomposition of grasp theory.  The radius is invariant under rigid motions, so
  the β row of G, ``g_β = ∂ ln r / ∂p`` (3n), is an internal force direction; the **squeeze**

      s = −(g_β · F) / (‖g_β‖² n r)   [N],   positive = pressing inward,

  is the component of F along it, normalised so that n equal inward radial forces of s newtons on
  a circle through n evenly spaced points (or a sphere) read s.  It is blind to external loads
  (g_β ⊥ every rigid field), and a commanded ``𝒲 = 𝒲_β e0∞`` (``τ = J^Gᵀ 𝒲``) reads back
  ``s = −𝒲_β / (n r)`` exactly.  The internal similarity wrench is ``𝒲_int = −s n r e0∞``; the rest of
  F_int (other internal forces, e.g. tangential ones) has no e0∞ component and is returned as
  ``internal_rest`` (n, 3).  Kinds without a dilation (point, line, plane) have s = 0.
* ``wrench = 𝒲_ext + 𝒲_int`` (7,).

Why not ``𝒲 = (Gᵀ)⁺ F``: the least-squares dual drops the forces in ker G — the components of F
tangent to the primitive (along a circle) — which carry external load: for a common in-plane force on
three evenly spaced points on a circle it recovers only half of the net force, and for unevenly spaced
points it reports a squeeze under a pure external load (``tests/cooperative/test_wrench.py`` shows
both).  The split above has neither defect.

Commanding a wrench: :meth:`WrenchMap.command` returns ``𝒲 = 𝒲_ext(w_d) − (s_d − s_ext) n r e0∞`` for
a desired object wrench w_d and squeeze s_d, where ``s_ext`` is the squeeze of the point forces
``Gᵀ 𝒲_ext`` alone (zero for evenly spaced points; for uneven ones the lift of a weight also presses);
``τ = J^Gᵀ 𝒲`` then exerts w_d (its resolvable part) and exactly the squeeze s_d on a held object,
statically.

Speed: one compiled CasADi function ``(p, F, T, w_d, s_d) → everything above`` per task
(:class:`WrenchMap`), built on the task graph's pose function (the same G as J^G) with the 6 × 6
solves in closed form (``(M + P)⁻¹`` with P the projector onto the known null space of M = (G A)ᵀ G A:
exact, no pseudo-inverse), compiled like the task's own entry points.
"""

from __future__ import annotations

import threading
import weakref
from typing import Any

import casadi as ca
import numpy as np

from .. import validation
from ..codegen import CompiledFunction
from ..errors import InvalidInputError
from ..geometry.groups import ROTOR_BLADES, decompose, rotor_matrix
from ..geometry.kinds import KIND_SPECS, Kind
from ..geometry.similarity import UNIT_AXIS
from .graph import TaskGraph, versor_expr

__all__ = [
    "BETA",
    "CooperativeWrench",
    "WrenchMap",
    "cooperative_wrench",
    "layout",
    "squeeze_capacity",
    "squeeze_direction",
    "wrench_expressions",
    "wrench_map",
]

#: index of the dilation (e0∞) row of a similarity twist / wrench
BETA = 3


# ====================================================================== symbolic core
def _skew(d: Any) -> ca.SX:
    return ca.vertcat(
        ca.horzcat(0, -d[2], d[1]),
        ca.horzcat(d[2], 0, -d[0]),
        ca.horzcat(-d[1], d[0], 0),
    )


def _rigid_map(p: ca.SX, c: ca.SX, n: int) -> ca.SX:
    """A (3n × 6): ṗ_i = v + ω × (p_i − c) for the rigid twist ξ = (v, ω)."""
    rows = [ca.horzcat(ca.SX.eye(3), -_skew(p[3 * i : 3 * i + 3] - c)) for i in range(n)]
    return ca.vertcat(*rows)


def _blocks(a: Any, b: Any) -> ca.SX:
    z = ca.SX.zeros(3, 3)
    return ca.vertcat(ca.horzcat(a, z), ca.horzcat(z, b))


def _null_projectors(kind: Kind, o: ca.SX | None, n: int) -> tuple[ca.SX, ca.SX]:
    """``(P_Z, P_A)`` (6 × 6): projectors onto the rigid twists (v at c, ω) that leave the primitive
    unchanged (ker G A) and that leave every end point fixed (ker A)."""
    spec = KIND_SPECS[kind]
    Z, I3 = ca.SX.zeros(3, 3), ca.SX.eye(3)
    oo = ca.mtimes(o, o.T) if o is not None else Z
    if spec.axis is None:  # point, sphere
        PZ = _blocks(Z, I3)  # every rotation about c
    elif not spec.flat:  # point pair, circle
        PZ = _blocks(Z, oo)  # the spin about the axis through c
    elif spec.axis_role == "direction":  # line
        PZ = _blocks(oo, oo)  # slide along and spin about the line
    else:  # plane: slides in the plane and the spin about its normal
        PZ = _blocks(I3 - oo, oo)
    # n ≤ 2 points: the rotations about the line through them (or the point) move no point
    PA = _blocks(Z, I3 if n == 1 else oo) if n <= 2 else ca.SX.zeros(6, 6)
    return PZ, PA


def wrench_expressions(graph: TaskGraph, p: Any, F: Any, T: Any, w_cmd: Any, s_cmd: Any) -> dict[str, ca.SX]:
    """The cooperative wrench as CasADi expressions (module docstring).

    Args:
        graph: the task's :class:`~coop_ga.cooperative.graph.TaskGraph`.
        p: (3n,) stacked end points [m]; F: (3n,) forces on the object [N]; T: (3n,) torques on the
            object [N m] (all world frame, SX).
        w_cmd: (6,) desired object wrench (force [N], torque about c [N m]); s_cmd: desired squeeze [N].

    Returns:
        dict of SX: ``wrench`` (7), ``external`` (7), ``squeeze`` (1), ``object_wrench`` (6),
        ``unresolved`` (6), ``internal_forces`` (3n), ``internal_rest`` (3n), ``centre`` (3),
        ``radius`` (1), ``command`` (7), ``direction`` (3n) the squeeze's unit point-force direction
        (inward), ``well_definedness``, ``chart``.
    """
    n = graph.n_points
    kind = graph.primitive_kind
    V, B, G, w, c2 = graph.pose_function(p)
    c, r = B[4:7], ca.exp(B[BETA])
    axis = UNIT_AXIS.get(kind)
    o: ca.SX | None = None
    if axis is not None:
        VR = decompose(versor_expr(V))[1]
        R = ca.vertcat(*[ca.horzcat(*row) for row in rotor_matrix(tuple(VR.get(k) for k in ROTOR_BLADES))])
        o = ca.mtimes(R, ca.SX(ca.DM(axis)))
    A = _rigid_map(p, c, n)
    PZ, PA = _null_projectors(kind, o, n)
    GA = ca.mtimes(G, A)
    M = ca.mtimes(GA.T, GA) + PZ  # invertible: M's null space is exactly range(P_Z)
    torque_pts = sum((T[3 * i : 3 * i + 3] for i in range(n)), ca.SX.zeros(3))
    wobj = ca.mtimes(A.T, F) + ca.vertcat(ca.SX.zeros(3), torque_pts)
    I6 = ca.SX.eye(6)

    def to_similarity(x: ca.SX) -> ca.SX:  # the minimum-norm 𝒲 with (G A)ᵀ 𝒲 = (I − P_Z) x
        return ca.mtimes(GA, ca.solve(M, ca.mtimes(I6 - PZ, x)))

    Wext = to_similarity(wobj)
    AA = ca.mtimes(A.T, A) + PA
    Fint = F - ca.mtimes(A, ca.solve(AA, ca.mtimes(A.T, F)))
    gb = G[BETA, :].T
    g2 = ca.dot(gb, gb)
    has_beta = ca.if_else(g2 > 1e-300, 1.0, 0.0)  # (a line / plane / point has no dilation)
    scale = n * r
    s = ca.if_else(g2 > 1e-300, -ca.dot(gb, F) / (ca.fmax(g2, 1e-300) * scale), 0.0)
    e_beta = ca.DM.zeros(7)
    e_beta[BETA] = 1.0
    direction = -gb / ca.sqrt(ca.fmax(g2, 1e-300)) * has_beta
    rest = Fint + ca.if_else(g2 > 1e-300, s * scale, 0.0) * gb  # F_int − (g_β·F / ‖g_β‖²) g_β
    # the command: 𝒲_ext(w_cmd) plus the e0∞ part that makes the squeeze of Gᵀ𝒲 exactly s_cmd — for
    # unevenly spaced points Gᵀ𝒲_ext itself squeezes by −g_β·Gᵀ𝒲_ext / (‖g_β‖² n r), which is removed
    Wc = to_similarity(w_cmd)
    s_ext = -ca.dot(gb, ca.mtimes(G.T, Wc)) / (ca.fmax(g2, 1e-300) * scale)
    command = Wc - has_beta * (s_cmd - s_ext) * scale * e_beta
    return {
        "wrench": Wext - s * scale * e_beta,
        "external": Wext,
        "squeeze": s,
        "object_wrench": wobj,
        "unresolved": ca.mtimes(PZ, wobj),
        "internal_forces": Fint,
        "internal_rest": rest,
        "centre": c,
        "radius": r,
        "command": command,
        "direction": direction,
        "well_definedness": w,
        "chart": c2,
    }


_OUTPUTS = (
    "wrench",
    "external",
    "squeeze",
    "object_wrench",
    "unresolved",
    "internal_forces",
    "internal_rest",
    "centre",
    "radius",
    "command",
    "direction",
)


def layout(n: int) -> dict[str, slice]:
    """Where each output of :data:`_OUTPUTS` sits in the flat ``values`` vector of the compiled function
    (n end points)."""
    sizes = {"squeeze": 1, "radius": 1, "centre": 3, "object_wrench": 6, "unresolved": 6}
    sizes |= {k: 7 for k in ("wrench", "external", "command")}
    sizes |= {k: 3 * n for k in ("internal_forces", "internal_rest", "direction")}
    out, i = {}, 0
    for k in _OUTPUTS:
        out[k] = slice(i, i + sizes[k])
        i += sizes[k]
    return out


def _wrench_function(graph: TaskGraph) -> ca.Function:
    """``(p, F, T, w_cmd, s_cmd) → (values, checks)``: every output of :data:`_OUTPUTS` stacked in one
    column (:func:`layout`: one copy gives them all), and the guard's checks."""
    m = 3 * graph.n_points
    p, F, T = ca.SX.sym("p", m), ca.SX.sym("F", m), ca.SX.sym("T", m)
    wc, sc = ca.SX.sym("w_cmd", 6), ca.SX.sym("s_cmd")
    e = wrench_expressions(graph, p, F, T, wc, sc)
    outs = [ca.densify(ca.vec(e[k])) for k in _OUTPUTS]
    checks = TaskGraph.checks(e, (p, F, T, wc, sc), tuple(outs))
    return ca.Function(
        f"coop_wrench_{graph.name}",
        [p, F, T, wc, sc],
        [ca.vertcat(*outs), checks],
        ["p", "F", "T", "w_cmd", "s_cmd"],
        ["values", "checks"],
    )


# ====================================================================== numeric front end
class CooperativeWrench:
    """The cooperative wrench of one set of end-point forces (module docstring): read-only views of one
    copy of the compiled function's output, each field sliced when it is read.

    Attributes:
        wrench: (7,) 𝒲 = external + internal, on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` (body frame) [J].
        external: (7,) 𝒲_ext: the similarity wrench of the object wrench (its e0∞ entry is 0) [J].
        internal: (7,) 𝒲_int = −s n r e0∞ [J].
        squeeze: s [N], the e0∞ internal force per end point; positive = pressing inward.
        force: (3,) net force the end points exert on the object [N], world frame.
        torque: (3,) their torque about the primitive's centre [N m], world frame.
        unresolved: (6,) the part of (force, torque) along rigid motions that leave the primitive
            unchanged (no similarity wrench exerts it; e.g. the torque about a circle's axis).
        internal_forces: (n, 3) F_int, the internal part of the forces [N] (zero net force and torque).
        internal_rest: (n, 3) F_int minus its squeeze component [N] (the other internal forces).
        centre: (3,) primitive centre c [m]; radius: r [m].
        direction: (n, 3) unit point-force direction of a positive squeeze (inward; zero without dilation).
        well_definedness: of the end points (1 best, 0 degenerate).
    """

    __slots__ = ("_n", "_sl", "_v", "well_definedness")

    def __init__(self, values: np.ndarray, n: int, slices: dict[str, slice], well_definedness: float):
        values.setflags(write=False)
        self._v, self._n, self._sl, self.well_definedness = values, n, slices, well_definedness

    def __repr__(self) -> str:
        return (
            f"CooperativeWrench(squeeze={self.squeeze:.6g} N, force={np.round(self.force, 6).tolist()} N, "
            f"torque={np.round(self.torque, 6).tolist()} N m)"
        )

    def _get(self, name: str) -> np.ndarray:
        return self._v[self._sl[name]]

    def _points(self, name: str) -> np.ndarray:
        return self._v[self._sl[name]].reshape(self._n, 3)

    wrench = property(lambda self: self._get("wrench"))
    external = property(lambda self: self._get("external"))
    unresolved = property(lambda self: self._get("unresolved"))
    centre = property(lambda self: self._get("centre"))
    force = property(lambda self: self._get("object_wrench")[:3])
    torque = property(lambda self: self._get("object_wrench")[3:])
    internal_forces = property(lambda self: self._points("internal_forces"))
    internal_rest = property(lambda self: self._points("internal_rest"))
    direction = property(lambda self: self._points("direction"))

    @property
    def squeeze(self) -> float:
        return float(self._get("squeeze")[0])

    @property
    def radius(self) -> float:
        return float(self._get("radius")[0])

    @property
    def internal(self) -> np.ndarray:
        e = np.zeros(7)
        e[BETA] = -self.squeeze * self._n * self.radius
        return e


class WrenchMap:
    """The compiled cooperative wrench of a task (module docstring); one per task (:func:`wrench_map`).

    Args:
        task: a :class:`~coop_ga.cooperative.CooperativeTask`.
        codegen: ``"auto"`` / True / False as for the task (default: the task's).

    The call costs one compiled evaluation (no Python loop over points); a thread may share it.
    """

    def __init__(self, task: Any, codegen: bool | str | None = None):
        if not hasattr(task, "graph") or not isinstance(task.graph, TaskGraph):
            raise InvalidInputError(f"WrenchMap needs a CooperativeTask, got {type(task).__name__}")
        self.task = task
        self.n = int(task.graph.n_points)
        self.function = _wrench_function(task.graph)
        self.compiled = CompiledFunction(
            self.function, codegen=task.codegen if codegen is None else codegen, check_finite=False
        )
        self._zero = np.zeros(3 * self.n)
        self._zero6 = np.zeros(6)
        #: where each quantity sits in :meth:`evaluate_views`' flat output
        self.slices = layout(self.n)

    def __repr__(self) -> str:
        return f"WrenchMap({self.task.name!r}, n={self.n}, instructions={self.compiled.n_instructions})"

    def _vec(self, x: Any, what: str, shape: tuple[int, ...]) -> np.ndarray:
        if (
            type(x) is np.ndarray
            and x.dtype == np.float64
            and (x.shape == shape or x.shape == (x.size,) == (3 * self.n,))
        ):
            return x.reshape(-1)  # NaN/inf are caught by the guard of the evaluation, naming the argument
        a = validation.array(x, what)
        if a.shape == shape:
            return a.reshape(-1)
        if a.shape == (int(np.prod(shape)),):  # already flat
            return a
        raise InvalidInputError(f"{what} must have shape {shape} ({self.n} end points), got {a.shape}")

    def evaluate_views(
        self, p: np.ndarray, F: np.ndarray, T: np.ndarray, w_cmd: np.ndarray, s_cmd: float
    ) -> np.ndarray:
        """Hot-loop variant: flat float arrays in (3n, 3n, 3n, 6) and a float; returns this thread's output
        buffer ``values`` (flat; :attr:`slices` says where each quantity sits), overwritten by the next
        call.  Raises like :meth:`__call__` on NaN input or degenerate points."""
        b = self.compiled.binding()
        ins = b.flat_inputs
        ins[0][...] = p
        ins[1][...] = F
        ins[2][...] = T
        ins[3][...] = w_cmd
        ins[4][0] = s_cmd
        b.eval()
        values, checks = b.outputs
        guard = self.task.guard
        if not checks.item(0) > guard.warn_below:
            guard.diagnose(
                checks,
                ins[0],
                (("points", ins[0]), ("forces", ins[1]), ("torques", ins[2]), ("w_cmd", ins[3]), ("s_cmd", ins[4])),
            )
        self._checks = checks
        return values.reshape(-1)

    def __call__(self, points: Any, forces: Any, torques: Any = None) -> CooperativeWrench:
        """The :class:`CooperativeWrench` of ``forces`` (n, 3) [N] (and ``torques`` (n, 3) [N m], default 0)
        that the end points at ``points`` (n, 3) [m] exert on the object (world frame)."""
        sh = (self.n, 3)
        p = self._vec(points, "points", sh)
        F = self._vec(forces, "forces", sh)
        T = self._zero if torques is None else self._vec(torques, "torques", sh)
        v = self.evaluate_views(p, F, T, self._zero6, 0.0).copy()
        return CooperativeWrench(v, self.n, self.slices, self._checks.item(1))

    def command(self, points: Any, force: Any = (0.0, 0.0, 0.0), torque: Any = (0.0, 0.0, 0.0), squeeze: float = 0.0):
        """The similarity wrench 𝒲 (7,) [J] to command (``τ = J^Gᵀ 𝒲``, Eq 52) so that the end points at
        ``points`` (n, 3) exert the object wrench (``force`` (3,) [N], ``torque`` (3,) [N m] about the
        primitive's centre, world frame; its unresolved part is dropped) and the squeeze ``squeeze`` [N]
        (positive = inward) on a held object."""
        p = self._vec(points, "points", (self.n, 3))
        wc = np.concatenate([validation.vector(force, 3, "force"), validation.vector(torque, 3, "torque")])
        s = validation.scalar(squeeze, "squeeze")
        return self.evaluate_views(p, self._zero, self._zero, wc, s)[self.slices["command"]].copy()


_MAPS: weakref.WeakKeyDictionary[Any, WrenchMap] = weakref.WeakKeyDictionary()
_MAPS_LOCK = threading.Lock()


def wrench_map(task: Any) -> WrenchMap:
    """The :class:`WrenchMap` of ``task`` (built and compiled on first use, then cached with the task)."""
    with _MAPS_LOCK:
        m = _MAPS.get(task)
        if m is None:
            m = _MAPS[task] = WrenchMap(task)
        return m


def cooperative_wrench(task: Any, points: Any, forces: Any, torques: Any = None) -> CooperativeWrench:
    """The :class:`CooperativeWrench` of the forces (n, 3) [N] (and torques (n, 3) [N m]) that the task's
    end points at ``points`` (n, 3) [m] exert on an object, world frame (module docstring).

    Raises:
        InvalidInputError: wrong shapes; NonFiniteError: NaN/inf; DegeneratePrimitiveError: degenerate
            end points (as the task's own evaluation).
    """
    return wrench_map(task)(points, forces, torques)


def squeeze_direction(task: Any, points: Any) -> np.ndarray:
    """(n, 3) unit point-force direction of a positive (inward) squeeze at ``points`` (n, 3): −∂ln r/∂p
    normalised (zero for kinds without a dilation)."""
    return wrench_map(task)(points, np.zeros((task.graph.n_points, 3))).direction


def squeeze_capacity(task: Any, q: Any, effort: Any, bias: Any = None) -> dict[str, float]:
    """How hard the chains can squeeze along e0∞ at q (§3.11), within their effort limits.

    A squeeze s [N] needs ``τ = J^Gᵀ 𝒲``, ``𝒲 = −s n r e0∞`` (module docstring), i.e. ``τ = s τ₁`` with
    ``τ₁ = −n r J^G[e0∞]ᵀ`` [N m per N]; on top of ``bias`` (nq,) [N m] (e.g. the arms' gravity torque)
    every joint must stay within ``effort`` (nq,) [N m].

    Args:
        task: a cooperative task with a dilation (point pair, circle, sphere).
        q: (nq,) configuration [rad]; effort: (nq,) torque limits [N m]; bias: (nq,) torque already used.

    Returns:
        ``squeeze_max`` [N]: the largest s with |bias + s τ₁| ≤ effort (both signs of bias counted, so
        also valid while the bias changes sign); ``joint``: the index of the joint that limits it;
        ``ellipsoid`` [N]: the force manipulability along e0∞, ``√(M_S⁻¹)[e0∞, e0∞] / (n r)`` with
        ``M_S = J̃ J̃ᵀ``, ``J̃ = J^G diag(effort)⁻¹`` (Eq 59, torques normalised by the effort: the extent of
        the force ellipsoid ‖τ / effort‖ ≤ 1 along e0∞, other wrench components free);
        ``radius`` [m].

    Raises:
        InvalidInputError: a kind without a dilation, bad shapes, a bias beyond the effort.
    """
    from .manipulability import force_manipulability

    if not KIND_SPECS[task.primitive_kind].has_radius:  # point pair, circle, sphere
        raise InvalidInputError(f"a {task.primitive_kind} has no dilation (e0∞): no squeeze capacity")
    st = task.evaluate(q)
    eff = validation.vector(effort, task.nq, "effort")
    b = np.zeros(task.nq) if bias is None else validation.vector(bias, task.nq, "bias")
    head = eff - np.abs(b)
    if np.any(head <= 0):
        raise InvalidInputError(f"bias exceeds the effort limit at joint(s) {np.flatnonzero(head <= 0).tolist()}")
    n, r = task.graph.n_points, float(np.exp(st.log[BETA]))
    tau1 = np.abs(n * r * st.jacobian[BETA])
    with np.errstate(divide="ignore"):
        per_joint = np.where(tau1 > 0, head / np.where(tau1 > 0, tau1, 1.0), np.inf)
    j = int(np.argmin(per_joint))
    Mf = force_manipulability(st.jacobian / eff[None, :])
    return {
        "squeeze_max": float(per_joint[j]),
        "joint": float(j),
        "ellipsoid": float(np.sqrt(max(Mf[BETA, BETA], 0.0)) / (n * r)),
        "radius": r,
    }
