"""The import paths from before the package reorganisation still work, for one release,
and say where the module went."""

from __future__ import annotations

import importlib
import sys

import pytest

from spectral_materials import _moved

ROOT = "spectral_materials"


def _forget(old: str) -> None:
    """Undo an earlier import of an old path, so that importing it again warns again."""
    sys.modules.pop(f"{ROOT}.{old}", None)
    parent, _, name = f"{ROOT}.{old}".rpartition(".")
    vars(sys.modules[parent]).pop(name, None)


def _old_paths(side: str) -> list[tuple[str, str]]:
    return [(old, new) for old, new in _moved.MOVED_MODULES.items() if old.startswith(side)]


@pytest.mark.parametrize(("old", "new"), _old_paths("core."))
def test_an_old_core_path_is_the_new_module_with_a_warning(old, new):
    _forget(old)
    with pytest.warns(DeprecationWarning, match=rf"{ROOT}\.{new}"):
        module = importlib.import_module(f"{ROOT}.{old}")
    assert module is importlib.import_module(f"{ROOT}.{new}")


def test_from_import_of_an_old_name_works():
    _forget("core.cp")
    with pytest.warns(DeprecationWarning, match="core.decomposition.cp"):
        from spectral_materials.core import cp
    from spectral_materials.core.decomposition import cp as new_cp
    assert cp is new_cp and callable(cp.reconstruct)


@pytest.mark.parametrize(("package", "module", "name"), [
    ("core.btf", "container", "ring_directions"),
    ("core.prt", "transfer", "irradiance"),
])
def test_old_modules_now_packages_forward_their_names(package, module, name):
    pkg = importlib.import_module(f"{ROOT}.{package}")
    with pytest.warns(DeprecationWarning, match=rf"{package}\.{module}\.{name}"):
        value = getattr(pkg, name)
    assert value is getattr(importlib.import_module(f"{ROOT}.{package}.{module}"), name)
    with pytest.raises(AttributeError, match="no attribute"):
        pkg.no_such_name  # noqa: B018


def test_the_table_names_only_modules_that_exist():
    for new in [*_moved.MOVED_MODULES.values(), *_moved.MODULES_NOW_PACKAGES.values()]:
        if new.startswith("blender."):
            continue  # imports bpy: tests/blender/test_moved_paths_blender.py
        importlib.import_module(f"{ROOT}.{new}")
    assert not set(_moved.MOVED_MODULES.values()) & set(_moved.MOVED_MODULES)
