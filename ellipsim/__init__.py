"""ellipsim: exact, fast ellipsoid collision detection for MuJoCo figures with oval limbs."""

from .charpoly import characteristic_polynomial
from .classify import Relation, classify
from .contact import contact_scale
from .ellipsoids import Ellipsoids
from .narrowphase import signed_distance

__all__ = ["Ellipsoids", "Relation", "classify", "characteristic_polynomial", "contact_scale", "signed_distance"]
__version__ = "0.1.0"
