"""Spectral Materials: spectral BRDFs as factor packs, rendered in Blender.

``spectral_materials.core`` is pure NumPy/SciPy/colour-science and never imports
``bpy``; ``spectral_materials.blender`` holds the Blender adapters.

:func:`dependency_problems` checks, without importing them, that the colour-science and
SciPy an import would load are new enough: in Blender another extension (or a legacy
add-on) may put an older copy first, and the add-on refuses to register with one clear
message rather than failing somewhere inside.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import re
import sys
from pathlib import Path

__version__ = "0.1.0"

# (distribution, top-level module, oldest version the add-on runs with). colour-science
# 0.4.6 is the API the core is written against; SciPy 1.13 is the oldest it is tested with
# (the extension bundles 1.17.1).
REQUIRED = (
    ("colour-science", "colour", "0.4.6"),
    ("scipy", "scipy", "1.13.0"),
)


class DependencyError(ImportError):
    """An installed dependency is missing or older than the add-on needs."""


def _release(version: str) -> tuple[int, ...]:
    """The leading numeric release of a version string: ``"1.13.1rc1"`` -> ``(1, 13, 1)``."""
    match = re.match(r"\s*v?(\d+(?:\.\d+)*)", version)
    return tuple(int(x) for x in match[1].split(".")) if match else (0,)


def _installed(dist: str, module_name: str) -> tuple[str | None, str | None]:
    """(version, location) of what ``import module_name`` loads (or has loaded).

    The version comes from the module once imported, else from the distribution's
    metadata next to the package the import system would find, so a copy earlier on
    ``sys.path`` (another extension's wheel) is the one judged, not any other installed
    copy. Nothing is imported.
    """
    module = sys.modules.get(module_name)
    if module is not None:
        version = getattr(module, "__version__", None)
        where = getattr(module, "__file__", None)
        if version is not None:
            return str(version), where
        spec = module.__spec__
    else:
        try:
            spec = importlib.util.find_spec(module_name)
        except (ImportError, ValueError):
            spec = None
        if spec is None:
            return None, None
    where = spec.origin if spec is not None else None
    if spec is not None and spec.submodule_search_locations:
        parent = str(Path(next(iter(spec.submodule_search_locations))).parent)
    elif where:
        parent = str(Path(where).parent)
    else:
        parent = None
    wanted = re.sub(r"[-_.]+", "-", dist).lower()
    if parent is not None:
        for found in importlib.metadata.distributions(path=[parent]):
            name = re.sub(r"[-_.]+", "-", found.metadata["Name"] or "").lower()
            if name == wanted:
                return found.version, where
    try:
        return importlib.metadata.version(dist), where
    except importlib.metadata.PackageNotFoundError:
        return None, where


def dependency_problems() -> list[str]:
    """One sentence per dependency that is missing or too old; empty when all is well."""
    problems = []
    for dist, module_name, minimum in REQUIRED:
        version, where = _installed(dist, module_name)
        if version is None and where is None:
            problems.append(f"{dist} >= {minimum} is not installed")
        elif version is None or _release(version) < _release(minimum):
            problems.append(
                f"{dist} {version or '(unknown version)'} is loaded from {where}, but "
                f"Spectral Materials needs {dist} >= {minimum}"
            )
    return problems


def dependency_message(problems: list[str]) -> str:
    """The one error message for ``problems`` (from :func:`dependency_problems`)."""
    return (
        "Spectral Materials cannot start: " + "; ".join(problems) + ". An older copy "
        "installed by another add-on or extension comes first: update or disable that one "
        "(or reinstall Spectral Materials, whose wheels bring these versions), then restart "
        "Blender."
    )


def check_dependencies() -> None:
    """Raise one :class:`DependencyError` naming every dependency that is missing or too old."""
    if problems := dependency_problems():
        raise DependencyError(dependency_message(problems))

# Old import paths (before the capability packages) keep working for one release.
from . import _moved  # noqa: E402 - after the version check helpers, which it does not need

_moved.install(__name__)
