"""The BTF job: a UBO2003 archive or a generated material → fit → drawable, with figures."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.btf import container as btf, generate as btf_generate, job as btf_job
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra
from spectral_materials.core.formats import ubo_btf


def _ubo_archive(path, texels=4):
    """A UBO2003-layout archive of a generated corduroy (sRGB-encoded, RGB)."""
    views = btf.ring_directions(((0.0, 1), (30.0, 6), (60.0, 8)))
    data = btf_generate.generate_btf("corduroy", texels=texels, views=views, lights=views)
    xyz = data.values.astype(np.float64) @ colour_pipeline.xyz_weights(
        "D65", data.wavelengths) / np.pi
    rgb = np.clip(colour_pipeline.xyz_to_linear_srgb(xyz), 0.0, 1.0)
    angles = np.array([[0, 0]] + [[30, 60 * i] for i in range(6)]
                      + [[60, 45 * i] for i in range(8)])
    ubo_btf.write_ubo2003(path, colour_pipeline.srgb_encode(rgb), angles, angles)
    return data


def test_a_ubo_archive_is_fitted_and_drawable(tmp_path):
    path = tmp_path / "corduroy.zip"
    _ubo_archive(path)
    for model in ("RFP", "RFNL"):
        result = btf_job.run_btf_job(btf_job.BTFJob("ubo2003", str(path), texels=0,
                                                    model=model, lobes=1))
        f = result.figures
        assert f["views"] == 15 and f["lights"] == 15 and f["texels"] == [4, 4]
        assert 0 < f["epsilon_avg"] < 0.05
        d = result.drawable
        assert d.kind == model and np.isfinite(d.params).all()
        # RGB albedo uplifted with Smits: spectra on the reference grid, non-negative.
        spectra_ = d.coefficients.astype(np.float64) @ d.basis.T
        assert spectra_.shape[-1] == len(spectra.WAVELENGTHS_REFERENCE)
        assert spectra_.min() > -1e-3


def test_a_cropped_window_and_progress(tmp_path):
    path = tmp_path / "corduroy.zip"
    _ubo_archive(path, texels=6)
    seen = []
    result = btf_job.run_btf_job(btf_job.BTFJob("ubo2003", str(path), texels=3, model="RFP"),
                                 lambda f, m: seen.append(f))
    assert result.figures["texels"] == [3, 3]
    assert seen[0] == 0.0 and seen[-1] == 1.0 and np.all(np.diff(seen) > -1e-12)


def test_generated_job_and_bad_settings():
    result = btf_job.run_btf_job(btf_job.BTFJob("knit", texels=3, model="RFP"))
    assert result.figures["source"] == "knit" and result.drawable.texels == (3, 3)
    with pytest.raises(ValueError, match="unknown BTF source"):
        btf_job.run_btf_job(btf_job.BTFJob("velvet"))
    with pytest.raises(ValueError, match="texels per side"):
        btf_job.run_btf_job(btf_job.BTFJob("corduroy", texels=500))
    with pytest.raises(ValueError, match="1..3 lobes"):
        btf_job.run_btf_job(btf_job.BTFJob("corduroy", lobes=5))
