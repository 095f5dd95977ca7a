"""A built library as an Asset Library .blend (blender/library): catalogs, previews and
stored factors; the open file left as it was; an asset appended into a new scene draws as
the same material factored directly from its file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from library_sources import make_sources, write_merl_file

from spectral_materials.blender.brdf import storage
from spectral_materials.blender.brdf.sphere import render_sphere
from spectral_materials.blender.library.asset_library import (
    register_asset_library,
    write_asset_library,
)
from spectral_materials.blender.library.catalogs import CATALOG_FILE, asset_names, catalog_id
from spectral_materials.core.brdf.factor import factor_brdf, resolve_parameterization
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.colour import spectra
from spectral_materials.core.formats.brdf_files import read_brdf_file
from spectral_materials.core.library import layout
from spectral_materials.core.library.build import build_library
from spectral_materials.core.library.settings import LibrarySettings

pytestmark = [pytest.mark.bpy]

SETTINGS = LibrarySettings(packs=2, theta_cells=8, basis=4, thumbnail_size=24)


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    root = tmp_path_factory.mktemp("assets")
    make_sources(root / "src", write_merl_file(root / "red.binary"))
    build_library([root / "src"], root / "lib", SETTINGS, workers=2)
    return root / "lib"


@pytest.fixture(scope="module")
def blend(library):
    before = (len(bpy.data.materials), len(bpy.data.images))
    out = write_asset_library(library)
    assert (len(bpy.data.materials), len(bpy.data.images)) == before   # nothing left behind
    return out


def _index(library) -> dict:
    return json.loads((library / layout.INDEX_FILE).read_text())


def test_the_blend_holds_every_material_as_an_asset_with_its_catalog(library, blend):
    index = _index(library)
    assert blend.materials == 10 and blend.blend.is_file()
    cats = (blend.blend.parent / CATALOG_FILE).read_text()
    assert "VERSION 1" in cats
    for path in ("src/studio/paints", "src/merl", "src/rgl", "src/studio", "src"):
        assert f"{catalog_id(path)}:{path}:" in cats
    with bpy.data.libraries.load(str(blend.blend), assets_only=True) as (source, _):
        names = sorted(source.materials)
    assert names == sorted(e["name"] for e in index["entries"])


def test_an_appended_asset_keeps_catalog_preview_and_factors(clean_scene, library, blend):
    entry = next(e for e in _index(library)["entries"] if e["name"] == "orange gloss")
    with bpy.data.libraries.load(str(blend.blend), link=False, assets_only=True) as (src, dst):
        dst.materials = ["orange gloss"]
    material = dst.materials[0]
    assert material.asset_data.catalog_id == catalog_id("src/studio/paints")
    assert "spectral" in [t.name for t in material.asset_data.tags]
    preview = material.preview
    assert tuple(preview.image_size) == (48, 24)
    from PIL import Image

    folder = library / layout.MATERIALS / entry["id"]
    with Image.open(folder / "thumbnail.png") as image:
        expected = np.asarray(image.convert("RGBA"), dtype=np.float32)[::-1] / 255.0
    pixels = np.empty(48 * 24 * 4, dtype=np.float32)
    preview.image_pixels_float.foreach_get(pixels)
    np.testing.assert_allclose(pixels.reshape(24, 48, 4), expected, atol=1.5 / 255)
    stored = storage.load_factored(material)
    original = FactoredBRDF.load(folder / "factors.npz")
    for a, b in zip([*stored.factors, stored.spectral], [*original.factors, original.spectral]):
        np.testing.assert_array_equal(a, np.asarray(b, dtype=a.dtype))


@pytest.mark.gpu
def test_an_appended_asset_draws_as_the_material_factored_directly(clean_scene, library,
                                                                    blend):
    """The whole path: a file, its library entry, the .blend, appended into a new scene, drawn;
    against the same file factored here with the library's settings and drawn."""
    entry = next(e for e in _index(library)["entries"] if e["name"] == "red plastic")
    with bpy.data.libraries.load(str(blend.blend), link=False, assets_only=True) as (src, dst):
        dst.materials = ["red plastic"]
    appended = storage.load_factored(dst.materials[0])
    brdf = read_brdf_file(entry["source"])
    wl = spectra.WAVELENGTHS_REFERENCE
    param, iso = resolve_parameterization(brdf, SETTINGS.parameterization, None, wl)
    # A MERL entry is drawn in the file's cells (core/library/entry.py).
    direct = factor_brdf(brdf, parameterization=param.name, isotropic=iso,
                         resolution=param.theta_resolution(SETTINGS.theta_cells),
                         packs=SETTINGS.packs, wavelengths=wl, spectral_basis=SETTINGS.basis,
                         cells=brdf.lookup_cells)
    assert appended.cells == direct.cells == brdf.lookup_cells
    for incidence, illuminant in ((0.0, "D65"), (60.0, "FL2")):
        a = render_sphere(appended, incidence, illuminant, 64)
        b = render_sphere(direct, incidence, illuminant, 64)
        assert (a[..., 3] > 0).sum() > 1000
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)
    # As a user drops it on an object: the spectral viewport draws the appended material,
    # and then the same object with the directly factored one.
    from spectral_materials.blender.viewport import draw

    cube = bpy.data.objects["Cube"]
    cube.data.materials.clear()
    cube.data.materials.append(dst.materials[0])
    seen, _ = draw.render_camera(clean_scene, width=96, height=72)
    storage.store_factored(dst.materials[0], direct)
    again, _ = draw.render_camera(clean_scene, width=96, height=72)
    assert (seen[..., 3] > 0).sum() > 500
    np.testing.assert_allclose(seen, again, rtol=1e-5, atol=1e-6)


def test_the_operator_writes_and_registers_the_library(clean_scene, library, tmp_path):
    result = bpy.ops.spectral.import_library(directory=str(library), register=True)
    assert result == {"FINISHED"}
    paths = [Path(bpy.path.abspath(lib.path)).resolve()
             for lib in bpy.context.preferences.filepaths.asset_libraries]
    assert library.resolve() in paths
    again = register_asset_library(library)
    assert [Path(bpy.path.abspath(lib.path)).resolve() for lib in
            bpy.context.preferences.filepaths.asset_libraries].count(library.resolve()) == 1
    assert again is not None


def test_a_folder_that_is_not_a_library_is_named_and_nothing_changes(clean_scene, tmp_path):
    other = tmp_path / "renders"
    other.mkdir()
    (other / "frame.png").write_bytes(b"\x89PNG")
    before = (len(bpy.data.materials), len(bpy.data.images))
    with pytest.raises(layout.NotALibrary, match="renders"):
        write_asset_library(other)
    assert (len(bpy.data.materials), len(bpy.data.images)) == before
    with pytest.raises(RuntimeError, match="renders"):       # the operator's error report
        bpy.ops.spectral.import_library(directory=str(other), register=False)
    empty = tmp_path / "empty"
    layout.open_library(empty, create=True)
    layout.write_index(empty, SETTINGS.as_dict(), [])
    with pytest.raises(layout.NotALibrary, match="no materials"):
        write_asset_library(empty)


def test_asset_names_tell_duplicates_apart():
    def entry(name, catalog, source):
        return {"name": name, "catalog": catalog, "source": source}

    entries = [entry("felt", "src/set1/studio/paints", "/a/felt.npz"),
               entry("felt", "src/set2/studio/paints", "/b/felt.npz"),
               entry("card", "src/set1/studio/paints", "/a/card.npz"),
               entry("gold", "lib/metals", "/c/gold.npz"),
               entry("gold", "lib/metals", "/c/gold.binary")]
    names = asset_names(entries)
    assert names[:3] == ["felt (set1)", "felt (set2)", "card"]
    assert len(set(names)) == 5 and all(n.startswith("gold (") for n in names[3:])


def test_the_users_catalogs_are_kept(clean_scene, library, tmp_path):
    target = tmp_path / "assets"
    target.mkdir()
    mine = "0b6c9c54-0000-4000-8000-000000000001:my things/chairs:my things-chairs"
    renamed = f"{catalog_id('src/merl')}:Measured/MERL:Measured-MERL"
    (target / CATALOG_FILE).write_text(f"VERSION 1\n\n{mine}\n{renamed}\n")
    write_asset_library(library, target / "spectral.blend")
    lines = (target / CATALOG_FILE).read_text().splitlines()
    assert mine in lines and renamed in lines              # kept, the rename too
    assert sum(line.startswith(catalog_id("src/merl")) for line in lines) == 1
    assert any(line.startswith(catalog_id("src/rgl")) for line in lines)


def test_import_reads_the_entries_on_disk(clean_scene, library, tmp_path):
    """After a build that was killed, the index may lag the entries: import trusts the disk."""
    import shutil

    copy = tmp_path / "lib"
    shutil.copytree(library, copy)
    index = json.loads((copy / layout.INDEX_FILE).read_text())
    index["entries"] = index["entries"][:3]
    (copy / layout.INDEX_FILE).write_text(json.dumps(index))
    assert write_asset_library(copy).materials == 10
