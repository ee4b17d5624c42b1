"""The algebra G(4,1) in the null basis, generic over numpy and CasADi coefficients."""

from . import backend
from .basis import BLADES_BY_GRADE, blade_index, blade_name, grade_of
from .multivector import Multivector, grade_blades

__all__ = ["BLADES_BY_GRADE", "Multivector", "backend", "blade_index", "blade_name", "grade_blades", "grade_of"]


def e(name: str, coeff=1.0) -> Multivector:
    """A single blade, e.g. ``e('e1')``, ``e('einf')``, ``e('e0inf', 2.0)``."""
    return Multivector.blade(name, coeff)


e0 = e("e0")
e1 = e("e1")
e2 = e("e2")
e3 = e("e3")
einf = e("einf")
I5 = e("e0123inf")
