"""A spectral material library as a Blender Asset Library .blend.

Each entry becomes a material marked as an asset. It carries its factors as the add-on
stores them (``brdf.storage``), its catalog by source, and its thumbnail as the preview.
The .blend is written with ``bpy.data.libraries.write``, so only these materials and
their images go in, and the open file is left as it was: the materials are made, written
and removed again. ``blender_assets.cats.txt`` goes beside the .blend. Registering the
folder under Preferences > File Paths > Asset Libraries puts the materials in the Asset
Browser.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np

from ...core.brdf.factored import FactoredBRDF
from ...core.library import layout
from ...core.progress import ProgressCallback, report
from ..brdf import storage
from .catalogs import asset_names, catalog_id, write_catalogs

DEFAULT_BLEND = "spectral_library.blend"


@dataclass
class AssetLibraryFile:
    blend: Path
    catalog_file: Path
    materials: int
    catalogs: int


def _preview_pixels(path: Path) -> tuple[tuple[int, int], np.ndarray]:
    """A thumbnail PNG as Blender's preview wants it: (width, height) and RGBA floats,
    row 0 at the bottom."""
    from PIL import Image

    with Image.open(path) as image:
        rgba = np.asarray(image.convert("RGBA"), dtype=np.float32) / 255.0
    return (rgba.shape[1], rgba.shape[0]), rgba[::-1].ravel()


def _make_material(entry: dict, folder: Path, name: str):
    model = FactoredBRDF.load(folder / layout.FACTORS_FILE)
    material = bpy.data.materials.new(name)
    try:
        material.spectral.enabled = True
        storage.store_factored(material, model, input_hash=entry.get("input_sha256", ""))
        material.asset_mark()
        asset = material.asset_data
        asset.catalog_id = catalog_id(entry["catalog"])
        asset.description = (f"{entry['format']}: ΔE94 mean {entry['de94']['mean']:.3f}, "
                             f"{entry['packs']} packs; from {Path(entry['source']).name}")
        for tag in ("spectral", Path(entry["source"]).suffix.lstrip(".")):
            asset.tags.new(tag, skip_if_exists=True)
        size, pixels = _preview_pixels(folder / layout.THUMBNAIL_FILE)
        preview = material.preview_ensure()
        preview.image_size = size
        preview.image_pixels_float.foreach_set(pixels)
    except Exception:
        _remove(material)
        raise
    return material


def _remove(material) -> None:
    storage.clear_factored(material)          # its factor and plot images
    bpy.data.materials.remove(material)


def write_asset_library(library: str | Path, blend: str | Path | None = None, *,
                        callback: ProgressCallback | None = None) -> AssetLibraryFile:
    """Write the library folder ``library`` as an Asset Library .blend (default
    ``LIB/spectral_library.blend``) and its catalog file; the open file is unchanged.
    NotALibrary names a folder that is not a library."""
    if not hasattr(bpy.types.Material, "spectral"):
        raise RuntimeError("the Spectral Materials add-on is not registered: call "
                           "spectral_materials.blender.register() first")
    root = layout.open_library(library, create=False)
    # The entries on disk, not the index: after a build that was killed they are the truth.
    entries = layout.read_entries(root)
    if not entries:
        raise layout.NotALibrary(f"{root}: the library has no materials to import")
    target = Path(blend) if blend is not None else root / DEFAULT_BLEND
    target.parent.mkdir(parents=True, exist_ok=True)
    made = []
    try:
        for count, (entry, name) in enumerate(zip(entries, asset_names(entries)), start=1):
            report(callback, (count - 1) / len(entries), name)
            made.append(_make_material(entry, root / layout.MATERIALS / entry["id"], name))
        report(callback, 1.0, f"writing {target.name}")
        partial = target.with_name(f".{target.name}.partial")
        bpy.data.libraries.write(str(partial), set(made), fake_user=True, compress=True)
        partial.replace(target)
    finally:
        for material in made:
            _remove(material)
    catalogs = {entry["catalog"] for entry in entries}
    cats = write_catalogs(target.parent, catalogs)
    return AssetLibraryFile(target, cats, len(entries), len(catalogs))


def register_asset_library(folder: str | Path, name: str | None = None):
    """Add ``folder`` to Preferences > File Paths > Asset Libraries (once; an entry with the
    same folder is returned as it is). It lasts beyond this session when the preferences
    are saved (Blender does so on exit when *Auto-Save Preferences* is on)."""
    folder = Path(folder).resolve()
    libraries = bpy.context.preferences.filepaths.asset_libraries
    for library in libraries:
        if Path(bpy.path.abspath(library.path)).resolve() == folder:
            return library
    entry = libraries.new(name=name or folder.name, directory=str(folder))
    return entry
