"""core/brdf/job.factor_material: one model per measured pack count, the series' figures
measured on exactly those models."""

import numpy as np

from spectral_materials.core.brdf import metrics, models
from spectral_materials.core.brdf.job import FactorOptions, factor_material


def _brdf():
    return models.make_model("oren_nayar", sigma=0.4, albedo=0.6)


def test_every_pack_count_keeps_its_own_model():
    job = factor_material(_brdf(), None, FactorOptions(parameterization="io", resolution=(8, 16, 8),
                                                       isotropic=True, packs=3))
    assert [m.packs for m in job.models] == [row["packs"] for row in job.series] == [1, 2, 3]
    assert job.models[-1] is job.model
    error = metrics.ProtocolError(_brdf())
    for row, model in zip(job.series, job.models):
        assert np.isclose(error.stats(model)["mean"], row["de94"]["mean"], rtol=0, atol=1e-12)
    means = [row["de94"]["mean"] for row in job.series]
    assert means[-1] < means[0]


def test_a_target_keeps_only_the_final_model():
    job = factor_material(_brdf(), None, FactorOptions(parameterization="io", resolution=(8, 16, 8),
                                                       isotropic=True, packs=4, target_de94=0.5))
    assert job.models == [job.model]
