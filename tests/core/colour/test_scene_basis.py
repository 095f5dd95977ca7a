"""Tests of spectral_materials.core.colour.scene_basis (the scene's own spectral basis).

The independent check recomputes every colour with colour-science's own
tables and ``sd_to_XYZ_integration`` (the ``colour.sd_to_XYZ`` computation on
the protocol's 5 nm grid), using only the chosen basis vectors from the module.
"""

from __future__ import annotations

import colour
import numpy as np
import pytest
from colour.colorimetry import sd_to_XYZ_integration

from spectral_materials.core import Cancelled
from spectral_materials.core.brdf import factor, models
from spectral_materials.core.colour import spectra
from spectral_materials.core.colour.basis import light_cmf_spectra, linear_model_basis
from spectral_materials.core.colour.scene_basis import (
    DEFAULT_SIZE,
    SceneBasisChoice,
    choose_scene_basis,
    describe_choice,
    lambertian_spectra,
)

WL = spectra.WAVELENGTHS_REFERENCE
SHAPE = colour.SpectralShape(380, 780, 5)
NAMES = spectra.colorchecker_names()


@pytest.fixture(scope="module")
def albedo() -> np.ndarray:
    """The 24 ColorChecker N Ohta reflectances (albedo), (24, 81)."""
    return np.stack([spectra.colorchecker(i) for i in range(1, 25)])


@pytest.fixture(scope="module")
def checker(albedo) -> dict[str, np.ndarray]:
    """One Lambertian material per patch, as f·cosθi at normal incidence."""
    return {name: lambertian_spectra(a) for name, a in zip(NAMES, albedo, strict=True)}


def lights(*names: str) -> dict[str, np.ndarray]:
    return {name: spectra.illuminant(name) for name in names}


def colour_xyz(reflectance: np.ndarray, illuminant: str, observer: str) -> np.ndarray:
    """XYZ (white Y = 1) of reflectances (K, 81) by colour-science alone."""
    with colour.utilities.suppress_warnings(colour_runtime_warnings=True):
        xyz = sd_to_XYZ_integration(reflectance, colour.MSDS_CMFS[observer],
                                    colour.SDS_ILLUMINANTS[illuminant], shape=SHAPE)
    return xyz / 100.0


def colour_de94(reference: np.ndarray, test: np.ndarray, white: np.ndarray) -> np.ndarray:
    xy = colour.XYZ_to_xy(white)
    return colour.delta_E(colour.XYZ_to_Lab(reference, xy), colour.XYZ_to_Lab(test, xy),
                          method="CIE 1994")


class TestReferenceCases:
    """Small scenes whose answer is known."""

    def test_single_reflectance_flat_light(self):
        # One reflectance and three light × CMF spectra span at most 4 dimensions: the
        # basis that spans them all reproduces the colour exactly.
        choice = choose_scene_basis({"patch 9": lambertian_spectra(spectra.colorchecker(9))},
                                    {"E": np.ones(WL.size)}, WL)
        assert isinstance(choice, SceneBasisChoice)
        assert choice.met
        assert 1 <= choice.size <= 4
        assert choice.basis.size == choice.size
        assert len(choice.per_size) == 4  # only 4 independent input spectra
        assert choice.per_size[-1]["max_de94"] < 1e-9
        assert choice.full_size == 4  # the fixed default, capped at what exists
        assert choice.worst_pair == ("E", "patch 9")
        assert choice.pairs == [{"light": "E", "material": "patch 9", "spectra": 1,
                                 "max_de94": choice.max_de94, "mean_de94": choice.max_de94}]

    def test_full_rank_projection_is_exact(self, checker):
        # 24 reflectances + 3 × 3 light × CMF spectra: at m = 33 the basis spans every input.
        choice = choose_scene_basis(checker, lights("D65", "FL2", "A"), WL, max_size=81)
        assert [d["size"] for d in choice.per_size] == list(range(1, 34))
        assert choice.per_size[-1]["max_de94"] < 1e-9
        assert choice.per_size[-1]["mean_de94"] < 1e-10

    def test_full_grid_basis_is_exact(self):
        # More spectra than samples: m = L, Ψ is square orthogonal, ΨΨᵀ = I.
        rng = np.random.default_rng(3)
        wl = spectra.wavelength_grid(400, 700, 20)
        materials = {"noise": rng.uniform(0.0, 0.3, (40, wl.size))}
        choice = choose_scene_basis(materials, {"E": np.ones(wl.size)}, wl, max_size=100,
                                    tolerance_de94=1e-6)
        assert len(choice.per_size) == wl.size
        assert choice.per_size[-1]["max_de94"] < 1e-9
        assert choice.met and choice.size <= wl.size

    def test_basis_is_linear_model_prefix(self, checker):
        choice = choose_scene_basis(checker, lights("FL11"), WL)
        reflectances = np.concatenate([np.atleast_2d(v) for v in checker.values()])
        expected = linear_model_basis(WL, reflectances, light_cmf_spectra(["FL11"], WL),
                                      count=choice.size)
        np.testing.assert_allclose(choice.basis.vectors, expected.vectors, atol=1e-12)
        np.testing.assert_array_equal(choice.basis.wavelengths, WL)
        np.testing.assert_allclose(choice.basis.vectors.T @ choice.basis.vectors,
                                   np.eye(choice.size), atol=1e-12)


class TestChoice:
    """The choice rule, the error curve and the per-pair report."""

    def test_smallest_size_meeting_tolerance(self, checker):
        choice = choose_scene_basis(checker, lights("D65", "FL2", "A"), WL)
        curve = [d["max_de94"] for d in choice.per_size]
        assert choice.met and choice.max_de94 <= 0.05
        assert choice.max_de94 == curve[choice.size - 1]
        assert all(e > 0.05 for e in curve[: choice.size - 1])
        assert len(curve) == 16
        assert all(0 <= d["mean_de94"] <= d["max_de94"] for d in choice.per_size)

    def test_pairs(self, checker):
        choice = choose_scene_basis(checker, lights("D65", "FL2", "A"), WL)
        assert len(choice.pairs) == 3 * 24
        assert [p["light"] for p in choice.pairs[:25]] == ["D65"] * 24 + ["FL2"]
        assert [p["material"] for p in choice.pairs[:24]] == NAMES
        worst = max(choice.pairs, key=lambda p: p["max_de94"])
        assert (worst["light"], worst["material"]) == choice.worst_pair
        assert worst["max_de94"] == choice.max_de94
        assert all(p["spectra"] == 1 and p["mean_de94"] == p["max_de94"] for p in choice.pairs)

    def test_tighter_tolerance_needs_at_least_as_many(self, checker):
        sizes = [choose_scene_basis(checker, lights("D65", "FL2", "A"), WL, max_size=40,
                                    tolerance_de94=t).size for t in (1.0, 0.05, 0.01)]
        assert sizes == sorted(sizes)
        assert sizes[-1] > sizes[0]

    def test_not_met(self, checker):
        choice = choose_scene_basis(checker, lights("D65", "FL2"), WL, max_size=3)
        assert not choice.met
        assert choice.size == 3 and choice.basis.size == 3
        assert choice.max_de94 == choice.per_size[-1]["max_de94"] > 0.05
        assert describe_choice(choice).endswith("tolerance not met")

    def test_error_curve_is_not_monotone_but_bounded(self, checker, albedo):
        """What is guaranteed, and what is not.

        Peercy's bases are nested, so each spectrum's projection residual ‖(I − P_m) s‖
        never grows with m. The colour error through the basis is the dot product of two
        residuals, ``R (I − P_m) W = ((I − P_m) R)·((I − P_m) W)``: bounded by the product
        of their norms (non-increasing, 0 at full rank), but its discarded terms can cancel,
        so the error itself — and ΔE94 — can grow from m to m + 1. The ColorChecker under
        D65 shows it (m = 1 → 2).
        """
        choice = choose_scene_basis(checker, lights("D65"), WL, max_size=27)
        curve = np.array([d["max_de94"] for d in choice.per_size])
        assert np.any(np.diff(curve) > 0)      # not monotone
        assert curve[-1] < 1e-9                # but exact at full rank
        assert curve[11] < 0.05 < curve[:11].min()  # and small from m = 12 on, as chosen
        psi = linear_model_basis(WL, albedo, np.stack(
            [spectra.illuminant("D65") * spectra.cmfs()[:, c] for c in range(3)]),
            count=27).vectors
        weights = spectra.illuminant("D65")[:, None] * spectra.cmfs()
        bound_prev = np.inf
        for m in range(1, 28):
            p = psi[:, :m] @ psi[:, :m].T
            r_res = albedo - albedo @ p
            w_res = weights - p @ weights
            error = np.abs(albedo @ weights - (albedo @ psi[:, :m]) @ (psi[:, :m].T @ weights))
            bound = np.linalg.norm(r_res, axis=1)[:, None] * np.linalg.norm(w_res, axis=0)
            assert np.all(error <= bound * (1 + 1e-9) + 1e-9)
            assert np.all(bound <= bound_prev * (1 + 1e-9) + 1e-12)
            bound_prev = bound

    def test_fluorescent_needs_more_than_d65(self, checker):
        def size(names, tolerance):
            return choose_scene_basis(checker, lights(*names), WL, max_size=40,
                                      tolerance_de94=tolerance).size

        d65 = size(["D65"], 0.5)
        assert size(["FL2"], 0.5) > d65
        assert size(["FL11"], 0.5) > d65
        assert size(["D65", "FL2", "FL11"], 0.05) > size(["D65"], 0.05)

    def test_light_by_name(self, checker):
        a = choose_scene_basis(checker, {"lamp": "FL2"}, WL)
        b = choose_scene_basis(checker, {"lamp": spectra.illuminant("FL2") * 7.0}, WL)
        assert a.size == b.size
        assert a.max_de94 == pytest.approx(b.max_de94, rel=1e-9, abs=1e-12)

    def test_several_spectra_per_material(self):
        brdf = models.OrenNayar(albedo=spectra.colorchecker_spectrum(12), sigma=0.3)
        samples = factor.sample_brdf_spectra(brdf, WL, True)
        materials = {"rough": samples, "flat": lambertian_spectra(spectra.colorchecker(3))}
        choice = choose_scene_basis(materials, lights("D65", "FL11"), WL)
        pair = next(p for p in choice.pairs if p["material"] == "rough" and p["light"] == "FL11")
        assert pair["spectra"] == samples.shape[0]
        assert pair["mean_de94"] <= pair["max_de94"] <= choice.max_de94


class TestIndependentCheck:
    """The chosen basis meets the tolerance by colour-science's own computation."""

    @pytest.mark.parametrize(("names", "observer"), [
        (("D65", "FL2", "A"), spectra.OBSERVER),
        (("FL11",), spectra.OBSERVER),
        (("D65", "FL2"), "CIE 1964 10 Degree Standard Observer"),
    ])
    @pytest.mark.parametrize("tolerance", [0.05, 0.01])
    def test_meets_tolerance(self, checker, albedo, names, observer, tolerance):
        choice = choose_scene_basis(checker, lights(*names), WL, tolerance_de94=tolerance,
                                    max_size=40, observer=observer)
        assert choice.met
        psi = choice.basis.vectors
        # (Ψᵀ R)·(Ψᵀ W) = Σ_λ (ΨΨᵀ R)(λ) W(λ): the projected reflectance through colour.
        projected = albedo @ psi @ psi.T
        worst = 0.0
        for name in names:
            white = colour_xyz(np.ones((1, WL.size)), name, observer)[0]
            reference = colour_xyz(albedo, name, observer)
            test = colour_xyz(projected, name, observer)
            de = colour_de94(reference, test, white)
            worst = max(worst, float(de.max()))
            pair_max = [p["max_de94"] for p in choice.pairs if p["light"] == name]
            np.testing.assert_allclose(de, pair_max, rtol=1e-6, atol=1e-9)
        assert worst <= tolerance
        assert worst == pytest.approx(choice.max_de94, rel=1e-6, abs=1e-9)
        # One size less would not have done (the choice is the smallest).
        if choice.size > 1:
            assert choice.per_size[choice.size - 2]["max_de94"] > tolerance

    def test_default_observer_is_1931(self, checker):
        a = choose_scene_basis(checker, lights("FL2"), WL)
        b = choose_scene_basis(checker, lights("FL2"), WL, observer="1931")
        c = choose_scene_basis(checker, lights("FL2"), WL, observer="1964")
        assert a.per_size == b.per_size
        assert a.per_size != c.per_size


class TestDescribe:
    def test_line(self, checker):
        choice = choose_scene_basis({"Paint": checker[NAMES[8]]}, lights("FL2"), WL)
        line = describe_choice(choice)
        assert line.startswith(f"basis {choice.size} of {choice.full_size} coefficients, "
                               "max ΔE94 ")
        assert line.endswith("(FL2 × Paint)")

    def test_more_than_default(self, checker):
        choice = choose_scene_basis(checker, lights("D65", "FL2", "A"), WL)
        assert choice.full_size == DEFAULT_SIZE == 8
        assert choice.size > DEFAULT_SIZE
        assert describe_choice(choice).startswith(
            f"basis {choice.size} coefficients (default 8), max ΔE94 ")


class TestValidation:
    """Bad input raises a ValueError naming what is wrong and where."""

    def test_empty(self, checker):
        with pytest.raises(ValueError, match="no materials"):
            choose_scene_basis({}, lights("D65"), WL)
        with pytest.raises(ValueError, match="no lights"):
            choose_scene_basis(checker, {}, WL)

    def test_not_mappings(self, albedo):
        with pytest.raises(TypeError, match="mapping"):
            choose_scene_basis([albedo], lights("D65"), WL)
        with pytest.raises(TypeError, match="mapping"):
            choose_scene_basis({"a": albedo}, [spectra.illuminant("D65")], WL)

    @pytest.mark.parametrize("shape", [(2, 3, 81), (1, 1, 1, 81), ()])
    def test_n_dimensional(self, shape):
        values = np.full(shape, 0.2)
        with pytest.raises(ValueError, match=r"material 'paint'.*\(K, L\)"):
            choose_scene_basis({"paint": values}, lights("D65"), WL)

    @pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
    def test_non_finite_material(self, albedo, bad):
        values = albedo[:3].copy()
        values[1, 40] = bad
        with pytest.raises(ValueError, match="material 'paint'.*non-finite"):
            choose_scene_basis({"ok": albedo[5], "paint": values}, lights("D65"), WL)

    def test_negative_material(self, albedo):
        values = albedo[:3].copy()
        values[2, 10] = -1e-3
        with pytest.raises(ValueError, match="material 'paint'.*negative"):
            choose_scene_basis({"paint": values}, lights("D65"), WL)

    def test_material_lengths(self, albedo):
        with pytest.raises(ValueError, match="material 'paint'.*40 samples.*81"):
            choose_scene_basis({"paint": albedo[:, :40]}, lights("D65"), WL)
        with pytest.raises(ValueError, match="material 'paint' has no spectra"):
            choose_scene_basis({"paint": np.zeros((0, 81))}, lights("D65"), WL)

    @pytest.mark.parametrize("bad", [np.nan, np.inf])
    def test_non_finite_light(self, albedo, bad):
        spd = spectra.illuminant("FL2")
        spd[30] = bad
        with pytest.raises(ValueError, match="light 'lamp'.*non-finite"):
            choose_scene_basis({"a": albedo}, {"D65": "D65", "lamp": spd}, WL)

    def test_negative_light(self, albedo):
        spd = spectra.illuminant("FL2") - 1.0
        with pytest.raises(ValueError, match="light 'lamp'.*negative"):
            choose_scene_basis({"a": albedo}, {"lamp": spd}, WL)

    def test_light_shape_and_luminance(self, albedo):
        with pytest.raises(ValueError, match="light 'lamp'.*shape"):
            choose_scene_basis({"a": albedo}, {"lamp": np.ones(40)}, WL)
        with pytest.raises(ValueError, match="light 'lamp'.*shape"):
            choose_scene_basis({"a": albedo}, {"lamp": np.ones((2, 81))}, WL)
        with pytest.raises(ValueError, match="light 'lamp'.*no luminance"):
            choose_scene_basis({"a": albedo}, {"lamp": np.zeros(81)}, WL)
        with pytest.raises(ValueError, match="light 'lamp'.*unknown illuminant"):
            choose_scene_basis({"a": albedo}, {"lamp": "D75"}, WL)

    def test_options(self, albedo):
        for tolerance in (0.0, -1.0, np.nan, np.inf):
            with pytest.raises(ValueError, match="tolerance_de94"):
                choose_scene_basis({"a": albedo}, lights("D65"), WL, tolerance_de94=tolerance)
        for max_size in (0, -3, 2.5, True):
            with pytest.raises(ValueError, match="max_size"):
                choose_scene_basis({"a": albedo}, lights("D65"), WL, max_size=max_size)
        with pytest.raises(ValueError, match="unknown observer"):
            choose_scene_basis({"a": albedo}, lights("D65"), WL, observer="2015")
        with pytest.raises(ValueError, match="strictly increasing"):
            choose_scene_basis({"a": albedo}, lights("D65"), WL[::-1])


class TestProgress:
    def test_callback_and_cancel(self, checker):
        seen = []
        choose_scene_basis(checker, lights("D65"), WL,
                           callback=lambda f, m: seen.append((f, m)) and False)
        fractions = [f for f, _ in seen]
        assert fractions[0] == 0.0 and fractions[-1] == 1.0
        assert fractions == sorted(fractions)
        assert all(m.startswith("scene basis") for _, m in seen)
        with pytest.raises(Cancelled):
            choose_scene_basis(checker, lights("D65"), WL, callback=lambda f, m: f >= 0.1)
        with pytest.raises(Cancelled):
            choose_scene_basis(checker, lights("D65"), WL, callback=lambda f, m: True)


def test_large_scene_chunks_match(monkeypatch, albedo):
    """Chunking over spectra (across material boundaries) does not change the result."""
    from spectral_materials.core.colour import scene_basis

    rng = np.random.default_rng(1)
    materials = {f"m{i}": lambertian_spectra(albedo[i] * rng.uniform(0.5, 1.0, (7, 1)))
                 for i in range(10)}
    whole = choose_scene_basis(materials, lights("A", "FL11"), WL)
    monkeypatch.setattr(scene_basis, "_CHUNK_VALUES", 16 * 5)  # 5 spectra per chunk
    chunked = choose_scene_basis(materials, lights("A", "FL11"), WL)
    assert chunked.size == whole.size
    for a, b in zip(chunked.per_size + chunked.pairs, whole.per_size + whole.pairs, strict=True):
        assert a.keys() == b.keys()
        for key in a:
            if isinstance(b[key], str):  # light and material names: exact (approx of a str
                assert a[key] == b[key]  # with rel= is a TypeError since pytest 9)
            else:
                assert a[key] == pytest.approx(b[key], rel=1e-12, abs=1e-15)
