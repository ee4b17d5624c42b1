"""Layer 4½: clearance in CGA — obstacles (spheres, planes), robot bodies as capsules, distances with
their Jacobians on numpy and CasADi, and potential-field paths (seed 002).

P·S = ½(r² − d²) is a smooth signed squared distance from a point P to a sphere S (or, for a
plane, the signed distance): the algebra that makes avoidance a smooth constraint.
"""
