"""Fit the active material's BTF (a modal job) and clear it."""

from __future__ import annotations

import bpy

from ...core.btf import job as btf_job
from ..ui.modal_job import ModalJob
from ..ui.widgets import active_material
from . import fit as btf, storage as btf_storage


class SPECTRAL_OT_fit_btf(ModalJob, bpy.types.Operator):
    """Fit the active material's BTF (generated or from a UBO file) as per-view reflectance
    fields and store it for the spectral viewport; Esc cancels and changes nothing"""

    bl_idname = "spectral.fit_btf"
    bl_label = "Fit BTF"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if active_material(context) is None:
            cls.poll_message_set("Select an object with a material")
            return False
        return True

    def plan(self, context):
        return btf.plan_fit(active_material(context))

    def run(self, plan, callback=None):
        return btf_job.run_btf_job(plan, callback)

    def commit(self, context, plan, result) -> str:
        btf.commit_fit(plan.name, result)
        from ..viewport import draw

        draw.redraw_viewports()
        return btf.status(bpy.data.materials[plan.name])


class SPECTRAL_OT_clear_btf(bpy.types.Operator):
    """Remove the active material's stored BTF"""

    bl_idname = "spectral.clear_btf"
    bl_label = "Clear BTF"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return btf_storage.has_btf(active_material(context))

    def execute(self, context):
        btf_storage.clear_btf(active_material(context))
        from ..viewport import draw

        draw.redraw_viewports()
        return {"FINISHED"}


CLASSES = (SPECTRAL_OT_fit_btf, SPECTRAL_OT_clear_btf)
