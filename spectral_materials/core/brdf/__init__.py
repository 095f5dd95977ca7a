"""Spectral BRDFs: analytic models, parameterisations, tabulation, factoring into packs,
:class:`~.factored.FactoredBRDF`, the protocol's metrics, the float64 mirror of the draw path
(:mod:`.shading`) and the EEVEE prefilter."""
