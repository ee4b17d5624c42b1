"""Clearance in CGA — obstacles (spheres, planes), robot bodies as capsules, distances with
their Jacobians on numpy and CasADi, and potential-field paths (seed 002).

P·S = ½(r² − d²) is a smooth signed squared distance from a point P to a sphere S (or, for a
plane, the signed distance): the algebra that makes avoidance a smooth constraint.

* :mod:`~coop_ga.collision.distance` — :class:`Sphere`, :class:`Plane`, :func:`as_obstacle` and the
  closed-form clearances (point/capsule–sphere, capsule–plane, capsule–capsule; Eq 28–29 of seed 002);
* :mod:`~coop_ga.collision.capsules` — :class:`Capsule`, :func:`fit_capsules` (a bounding capsule per
  link mesh);
* :mod:`~coop_ga.collision.model` — :class:`CollisionModel`: every clearance of a system at q, its
  Jacobian, and the same code as a CasADi function;
* :mod:`~coop_ga.collision.potential` — Coulomb potential-field paths around sphere obstacles (seed 002 §VI).
"""

from .capsules import Capsule, capsule_chain, fit_capsule, fit_capsules, link_meshes
from .distance import (
    Obstacle,
    Plane,
    Sphere,
    as_obstacle,
    capsule_capsule_distance,
    capsule_plane_distance,
    capsule_sphere_distance,
    conformal_point,
    point_plane_distance,
    point_sphere_distance,
    point_sphere_product,
    seed002_link_sphere_distance,
    segment_point_parameter,
    segment_segment_closest,
)
from .model import CollisionModel
from .potential import PotentialPath, charges, coulomb_field, potential_path, random_scene

__all__ = [
    "Capsule",
    "CollisionModel",
    "Obstacle",
    "Plane",
    "PotentialPath",
    "Sphere",
    "as_obstacle",
    "capsule_capsule_distance",
    "capsule_chain",
    "capsule_plane_distance",
    "capsule_sphere_distance",
    "charges",
    "conformal_point",
    "coulomb_field",
    "fit_capsule",
    "fit_capsules",
    "link_meshes",
    "point_plane_distance",
    "point_sphere_distance",
    "point_sphere_product",
    "potential_path",
    "random_scene",
    "seed002_link_sphere_distance",
    "segment_point_parameter",
    "segment_segment_closest",
]
