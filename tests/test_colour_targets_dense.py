"""benchmarks/colour_targets.py's dense grazing bands: the pairs lie where they say, are
distributed as the protocol's pairs given the band, and the falls check reads them."""

import numpy as np

from benchmarks import colour_targets as ct


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


def test_grazing_pairs_follow_uniform_pairs_given_the_band():
    """Against rejection from the protocol's own sampler (uniform in solid angle): the
    other direction's cosine is uniform on [grazing cosine, 1] (mean ≈ 0.5 here), the
    grazing cosine uniform in the band, azimuths uniform."""
    rng = np.random.default_rng(1)
    wi, wo = ct.grazing_pairs((80.0, 85.0), 20000, rng, True)
    low, high = np.cos(np.radians(85.0)), np.cos(np.radians(80.0))
    # Reference values from the joint density of two uniform cosines on the band.
    c = np.linspace(low, high, 20001)
    weight = 1.0 - c
    expected_grazing = np.sum(c * weight) / np.sum(weight)
    expected_other = np.sum((1.0 + c) / 2.0 * weight) / np.sum(weight)
    assert abs(wi[:, 2].mean() - expected_grazing) < 1e-3
    assert abs(wo[:, 2].mean() - expected_other) < 5e-3
    assert abs(np.mean(np.cos(np.arctan2(wi[:, 1], wi[:, 0])))) < 0.02


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
