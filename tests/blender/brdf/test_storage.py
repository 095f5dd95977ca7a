"""Factor packs on float images: layout round trip, bit-identical reload, clean removal."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import bpy
import numpy as np
import pytest
from blender_helpers import spectral_material

from spectral_materials.blender.brdf import storage
from spectral_materials.core.brdf import models
from spectral_materials.core.brdf.factor import factor_brdf
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.brdf.metrics import random_direction_pairs
from spectral_materials.core.colour import spectra

pytestmark = pytest.mark.bpy


def _random_model(terms: int, basis_size: int | None, seed: int = 0) -> FactoredBRDF:
    rng = np.random.default_rng(seed)
    resolution = (5, 9, 4)
    wl = spectra.WAVELENGTHS_REFERENCE
    basis = None
    size = wl.size
    if basis_size is not None:
        basis = np.linalg.qr(rng.standard_normal((wl.size, basis_size)))[0].astype(np.float32)
        size = basis_size
    return FactoredBRDF(
        parameterization="io_iso", resolution=resolution, wavelengths=wl, basis=basis,
        cosine_weighted=True, factors=[rng.standard_normal((n, terms)).astype(np.float32)
                                       for n in resolution],
        spectral=rng.standard_normal((size, terms)).astype(np.float32), pack_size=4)


@pytest.mark.parametrize("terms, basis_size", [(1, None), (4, 3), (7, 8), (12, 5)])
def test_pack_unpack_round_trip(terms, basis_size):
    model = _random_model(terms, basis_size)
    pixels = storage.pack_pixels(model)
    groups = -(-terms // 4)
    basis_rows = 0 if basis_size is None else -(-basis_size // 4)
    assert pixels.shape == (4 * groups + basis_rows, 81, 4)
    lengths = list(model.resolution) + [model.spectral_size]
    arrays, basis = storage.unpack_pixels(pixels, lengths, terms,
                                          None if basis_size is None else (81, basis_size))
    for a, b in zip(arrays, model.factors + [model.spectral]):
        np.testing.assert_array_equal(a, b)
    if basis_size is not None:
        np.testing.assert_array_equal(basis, model.basis)
    # One pack is one texel row: terms 0..3 of axis 1 at sample 2 are row `groups`, texel 2.
    np.testing.assert_array_equal(pixels[groups, 2, : min(terms, 4)],
                                  model.factors[1][2, : min(terms, 4)])


def test_store_and_load_in_memory_is_bit_identical(clean_scene):
    material = spectral_material()
    model = _random_model(6, 4)
    model.report = {"de94": {"mean": 0.1, "p95": 0.2, "max": 0.3}, "seconds": 1.5}
    stored = storage.store_factored(material, model, input_hash="abc")
    loaded = storage.load_factored(material)
    wi, wo = random_direction_pairs(500)
    np.testing.assert_array_equal(loaded.evaluate(wi, wo), stored.evaluate(wi, wo))
    image = material.spectral.result.image
    assert image.packed_file is not None and image.use_fake_user
    assert not image.use_half_precision and image.is_float
    assert material.spectral.result.de94_p95 == pytest.approx(0.2)


def test_restore_replaces_images_without_orphans(clean_scene):
    material = spectral_material()
    storage.store_factored(material, _random_model(4, 3))
    storage.store_factored(material, _random_model(8, 3, seed=1))
    names = [i.name for i in bpy.data.images if i.name.startswith(storage.IMAGE_PREFIX)]
    assert names == [material.spectral.result.image.name]
    assert storage.clear_factored(material)
    assert not any(i.name.startswith(storage.IMAGE_PREFIX) for i in bpy.data.images)
    with pytest.raises(storage.StorageError, match="no stored factors"):
        storage.load_factored(material)


def test_load_refuses_a_damaged_image(clean_scene):
    material = spectral_material()
    storage.store_factored(material, _random_model(4, 3))
    material.spectral.result.image.scale(81, 2)
    with pytest.raises(storage.StorageError, match="metadata needs"):
        storage.load_factored(material)


def test_load_refuses_an_unknown_edge_rule_and_names_the_material(clean_scene):
    """A hand-edited or future file whose edge rule this version does not know."""
    material = spectral_material()
    storage.store_factored(material, _random_model(4, 3))
    assert storage.load_factored(material).edge in ("linear", "horizon")
    material.spectral.result.edge = "bogus"
    with pytest.raises(storage.StorageError, match=r"Material '.*'.*unknown edge rule 'bogus'"):
        storage.load_factored(material)


def test_load_refuses_a_hostile_oren_nayar_lobe_and_names_the_material(clean_scene):
    """A stored Oren–Nayar lobe with exponents, with a second spectrum (which the GPU
    would multiply by 0 in float32: NaN from a huge one), or an unknown family."""
    material = spectral_material()
    brdf = models.make_model("oren_nayar", sigma=0.5,
                             albedo=(spectra.WAVELENGTHS_REFERENCE, spectra.colorchecker(9)))
    model = factor_brdf(brdf, parameterization="io_iso", isotropic=True,
                        resolution=(6, 12, 6), packs=1, spectral_basis=4, lobe="oren_nayar")
    storage.store_factored(material, model)
    result = material.spectral.result
    assert storage.load_factored(material).lobe.family == "oren_nayar"
    good = list(result["lobe_spectral"])
    for change, message in ((lambda: result.__setitem__("lobe_exponents", [12.0, 12.0]),
                             "no exponents"),
                            (lambda: result.__setitem__("lobe_spectral",
                                                        [v if i % 2 == 0 else 1e38
                                                         for i, v in enumerate(good)]),
                             "second spectrum must be 0"),
                            (lambda: setattr(result, "lobe", "phong"),
                             "unknown lobe family")):
        change()
        with pytest.raises(storage.StorageError, match=f"Material.*{message}"):
            storage.load_factored(material)
        result["lobe_exponents"], result["lobe_spectral"] = [0.0, 0.0], good
        result.lobe = "oren_nayar"
    assert storage.load_factored(material).lobe.family == "oren_nayar"


_REOPEN = textwrap.dedent("""
    import sys, numpy as np, bpy
    from spectral_materials import blender as addon
    from spectral_materials.blender import storage
    from spectral_materials.core.metrics import random_direction_pairs
    addon.register()
    bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
    model = storage.load_factored(bpy.data.materials["Paint"])
    wi, wo = random_direction_pairs(2000)
    np.save(sys.argv[2], model.evaluate(wi, wo))
""")


def test_factor_save_reopen_in_fresh_process_is_bit_identical(clean_scene, tmp_path):
    material = spectral_material(model="ASHIKHMIN_SHIRLEY", theta_cells=8, packs=2)
    material.spectral.nu = material.spectral.nv = 16
    assert bpy.ops.spectral.factor_material() == {"FINISHED"}
    in_memory = storage.load_factored(material)
    wi, wo = random_direction_pairs(2000)
    expected = in_memory.evaluate(wi, wo)
    blend = tmp_path / "round_trip.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "values.npy"
    subprocess.run([sys.executable, "-c", _REOPEN, str(blend), str(out)], check=True,
                   capture_output=True, timeout=300)
    np.testing.assert_array_equal(np.load(out), expected)
    report = json.loads(material.spectral.result.report_json)
    assert report["de94"]["count"] == 20000


def test_stored_model_matches_the_fit(clean_scene):
    """What storage keeps is the fit rounded to float32, nothing else."""
    material = spectral_material()
    brdf = models.OrenNayar(albedo=spectra.colorchecker_spectrum(9), sigma=0.3)
    model = factor_brdf(brdf, resolution=(8, 16, 8), packs=1, spectral_basis=4)
    stored = storage.store_factored(material, model)
    wi, wo = random_direction_pairs(300)
    np.testing.assert_allclose(stored.evaluate(wi, wo), model.evaluate(wi, wo), rtol=1e-5,
                               atol=1e-7)
