"""benchmarks/colour_targets.py's dense grazing bands: the pairs lie where they say, are
distributed as the protocol's pairs given the band, and the falls check reads them."""

import numpy as np
from scipy import stats

from benchmarks import colour_targets as ct
from spectral_materials.core.brdf import metrics


def test_grazing_pairs_lie_in_their_band_with_the_other_direction_higher():
    rng = np.random.default_rng(0)
    for incidence in (True, False):
        wi, wo = ct.grazing_pairs((89.5, 89.9), 5000, rng, incidence)
        assert wi.shape == wo.shape == (5000, 3)
        assert np.allclose(np.linalg.norm(wi, axis=1), 1.0)
        assert np.allclose(np.linalg.norm(wo, axis=1), 1.0)
        grazing, other = (wi, wo) if incidence else (wo, wi)
        theta = np.degrees(np.arccos(grazing[:, 2]))
        assert theta.min() >= 89.5 and theta.max() <= 89.9
        assert np.all(other[:, 2] >= grazing[:, 2])


def _relative_azimuth(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.mod(np.arctan2(a[:, 1], a[:, 0]) - np.arctan2(b[:, 1], b[:, 0]), 2 * np.pi)


def test_grazing_pairs_are_the_protocols_pairs_given_the_band():
    """Against the protocol's own sampler (uniform in solid angle) filtered to the band,
    on each side: the grazing cosine, the other's and the relative azimuth have the same
    distributions (two-sample Kolmogorov–Smirnov)."""
    band = (80.0, 85.0)
    low, high = np.cos(np.radians(band[1])), np.cos(np.radians(band[0]))
    rng = np.random.default_rng(4)
    wi_all = metrics.uniform_hemisphere(rng, 400_000)
    wo_all = metrics.uniform_hemisphere(rng, 400_000)
    for incidence in (True, False):
        grazing_all, other_all = (wi_all, wo_all) if incidence else (wo_all, wi_all)
        keep = (grazing_all[:, 2] >= low) & (grazing_all[:, 2] <= high) & \
            (other_all[:, 2] >= grazing_all[:, 2])
        assert keep.sum() > 10_000
        wi, wo = ct.grazing_pairs(band, 10_000, rng, incidence)
        grazing, other = (wi, wo) if incidence else (wo, wi)
        for ours, theirs in ((grazing[:, 2], grazing_all[keep, 2]),
                             (other[:, 2], other_all[keep, 2]),
                             (_relative_azimuth(wi, wo),
                              _relative_azimuth(wi_all[keep], wo_all[keep]))):
            assert stats.ks_2samp(ours, theirs).pvalue > 1e-3


def test_a_sampler_without_the_rejection_is_told_apart():
    """The KS comparison above, against the same filtered reference, rejects the grazing
    cosine drawn uniform in the band (the other direction not kept above it): the
    mistake it guards against (a wide band, where the two differ most)."""
    band = (60.0, 85.0)
    low, high = np.cos(np.radians(band[1])), np.cos(np.radians(band[0]))
    rng = np.random.default_rng(5)
    wi_all = metrics.uniform_hemisphere(rng, 200_000)
    wo_all = metrics.uniform_hemisphere(rng, 200_000)
    keep = (wi_all[:, 2] >= low) & (wi_all[:, 2] <= high) & (wo_all[:, 2] >= wi_all[:, 2])
    wrong = rng.uniform(low, high, 20_000)
    assert stats.ks_2samp(wrong, wi_all[keep, 2]).pvalue < 1e-6
    wi, _ = ct.grazing_pairs(band, 20_000, rng, True)
    assert stats.ks_2samp(wi[:, 2], wi_all[keep, 2]).pvalue > 1e-3


def test_dense_stats_and_the_falls_check():
    bands = ct.DENSE_BANDS_DEG
    falling = {("incidence", b): np.full(10, 1.0 / (k + 1)) for k, b in enumerate(bands)}
    growing = {("view", b): np.full(10, 1.0 + k) for k, b in enumerate(bands)}
    out = ct.dense_stats({**falling, **growing})
    assert out["incidence"]["falls"] and not out["view"]["falls"]
    first = out["incidence"]["bands"][0]
    assert (first["from"], first["to"], first["count"], first["mean"], first["se"]) == \
        (89.0, 89.5, 10, 1.0, 0.0)
    nan = {**falling, ("incidence", bands[1]): np.array([np.nan, 1.0])}
    assert not ct.dense_stats({**nan, **growing})["incidence"]["falls"]
