"""The configuration of one control step: q, the previous velocity and its kinematics, evaluated once.

This is the ``Configuration`` of mink and pink (kevinzakka/mink ``mink/configuration.py``,
stephane-caron/pink ``pink/configuration.py``): the object every :class:`~coop_ga.control.tasks.Task`
and every :class:`~coop_ga.control.limits.Limit` of a step reads, so that the kinematics are computed
once per q and shared.  Here the kinematics are those of the cooperative task graph
(:class:`~coop_ga.cooperative.graph.TaskGraph` of a :class:`~coop_ga.CooperativeTask`, the *model*):
one compiled call ``(q, V_d) → (V_Sc, B_Sc, J^G, checks, end points, end-point Jacobians, e, K)``
gives

* V_Sc (12,), B_Sc = log V_Sc (7,) and the body Jacobian J^G (7, nv) (Eq 28, 30; nv = nq without a free flyer);
* the end points p_i (n, 3) [m] and their world Jacobians J_{p,i} (n, 3, nq) [m/rad] (Eq 7, 17);
* for one target V_d: e = log(Ṽ_Sc V_d) (7,) (Eq 44) and K = ∂e/∂b with J_e = K J^G (Eq 47),

in one evaluation of generated C (:class:`~coop_ga.codegen.CompiledFunction`), where the previous
controllers made one call for J^G and another for e at the same q.  The target is an input of the call;
:meth:`Configuration.prepare` tells the configuration which target the step's similarity task will ask
for, so that the first evaluation already contains its error (another target costs one more call,
cached per target object).  Results are cached per q: :meth:`Configuration.update` starts the next step.
Anything else a task or limit computes from q (clearances, line parameters) is cached through
:meth:`Configuration.cached`, keyed by the caller's identity.

``velocity`` is the joint velocity q̇ [rad/s] of the previous step (zeros: at rest), which the
:class:`~coop_ga.control.limits.AccelerationLimit` needs.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from typing import Any, NamedTuple, TypeVar

import numpy as np

from .. import validation
from ..codegen import CompiledFunction
from ..geometry.groups import Similarity

__all__ = ["Configuration", "Kinematics"]

T = TypeVar("T")

#: the identity similarity's 12 coefficients (scalar 1), the target input when no task has one
_IDENTITY = Similarity.identity().coeffs.copy()

_KINEMATICS: weakref.WeakKeyDictionary[Any, CompiledFunction] = weakref.WeakKeyDictionary()


def _kinematics_function(model: Any) -> CompiledFunction:
    """The model's compiled ``(q, V_d) → (V, B, J, checks, points, J_p, e, K)`` (built once per model)."""
    cf = _KINEMATICS.get(model)
    if cf is None:
        import casadi as ca

        from ..cooperative.graph import NB, _coeffs_expr, versor_expr
        from ..geometry.groups import SIMILARITY_BLADES

        g = model.graph
        q = ca.SX.sym("q", model.nq)
        vd = ca.SX.sym("Vd", NB)
        p, Jp = g.points(q)
        V, B, G, w, c2 = g.pose_function(p)
        J = ca.mtimes(G, Jp)
        W = (versor_expr(V).reverse() * versor_expr(vd)).with_blades(SIMILARITY_BLADES)
        e, K = g.error_small_function(_coeffs_expr(W))
        s = {"well_definedness": w, "chart": c2}
        checks = g.checks(s, (q, vd), (V, B, J, e))
        f = ca.Function(
            f"coop_kin_{model.name}",
            [q, vd],
            [V, B, ca.densify(J), checks, p, ca.densify(Jp), e, ca.densify(K)],
            ["q", "Vd"],
            ["V", "B", "J", "checks", "points", "Jp", "e", "K"],
        )
        cf = _KINEMATICS[model] = CompiledFunction(f, codegen=model.codegen, check_finite=False)
    return cf


class Kinematics(NamedTuple):
    """What one evaluation of the model at q gives (copies, owned by one configuration; module docstring).

    coeffs (12,) V_Sc's coefficients on SIMILARITY_BLADES; log (7,) B_Sc; jacobian (7, nq) J^G (body frame);
    points (n, 3) [m]; point_jacobians (3n, nq) [m/rad], rows 3i..3i+2 the world Jacobian of end point i;
    checks (5,) the guard's numbers (``checks[1]``: well-definedness in [0, 1]); target (12,) the V_d of the error;
    error (7,) e = log(Ṽ_Sc V_d); error_map (7, 7) K with J_e = K J^G.
    """

    coeffs: np.ndarray
    log: np.ndarray
    jacobian: np.ndarray
    points: np.ndarray
    point_jacobians: np.ndarray
    checks: np.ndarray
    target: np.ndarray
    error: np.ndarray
    error_map: np.ndarray


_F64 = np.dtype(np.float64)


def _vector(x: Any, n: int, what: str, owner: str) -> np.ndarray:
    """x as an (n,) float array: the hot path (a float64 (n,) array) is not copied or re-validated here
    (the caller copies it; non-finite values are caught by the compiled call's guard)."""
    if type(x) is np.ndarray and x.dtype is _F64 and x.shape == (n,):
        return x
    return validation.configuration(x, n, what, owner=owner)


class Configuration:
    """q (nq,) and the previous joint velocity of a model, with the kinematics evaluated once per q.

    Args:
        model: a :class:`~coop_ga.CooperativeTask` (its system, kinematic tree and task graph).
        q: (nq,) joint configuration [rad or m] (copied; with a free flyer its quaternion must be unit).
        velocity: (nv,) joint velocity q̇ of the previous step [rad/s] (None: at rest, zeros).

    Raises:
        InvalidInputError: q or velocity of the wrong size; NonFiniteError (at the first evaluation): not finite.

    The configuration owns its buffers: ``q``, ``velocity`` and the arrays of :meth:`kinematics` are
    overwritten by :meth:`update` (like mink's ``Configuration.data``), so copy what must outlive a step.
    One configuration belongs to one thread.
    """

    __slots__ = ("_cache", "_done", "_errors", "_eval", "_kin", "_out", "_qb", "_src", "_vb", "model", "q", "velocity")

    def __init__(self, model: Any, q: Any, velocity: Any = None):
        from ..codegen import Binding

        self.model = model
        cf = _kinematics_function(model)
        b = Binding(cf.function, cf._in_shapes, cf._out_shapes)  # this configuration's own buffers
        self._eval, self._out = b.eval, (b, b.outputs)
        self._qb, self._vb = b.flat_inputs[0], b.flat_inputs[1]
        out = b.outputs
        self._kin = Kinematics(
            out[0][:, 0],
            out[1][:, 0],
            out[2],
            out[4].reshape(-1, 3),
            out[5],
            out[3][:, 0],
            self._vb,
            out[6][:, 0],
            out[7],
        )
        self.q = np.zeros(model.nq)
        self.velocity = np.zeros(getattr(model, "nv", model.nq))
        self._done = False
        self._src: np.ndarray = _IDENTITY
        self._errors: dict[int, tuple[Any, np.ndarray, np.ndarray]] = {}
        self._cache: dict[Any, Any] = {}
        self.update(q, velocity)

    @property
    def nq(self) -> int:
        """Number of coordinates of q."""
        return int(self.model.nq)

    @property
    def nv(self) -> int:
        """Number of velocities: the size of q̇ and of every task's Jacobian rows (nq, or nq − 1 with a free flyer)."""
        return int(getattr(self.model, "nv", self.model.nq))

    @property
    def system(self) -> Any:
        """The task's system (:meth:`~coop_ga.systems.System.integrate`, limits)."""
        return self.model.system

    def limit_coordinates(self) -> np.ndarray:
        """The coordinates of q the position limits bound, in q̇ order (nv,): q itself when nq = nv
        (:meth:`~coop_ga.systems.System.limit_coordinates`)."""
        if self.nq == self.nv:
            return self.q
        return self.model.system.limit_coordinates(self.q)

    @property
    def limits(self) -> Any:
        """The system's :class:`~coop_ga.systems.limits.JointLimits`."""
        return self.model.system.limits

    def update(self, q: Any, velocity: Any = None) -> None:
        """Move to a new q (and previous velocity; None: zeros); every cached evaluation is dropped."""
        n = self.model.nq
        owner = f"task '{self.model.name}'"
        self.q[...] = _vector(q, n, "q", owner)
        if velocity is None:
            self.velocity[...] = 0.0
        else:
            self.velocity[...] = _vector(velocity, self.velocity.shape[0], "velocity", owner)
        self._vb[...] = self._src = _IDENTITY
        self._done = False
        if self._errors:
            self._errors = {}
        if self._cache:
            self._cache = {}

    def prepare(self, target: Similarity | None) -> None:
        """Use ``target`` as V_d of the (not yet made) evaluation, so that its error comes with it."""
        if not self._done and target is not None:
            self._vb[...] = self._src = target.coeffs

    def kinematics(self) -> Kinematics:
        """The evaluation at q (made on first use, then shared until :meth:`update`)."""
        if not self._done:
            self._qb[...] = self.q
            self._eval()
            out = self._out[1]
            if not out[3].item(0) > self.model.warn_below:  # the task's guard: non-finite, degeneracy, chart
                self.model.guard.diagnose(out[3], out[4], (("q", self._qb), ("target", self._vb)))
            self._done = True
        return self._kin

    def similarity_error(self, target: Similarity) -> tuple[np.ndarray, np.ndarray]:
        """``(e (7,), K (7, 7))``: e = log(Ṽ_Sc(q) V_d) (Eq 44) and ``J_e = K J^G`` (Eq 47) for ``target`` V_d.

        From the shared evaluation when it was made for this target (:meth:`prepare`), else from one
        more call, cached per target object.
        """
        vd = target.coeffs
        if not self._done:
            self._vb[...] = vd
            self._src = vd
        kin = self.kinematics()
        if self._src is vd or np.array_equal(self._vb, vd):
            return kin.error, kin.error_map
        hit = self._errors.get(id(target))
        if hit is None or hit[0] is not target:
            b = _kinematics_function(self.model).binding()
            b.flat_inputs[0][...] = self.q
            b.flat_inputs[1][...] = vd
            b.eval()
            hit = self._errors[id(target)] = (target, b.outputs[6][:, 0].copy(), b.outputs[7].copy())
        return hit[1], hit[2]

    def cached(self, key: Any, compute: Callable[[Configuration], T]) -> T:
        """``compute(self)``, evaluated once per q for ``key`` (a task's or limit's identity)."""
        try:
            return self._cache[key]
        except KeyError:
            v = self._cache[key] = compute(self)
            return v

    def __repr__(self) -> str:
        return f"Configuration({self.model.name!r}, nq={self.nq})"
