"""Measured and tabulated BRDF files by suffix: one entry point for the add-on and scripts."""

from __future__ import annotations

from pathlib import Path

from ..errors import InvalidBRDFData


def _tabulated(path):
    from .tabulated import read_tabulated

    return read_tabulated(path)


def _merl(path):
    from .merl import read_merl

    return read_merl(path, fill="neighbours")  # −1 and invalid cells from their neighbours


def _rgl(path):
    from .rgl_bsdf import read_rgl_bsdf

    return read_rgl_bsdf(path)


#: Suffix → (description, reader returning a BRDF callable f(wi, wo, wavelengths)).
READERS = {
    ".npz": ("tabulated spectral BRDF (the project's format)", _tabulated),
    ".binary": ("MERL BRDF (RGB, uplifted with Smits 1999)", _merl),
    ".bsdf": ("RGL tensor BSDF (Dupuy & Jakob 2018; spectral or RGB)", _rgl),
}


#: Suffixes whose readers look pairs up in cells (``lookup_cells``: MERL's nearest cell).
LOOKED_UP_IN_CELLS = frozenset({".binary"})


def looked_up_in_cells(path: str | Path) -> bool:
    """Whether the file's reader looks pairs up in cells (its suffix says; no reading)."""
    return Path(path).suffix.lower() in LOOKED_UP_IN_CELLS


def read_brdf_file(path: str | Path):
    """The BRDF callable of a data file, chosen by its suffix; InvalidBRDFData otherwise."""
    path = Path(path)
    entry = READERS.get(path.suffix.lower())
    if entry is None:
        known = ", ".join(f"{suffix} ({what})" for suffix, (what, _) in READERS.items())
        raise InvalidBRDFData(f"{path}: unknown BRDF file type {path.suffix!r}; known: {known}")
    return entry[1](path)
