"""Scene jobs in three steps: plan (main thread), run (any thread), commit (main thread).

Operators and headless scripts share these functions::

    plan = scene.plan_scene(bpy.context.scene)          # reads and validates everything
    result = run_scene_job(plan, callback)               # pure NumPy; cancellable
    message = commit_scene_job(bpy.context.scene, result)  # all or nothing

``run_scene_job`` never touches ``bpy``, so the UI runs it in a worker thread; the
commit creates every image before it changes any property, so a failure or a
cancel leaves the scene as it was.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

import bpy
import numpy as np

from ...core.brdf.factor import is_isotropic, resolve_parameterization
from ...core.brdf.factored import json_default
from ...core.brdf.job import FactorOptions, MaterialJobResult, factor_material
from ...core.colour import scene_basis
from ...core.colour.basis import LinearModelBasis
from ...core.progress import ProgressCallback, report, scaled
from . import hooks, sources, storage
from .scene import ScenePlan

BASIS_KEY = "basis"


@dataclass
class SceneJobResult:
    """What a scene job computed, ready to commit."""

    plan: ScenePlan
    choice: scene_basis.SceneBasisChoice
    factored: dict[str, tuple[MaterialJobResult, str]] = field(default_factory=dict)
    up_to_date: list[str] = field(default_factory=list)
    factor_only: bool = True          # False: the job only chose the basis
    seconds: float = 0.0

    def summary(self) -> str:
        plan, choice = self.plan, self.choice
        parts = [scene_basis.describe_choice(choice)]
        if plan.implicit_light:
            parts.append(f"no light reaches the scene, used {plan.implicit_light}")
        if plan.hidden_lights:
            parts.append(f"{len(plan.hidden_lights)} light(s) left out: "
                         + ", ".join(plan.hidden_lights))
        if plan.unused:
            parts.append(f"{len(plan.unused)} unused material(s) skipped: "
                         + ", ".join(plan.unused))
        if self.up_to_date:
            parts.append(f"{len(self.up_to_date)} material(s) up to date")
        if self.factor_only:
            parts.append(f"{len(self.factored)} factored in {self.seconds:.1f} s")
        return "; ".join(parts)

    def analysis(self) -> dict:
        choice = self.choice
        return {
            "basis": {"size": choice.size, "full_size": choice.full_size,
                      "max_de94": choice.max_de94, "worst_pair": list(choice.worst_pair),
                      "met": choice.met, "tolerance_de94": self.plan.tolerance_de94,
                      "per_size": choice.per_size},
            "materials_used": sorted(self.plan.materials),
            "materials_unused": self.plan.unused,
            "lights": sorted(self.plan.lights),
            "lights_left_out": self.plan.hidden_lights,
            "implicit_light": self.plan.implicit_light,
            "up_to_date": self.up_to_date,
            "factored": {name: {"packs": r.model.packs, "de94": r.model.report.get("de94"),
                                "seconds": r.seconds, "bytes": r.model.nbytes,
                                "series": r.series}
                         for name, (r, _hash) in self.factored.items()},
            "seconds": self.seconds,
            "summary": self.summary(),
        }


def factor_options(inputs: sources.MaterialInputs, brdf, isotropic: bool) -> FactorOptions:
    name = sources.resolve_auto(inputs.parameterization, isotropic, inputs.lobe)
    param, isotropic = resolve_parameterization(brdf, name, isotropic, sources.WAVELENGTHS)
    resolution = sources.resolution_for(name, isotropic, inputs.theta_cells)
    # Automatic gives packs alone another layout than packs beside a lobe (hd for an
    # anisotropic glossy model): used when the lobe is not kept.
    plain = sources.resolve_auto(inputs.parameterization, isotropic, "off")
    plain_layout = None if plain == name else (
        resolve_parameterization(brdf, plain, isotropic, sources.WAVELENGTHS)[0].name,
        sources.resolution_for(plain, isotropic, inputs.theta_cells))
    return FactorOptions(parameterization=param.name, resolution=resolution,
                         isotropic=isotropic, packs=inputs.packs, target_de94=inputs.target_de94,
                         pack_size=inputs.pack_size, smoothing=inputs.smoothing,
                         lobe=inputs.lobe, automatic=inputs.automatic,
                         plain_layout=plain_layout, cells=inputs.cells)


def run_scene_job(plan: ScenePlan, callback: ProgressCallback | None = None, *,
                  factor: bool = True) -> SceneJobResult:
    """Choose the scene basis and factor the stale target materials (no ``bpy``)."""
    start = time.perf_counter()
    names = list(plan.materials)
    brdfs, isotropic, spectra_by_material = {}, {}, {}
    for i, name in enumerate(names):
        report(callback, 0.1 * i / len(names), f"sampling spectra of {name}")
        brdfs[name] = plan.materials[name].brdf()
        isotropic[name] = is_isotropic(brdfs[name], sources.WAVELENGTHS)
        spectra_by_material[name] = sources.sampled_spectra(brdfs[name], isotropic[name])
    report(callback, 0.1, "choosing the spectral basis")
    choice = scene_basis.choose_scene_basis(
        spectra_by_material, plan.lights, sources.WAVELENGTHS,
        tolerance_de94=plan.tolerance_de94, max_size=plan.max_size, observer=plan.observer,
        callback=scaled(callback, 0.1, 0.15))
    result = SceneJobResult(plan=plan, choice=choice, factor_only=factor)
    if factor:
        basis = choice.basis
        stale = []
        for name in plan.targets:
            digest = sources.input_hash(plan.materials[name], basis.vectors)
            if digest == plan.stored_hashes.get(name) and not plan.force:
                result.up_to_date.append(name)
            else:
                stale.append((name, digest))
        for i, (name, digest) in enumerate(stale):
            sub = scaled(callback, 0.15 + 0.85 * i / len(stale),
                         0.15 + 0.85 * (i + 1) / len(stale))
            labelled = None if sub is None else (
                lambda f, m, name=name, sub=sub: sub(f, f"{name}: {m}"))
            options = factor_options(plan.materials[name], brdfs[name], isotropic[name])
            job = factor_material(brdfs[name], basis, options, labelled)
            result.factored[name] = (job, digest)
    result.seconds = time.perf_counter() - start
    report(callback, 1.0, "done")
    return result


def store_scene_basis(scene, basis: LinearModelBasis, max_de94: float) -> None:
    settings = scene.spectral
    vectors = np.asarray(basis.vectors, dtype=np.float32)
    settings[BASIS_KEY] = [float(v) for v in vectors.ravel()]
    settings["basis_wavelengths"] = [float(w) for w in basis.wavelengths]
    settings.basis_size = vectors.shape[1]
    settings.basis_max_de94 = float(max_de94)


def clear_scene_basis(scene) -> None:
    settings = scene.spectral
    for key in (BASIS_KEY, "basis_wavelengths"):
        if key in settings:
            del settings[key]
    settings.basis_size = 0
    settings.basis_max_de94 = 0.0
    settings.analysis = ""
    settings.analysis_json = ""
    scene.update_tag()


def load_scene_basis(scene) -> LinearModelBasis | None:
    """The scene's stored basis (float32 values), or None."""
    settings = scene.spectral
    if BASIS_KEY not in settings or settings.basis_size == 0:
        return None
    wavelengths = np.asarray(settings["basis_wavelengths"], dtype=np.float64)
    vectors = np.asarray(settings[BASIS_KEY], dtype=np.float32).reshape(wavelengths.size, -1)
    return LinearModelBasis(wavelengths=wavelengths, vectors=vectors,
                            singular_values=np.zeros(0))


def commit_scene_job(scene, result: SceneJobResult) -> str:
    """Store the basis, the analysis and every factored material; all or nothing."""
    prepared = {}
    try:
        for name, (job, _digest) in result.factored.items():
            if name not in bpy.data.materials:
                raise storage.StorageError(f"Material '{name}' was removed while it was "
                                           "being factored; nothing was stored")
            stored = storage.as_stored(job.model)
            stored.validate()
            prepared[name] = (stored, storage.prepare_images(name, stored, job.plot))
    except Exception:
        for _stored, images in prepared.values():
            for image in images:
                storage.remove_image(image)
        raise
    for name, (stored, images) in prepared.items():
        storage.apply_factored(bpy.data.materials[name], stored, images,
                               result.factored[name][1])
    store_scene_basis(scene, result.choice.basis, result.choice.max_de94)
    summary = result.summary()
    # What follows the factors (an applied EEVEE node group) is rebuilt now.
    notes = [note for name in prepared
             for note in hooks.after_store(bpy.data.materials[name], scene)]
    summary = "; ".join([summary] + [n for n in notes if n])
    scene.spectral.analysis = summary
    scene.spectral.analysis_json = json.dumps(result.analysis(), default=json_default)
    scene.update_tag()      # so that memfile undo restores the scene's properties too
    return summary


def factor_scene(scene, callback: ProgressCallback | None = None, *, only=None,
                 force: bool = False, factor: bool = True) -> SceneJobResult:
    """Plan, run and commit synchronously (headless scripts, background operators)."""
    from .scene import plan_scene

    plan = plan_scene(scene, only=only, force=force)
    result = run_scene_job(plan, callback, factor=factor)
    commit_scene_job(scene, result)
    return result
