"""Moving spherical obstacles for the receding-horizon controller, and the velocity dampers that account for them.

A :class:`MovingSphere` follows a path ``t → centre`` [s → m].  :class:`ObstacleWorld` owns the
:class:`~coop_ga.collision.model.CollisionModel` of a system with those spheres and moves them to their
positions at time t (:meth:`ObstacleWorld.at`; the model reads its ``obstacles`` on every call).

The velocity damper (A1) of :class:`~coop_ga.control.limits.ClearanceLimit` assumes a static world: the
clearance changes only through the robot, ``ḋ = J_d q̇``.  A moving sphere adds ``∂d/∂t`` at fixed q (negative
while it approaches), so :class:`MovingClearanceLimit` shifts each obstacle row by it:

    −J_{d,k} q̇ ≤ h_k + ∂d_k/∂t,                                                        (A1')

h_k the row of (A1) (damper, capped by the braking speed).  A pair within d_s whose sphere approaches gets a
negative bound: the robot must move away at least as fast as the sphere comes (where (A1) would only stop
it).  ``∂d/∂t`` is a one-sided difference of the model's distances along the sphere's velocity over 1 ms.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import validation
from ...errors import InvalidInputError
from ..limits import ClearanceLimit
from ..limits.base import Inequalities
from ..limits.clearance import distances

__all__ = ["MovingClearanceLimit", "MovingSphere", "ObstacleWorld"]

#: time step [s] of the difference that gives the sphere velocity and ∂d/∂t
_H = 1e-3


@dataclass(frozen=True)
class MovingSphere:
    """A sphere of ``radius`` [m] whose centre (3,) [m, world frame] at time t [s] is ``path(t)``."""

    radius: float
    path: Callable[[float], Any]
    name: str = "obstacle"

    def __post_init__(self) -> None:
        validation.positive(self.radius, "sphere radius [m]")
        if not callable(self.path):
            raise InvalidInputError("MovingSphere.path must be callable as path(t) -> centre (3,) [m]")

    def center(self, t: float) -> np.ndarray:
        """The centre (3,) [m] at t, checked (NaN or a wrong shape raise)."""
        return validation.vector(self.path(float(t)), 3, f"{self.name} path({t:.4f})")

    def velocity(self, t: float) -> np.ndarray:
        """(3,) [m/s], by a central difference of the path over ±1 ms."""
        return (self.center(t + _H) - self.center(t - _H)) / (2.0 * _H)


class ObstacleWorld:
    """A collision model of ``system`` with the spheres at time t (module docstring).

    Args:
        system: a :class:`~coop_ga.systems.System`.
        spheres: the :class:`MovingSphere` s.
        **model_options: passed to :class:`~coop_ga.collision.model.CollisionModel` (``self_collision``,
            ``margin``, …).
    """

    def __init__(self, system: Any, spheres: Sequence[MovingSphere] = (), **model_options: Any):
        from ...collision.distance import Sphere
        from ...collision.model import CollisionModel

        self.spheres = tuple(spheres)
        if not all(isinstance(s, MovingSphere) for s in self.spheres):
            raise InvalidInputError("spheres must be coop_ga.control.mpc.MovingSphere objects")
        self._Sphere = Sphere
        self.model = CollisionModel(system, obstacles=self._placed(0.0), **model_options)
        self.time = 0.0

    def _placed(self, t: float) -> list[Any]:
        return [self._Sphere(s.center(t), s.radius, s.name) for s in self.spheres]

    def at(self, t: float) -> Any:
        """Move the spheres to time t [s]; returns the collision model."""
        self.time = float(t)
        if self.spheres:
            self.model.obstacles = tuple(self._placed(self.time))
        return self.model

    def obstacle_rate(self, q: np.ndarray, d: np.ndarray | None = None) -> np.ndarray:
        """``∂d/∂t`` (n,) [m/s] of every distance at fixed q and the current time (0 on the self rows); ``d``
        (n,) [m]: the distances at q now, if already known (saves one evaluation of the model)."""
        n_obs = self.model.n_obstacle_rows
        rate = np.zeros(self.model.n)
        if not n_obs:
            return rate
        d0 = self.model.distances(q) if d is None else d
        placed = self.model.obstacles
        t = self.time
        self.model.obstacles = tuple(
            self._Sphere(s.center(t) + _H * s.velocity(t), s.radius, s.name) for s in self.spheres
        )
        try:
            d1 = self.model.distances(q)
        finally:
            self.model.obstacles = placed
        rate[:n_obs] = (d1[:n_obs] - d0[:n_obs]) / _H
        return rate


class MovingClearanceLimit(ClearanceLimit):
    """The rows (A1') of the module docstring: :class:`~coop_ga.control.limits.ClearanceLimit` on the moving
    spheres of an :class:`ObstacleWorld` (placed at its current time by :meth:`ObstacleWorld.at`)."""

    name = "clearance (moving obstacles)"

    def __init__(self, world: ObstacleWorld, dt: float = 0.01, **options: Any):
        if not isinstance(world, ObstacleWorld):
            raise InvalidInputError("MovingClearanceLimit needs an ObstacleWorld")
        super().__init__(world.model, dt, **options)
        self.world = world

    def inequalities(self, configuration: Any, dt: float) -> Inequalities:
        d, Jd = distances(self.model, configuration)
        a = configuration.limits.acceleration
        rows = self.rows(d, Jd, dt, a if self.braking and np.any(np.isfinite(a)) else None)
        idx = np.flatnonzero(d < self.d_influence)  # the rows' pairs (damper_rows' selection)
        if not idx.size or rows.h is None:
            return rows
        rate = self.world.obstacle_rate(configuration.q.copy(), d)
        return Inequalities(None, None, rows.G, rows.h + rate[idx], rows.labels)
