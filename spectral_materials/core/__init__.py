"""The pure-Python core: no ``bpy`` here, ever.

Public API (names fixed for scripts and the add-on)::

    from spectral_materials.core import factor_brdf, FactoredBRDF
"""

from .brdf.factor import factor_brdf, factor_brdf_series
from .brdf.factored import FactoredBRDF
from .errors import Cancelled, InvalidBRDFData

__all__ = ["Cancelled", "FactoredBRDF", "InvalidBRDFData", "factor_brdf", "factor_brdf_series"]
