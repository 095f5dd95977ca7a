"""The add-on's import paths from before the package reorganisation, as README.md used
them, still work for one release with a DeprecationWarning."""

from __future__ import annotations

import importlib
import sys

import pytest

pytest.importorskip("bpy")

pytestmark = pytest.mark.bpy

from spectral_materials import _moved

ROOT = "spectral_materials"


def _forget(old: str) -> None:
    """Undo an earlier import of an old path, so that importing it again warns again."""
    sys.modules.pop(f"{ROOT}.{old}", None)
    parent, _, name = f"{ROOT}.{old}".rpartition(".")
    vars(sys.modules[parent]).pop(name, None)


@pytest.mark.parametrize(("old", "new"), [(o, n) for o, n in _moved.MOVED_MODULES.items()
                                          if o.startswith("blender.")])
def test_an_old_blender_path_is_the_new_module_with_a_warning(old, new):
    _forget(old)
    with pytest.warns(DeprecationWarning, match=rf"{ROOT}\.{new}"):
        module = importlib.import_module(f"{ROOT}.{old}")
    assert module is importlib.import_module(f"{ROOT}.{new}")


@pytest.mark.parametrize(("package", "module"), [
    (old, new.rpartition(".")[2]) for old, new in _moved.MODULES_NOW_PACKAGES.items()
    if old.startswith("blender.")])
def test_old_blender_modules_now_packages_forward_their_names(package, module):
    new = importlib.import_module(f"{ROOT}.{package}.{module}")
    # A module that became a public face (it serves names defined beside it) lists them.
    names = getattr(new, "__all__", None) or [
        n for n in vars(new) if getattr(getattr(new, n), "__module__", "") == new.__name__]
    name = next(n for n in names if not n.startswith("_") and callable(getattr(new, n)))
    pkg = importlib.import_module(f"{ROOT}.{package}")
    with pytest.warns(DeprecationWarning, match=rf"{package}\.{module}\.{name}"):
        assert getattr(pkg, name) is getattr(new, name)


def test_the_readme_api_of_the_release_before_still_works():
    """README.md's examples as they were written before the move (issue 17)."""
    for old in ("blender.jobs", "blender.storage", "core.btf_generate", "core.btf_fit",
                "core.models", "core.spectra", "core.metrics"):
        _forget(old)
    with pytest.warns(DeprecationWarning):
        from spectral_materials.blender import btf, jobs, prt, storage

        # factor_brdf and FactoredBRDF never moved; the others did.
        from spectral_materials.core import (
            FactoredBRDF,
            btf_fit,
            btf_generate,
            factor_brdf,
            metrics,
            models,
            spectra,
        )
        calls = (jobs.factor_scene, storage.load_factored, prt.bake_prt, prt.vertex_xyz,
                 prt.vertex_reference_xyz, btf_generate.generate_btf, btf_fit.fit_rfnl,
                 btf_fit.epsilon, btf.fit_btf, models.AshikhminShirley,
                 spectra.colorchecker_spectrum, metrics.random_direction_pairs,
                 factor_brdf, FactoredBRDF.load)
    assert all(callable(c) for c in calls)
