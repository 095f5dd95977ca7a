"""BTF materials in Blender: fit what a material's BTF settings name, store the result.

The work is split as the operators need it: :func:`plan_fit` reads the material's
settings on the main thread, :func:`~spectral_materials.core.btf.job.run_btf_job` fits
in any thread (progress, cancellation), :func:`commit_fit` stores on the main thread.
:func:`fit_btf` does all three for scripts.
"""

from __future__ import annotations

import bpy

from ...core.btf import job as btf_job
from . import storage as btf_storage


def plan_fit(material) -> btf_job.BTFJob:
    """The job a material's ``spectral_btf`` settings describe (main thread)."""
    if material is None:
        raise ValueError("No material to fit a BTF to")
    s = material.spectral_btf
    source = s.source.lower()
    filepath = bpy.path.abspath(s.filepath) if source.startswith("ubo") else ""
    if source.startswith("ubo") and not s.filepath:
        raise ValueError(f"Material '{material.name}': choose the {s.source} file to fit")
    return btf_job.BTFJob(source=source, filepath=filepath, texels=int(s.texels),
                          model=s.model, lobes=int(s.lobes), name=material.name)


def commit_fit(material_name: str, result: btf_job.BTFJobResult) -> None:
    """Store a fit on the material (main thread); the material may have gone meanwhile."""
    material = bpy.data.materials.get(material_name)
    if material is None:
        raise ValueError(f"Material '{material_name}' was removed while its BTF was fitted")
    btf_storage.store_btf(material, result.drawable, figures=result.figures)


def fit_btf(material, *, callback=None) -> btf_job.BTFJobResult:
    """Fit and store the BTF a material's settings describe."""
    job = plan_fit(material)
    result = btf_job.run_btf_job(job, callback)
    commit_fit(material.name, result)
    return result


def status(material) -> str:
    """One line for the panel: what is stored and how well it fits."""
    if not btf_storage.has_btf(material):
        return "No BTF stored: Fit BTF"
    f = btf_storage.figures(material)
    if not f:
        return "BTF stored"
    return (f"{f.get('model', '?')}: ε {f.get('epsilon_avg', float('nan')):.4f}, "
            f"{f.get('views', '?')} views, {f.get('gpu_bytes', 0) / 2**20:.1f} MiB, "
            f"fit {f.get('fit_seconds', 0.0):.1f} s")
