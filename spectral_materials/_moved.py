"""Import paths from before the package reorganisation (issue 17), kept for one release.

Until then ``spectral_materials.core.cp`` and its kind still import: a finder on
``sys.meta_path`` hands out the module's new home under the old name, with a
``DeprecationWarning`` that names the new path. Five old modules share their name with a
new package (``core.btf``, ``core.prt``, ``blender.btf``, ``blender.prt``,
``blender.eevee``); there the package forwards the old module's names
(:func:`forward_to`). Names that left a module that still exists (``viewport.draw``,
``gpu.offscreen``, ``formats.merl``) are served there by :func:`forward_names`. Remove
this file, its installation in ``spectral_materials/__init__`` and the ``forward_to`` /
``forward_names`` lines in the release after 0.x."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: Old module → new module, both relative to the package root.
MOVED_MODULES: dict[str, str] = {
    "core.spectra": "core.colour.spectra",
    "core.colour_pipeline": "core.colour.pipeline",
    "core.basis": "core.colour.basis",
    "core.scene_basis": "core.colour.scene_basis",
    "core.metamers": "core.colour.metamers",
    "core.spectrum_library": "core.colour.spectrum_library",
    "core.cp": "core.decomposition.cp",
    "core.separable": "core.decomposition.separable",
    "core.models": "core.brdf.models",
    "core.params": "core.brdf.params",
    "core.tabulate": "core.brdf.tabulate",
    "core.factor": "core.brdf.factor",
    "core.factored": "core.brdf.factored",
    "core.metrics": "core.brdf.metrics",
    "core.shading": "core.brdf.shading",
    "core.material_job": "core.brdf.job",
    "core.prefilter": "core.brdf.prefilter",
    "core.sh": "core.prt.sh",
    "core.environment": "core.prt.environment",
    "core.albedo": "core.prt.albedo",
    "core.prt_reference": "core.prt.reference",
    "core.raycast": "core.prt.raycast",
    "core.btf_fit": "core.btf.fit",
    "core.btf_lm": "core.btf.lm",
    "core.btf_generate": "core.btf.generate",
    "core.btf_job": "core.btf.job",
    "core.btf_render": "core.btf.render",
    "blender.gpu_context": "blender.gpu.context",
    "blender.shaders": "blender.gpu.shaders",
    "blender.gpu_state": "blender.gpu.state",
    "blender.offscreen": "blender.gpu.offscreen",
    "blender.mesh_batches": "blender.gpu.batches",
    "blender.draw": "blender.viewport.draw",
    "blender.render_output": "blender.viewport.render_output",
    "blender.storage": "blender.brdf.storage",
    "blender.jobs": "blender.brdf.jobs",
    "blender.gpu_material": "blender.brdf.gpu_material",
    "blender.sources": "blender.brdf.sources",
    "blender.scene": "blender.brdf.scene",
    "blender.scene_reference": "blender.brdf.scene_reference",
    "blender.scene_lights": "blender.lights.scene_lights",
    "blender.plots": "blender.lights.plots",
    "blender.bake": "blender.prt.bake",
    "blender.prt_gpu": "blender.prt.drawer",
    "blender.prt_images": "blender.prt.images",
    "blender.btf_gpu": "blender.btf.drawer",
    "blender.btf_storage": "blender.btf.storage",
    "blender.eevee_nodes": "blender.eevee.nodes",
    "blender.properties": "blender.brdf.properties",
    "blender.operators": "blender.brdf.operators",
    "blender.panels": "blender.brdf.panels",
}

#: Old modules whose name is now a package: the package forwards to this module.
MODULES_NOW_PACKAGES: dict[str, str] = {
    "core.btf": "core.btf.container",
    "core.prt": "core.prt.transfer",
    "blender.btf": "blender.btf.fit",
    "blender.prt": "blender.prt.scene",
    "blender.eevee": "blender.eevee.apply",
}


def _warn(old: str, new: str, stacklevel: int) -> None:
    warnings.warn(f"{old} moved to {new}; the old path goes in the next release",
                  DeprecationWarning, stacklevel=stacklevel)


class _Alias(importlib.abc.Loader):
    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec):
        module = importlib.import_module(self.new)
        self.real_spec = module.__spec__
        return module

    def exec_module(self, module) -> None:
        # Already executed under its new name. The import system has just set its
        # __spec__ to the old name's; put the real one back, or the module's own relative
        # imports would see __package__ != __spec__.parent.
        module.__spec__ = self.real_spec


class MovedModuleFinder(importlib.abc.MetaPathFinder):
    """Finds ``<root>.<old>`` for every old path in :data:`MOVED_MODULES`."""

    def __init__(self, root: str) -> None:
        self.root = root

    def find_spec(self, fullname, path=None, target=None):
        prefix = self.root + "."
        if not fullname.startswith(prefix):
            return None
        new = MOVED_MODULES.get(fullname[len(prefix):])
        if new is None:
            return None
        _warn(fullname, prefix + new, stacklevel=4)
        return importlib.util.spec_from_loader(fullname, _Alias(prefix + new))


def install(root: str) -> None:
    """Put the finder for package ``root`` on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, MovedModuleFinder) and f.root == root for f in sys.meta_path):
        sys.meta_path.append(MovedModuleFinder(root))


def forward_names(module: str, moved: dict[str, str]):
    """A module ``__getattr__`` for names that left ``module`` for another module.

    ``moved`` maps each old name to ``"<new module>"`` (same name there) or
    ``"<new module>:<new name>"``, the new module relative to the package root. The new
    module is imported by name on first use, so the forward adds no import to ``module``
    (a lower layer may forward to a higher one)."""
    root = __name__.rpartition(".")[0]

    def __getattr__(name: str):
        target = moved.get(name)
        if target is None:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        new_module, _, new_name = target.partition(":")
        new_module, new_name = f"{root}.{new_module}", new_name or name
        _warn(f"{module}.{name}", f"{new_module}.{new_name}", stacklevel=3)
        return getattr(importlib.import_module(new_module), new_name)

    return __getattr__


def forward_to(package: str, *modules: str):
    """A module ``__getattr__`` for ``package`` that serves the names of the old module of
    the same name, now in ``package.<module>`` (the first of ``modules`` that has the
    name), with a DeprecationWarning."""

    def __getattr__(name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        for module in modules:
            target = importlib.import_module(f"{package}.{module}")
            if hasattr(target, name):
                _warn(f"{package}.{name}", f"{package}.{module}.{name}", stacklevel=3)
                return getattr(target, name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return __getattr__
