"""File formats read and written by the core (``tabulated``: sampled spectral BRDFs)."""
