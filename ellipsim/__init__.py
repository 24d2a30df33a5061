"""ellipsim: exact, fast ellipsoid collision detection for MuJoCo figures with oval limbs."""

from .charpoly import characteristic_polynomial
from .classify import Relation, classify
from .contact import contact_scale
from .ellipsoids import Ellipsoids

__all__ = ["Ellipsoids", "Relation", "classify", "characteristic_polynomial", "contact_scale"]
__version__ = "0.1.0"
