"""Same inputs, same bits: evaluation must not depend on where NumPy put its arrays.

Stored factors must reload bit-identical in another process (the extension's round
trip). NumPy's SIMD loops over strided views can round the last bit differently
with the memory alignment of the buffers, and BLAS products may sum in an order
that depends on threads and alignment; each process below allocates a different
amount first, so its arrays land at different alignments.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

_PROBE = textwrap.dedent("""
    import hashlib, sys
    import numpy as np
    junk = [np.empty(int(sys.argv[1]) + k) for k in range(5)]
    from spectral_materials.core import models, spectra
    from spectral_materials.core.factor import factor_brdf
    from spectral_materials.core.metrics import random_direction_pairs
    from spectral_materials.core.params import PARAMETERIZATIONS, get_parameterization
    wi, wo = random_direction_pairs(5000)
    digest = hashlib.sha256()
    for name in sorted(PARAMETERIZATIONS):
        digest.update(np.ascontiguousarray(get_parameterization(name).forward(wi, wo)))
    brdf = models.AshikhminShirley(nu=8, nv=32, diffuse=spectra.colorchecker_spectrum(6))
    for parameterization, isotropic, resolution, basis in (
            ("io", False, (6, 12, 6, 12), 6), ("io", True, (6, 12, 6), 4),
            ("hd", False, (6, 12, 6, 12), None)):
        model = factor_brdf(brdf, parameterization=parameterization, isotropic=isotropic,
                            resolution=resolution, packs=2, spectral_basis=basis)
        digest.update(model.evaluate(wi, wo).tobytes())
    print(digest.hexdigest())
""")


def test_evaluation_is_bit_reproducible_across_processes():
    digests = set()
    for junk in (1, 7, 33, 1001):
        run = subprocess.run([sys.executable, "-c", _PROBE, str(junk)], check=True,
                             capture_output=True, text=True, timeout=300)
        digests.add(run.stdout.strip())
    assert len(digests) == 1, digests
