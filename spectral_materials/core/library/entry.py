"""One library entry, factored where a worker runs: bytes in, bytes out.

:func:`factor_entry` is what a process-pool or Dask worker runs. It receives the file's
bytes (so workers need no shared file system) and returns the entry's files as bytes
and its report row; only the process building the library writes them (``layout``).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from ..brdf import metrics
from ..brdf.factor import factor_brdf, resolve_parameterization
from ..brdf.job import drawn_cells
from ..colour import spectra
from ..formats.brdf_files import READERS, read_brdf_file
from .layout import FACTORS_FILE, THUMBNAIL_FILE
from .settings import LibrarySettings
from .thumbnail import thumbnail_png


def factor_entry(name: str, suffix: str, data: bytes, settings: dict) -> dict:
    """Factor one BRDF file given as ``data`` (its bytes, ``suffix`` its type).

    Returns ``{"files": {FACTORS_FILE: bytes, THUMBNAIL_FILE: bytes}, "row": {...}}``,
    the row holding ΔE94 mean / p95 / max at the protocol's pairs under D65 against
    the file's own data, packs, bytes and seconds. Raises what reading or factoring
    raises (InvalidBRDFData for a bad file), with ``name`` in the message.
    """
    started = time.perf_counter()
    options = LibrarySettings(**settings)
    if suffix.lower() not in READERS:
        raise ValueError(f"{name}: unsupported file type {suffix!r}")
    with tempfile.TemporaryDirectory(prefix="sm-library-") as tmp:
        path = Path(tmp) / f"input{suffix.lower()}"
        path.write_bytes(data)
        try:
            brdf = read_brdf_file(path)
            wavelengths = spectra.WAVELENGTHS_REFERENCE
            param, isotropic = resolve_parameterization(brdf, options.parameterization, None,
                                                        wavelengths)
            resolution = param.theta_resolution(options.theta_cells)
            # A MERL file is drawn in its cells, as the add-on's Automatic draws it.
            model = factor_brdf(brdf, parameterization=param.name, isotropic=isotropic,
                                resolution=resolution, packs=options.packs,
                                wavelengths=wavelengths, spectral_basis=options.basis,
                                cells=drawn_cells(brdf, "auto"))
            stats = metrics.ProtocolError(brdf).stats(model)
        except (ValueError, OSError) as exc:
            # The reader names the temporary copy; the user knows the file by its name.
            raise ValueError(f"{name}{suffix}: {str(exc).replace(str(path), 'file')}") from None
        saved = Path(tmp) / FACTORS_FILE
        model.save(saved)
        factors = saved.read_bytes()
    return {
        "files": {FACTORS_FILE: factors,
                  THUMBNAIL_FILE: thumbnail_png(model, options.thumbnail_size)},
        "row": {"parameterization": model.parameterization,
                "resolution": list(model.resolution), "packs": int(model.packs),
                "terms": int(model.terms), "spectral_size": int(model.spectral_size),
                "bytes": int(len(factors)), "model_bytes": int(model.nbytes),
                "de94": {k: float(stats[k]) for k in ("mean", "p95", "max")},
                "seconds": time.perf_counter() - started},
    }

