"""The pure-Python core: no ``bpy`` here, ever.

Public API (names fixed for scripts and the add-on)::

    from spectral_materials.core import factor_brdf, FactoredBRDF
"""

from .errors import Cancelled, InvalidBRDFData
from .factor import factor_brdf, factor_brdf_series
from .factored import FactoredBRDF

__all__ = ["Cancelled", "FactoredBRDF", "InvalidBRDFData", "factor_brdf", "factor_brdf_series"]
