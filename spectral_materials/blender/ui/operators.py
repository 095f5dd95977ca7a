"""Operators: thin wrappers over :mod:`.jobs` and :mod:`.storage`.

Long jobs run modal in the UI: the work runs in a worker thread (it never touches
``bpy``), a timer moves the progress bar, Esc cancels, and the result is committed
on the main thread when the thread is done. In background mode, or when called
with ``EXEC_DEFAULT`` (as ``bpy.ops`` does from scripts), they run synchronously.
A failure or a cancel commits nothing.
"""

from __future__ import annotations

import threading

import bpy
from bpy.props import BoolProperty, EnumProperty

from ...core.btf import job as btf_job
from ...core.errors import Cancelled
from ..brdf import jobs, scene, storage
from ..btf import fit as btf
from ..btf import storage as btf_storage
from ..eevee import apply as eevee
from ..prt import scene as prt

# SourceError, SceneError and StorageError are ValueErrors: bad input, said plainly.
_EXPECTED = (ValueError, OSError)


class _Worker:
    """A job running in a thread with a cancel flag and the latest progress."""

    def __init__(self, work):
        self.fraction, self.message = 0.0, "starting"
        self.result = self.error = None
        self.cancel = threading.Event()
        self.thread = threading.Thread(target=self._run, args=(work,), daemon=True)
        self.thread.start()

    def callback(self, fraction: float, message: str) -> bool:
        self.fraction, self.message = fraction, message
        return self.cancel.is_set()

    def _run(self, work) -> None:
        try:
            self.result = work(self.callback)
        except BaseException as exc:  # noqa: BLE001 - reported on the main thread
            self.error = exc

    @property
    def done(self) -> bool:
        return not self.thread.is_alive()


class _ModalJob:
    """A job planned on the main thread, run in a worker thread behind a progress bar and
    committed on the main thread. Subclasses give :meth:`plan` (reads ``bpy``),
    :meth:`run` (must not touch ``bpy``: it runs in the worker thread) and :meth:`commit`
    (stores the result, returns the message to report)."""

    def plan(self, context):
        raise NotImplementedError

    def run(self, plan, callback=None):
        raise NotImplementedError

    def commit(self, context, plan, result) -> str:
        raise NotImplementedError

    def _commit(self, context, plan, result) -> set[str]:
        try:
            message = self.commit(context, plan, result)
        except Exception as exc:  # noqa: BLE001
            return self._report_failure(exc)
        self.report({"INFO"}, message)
        return {"FINISHED"}

    def execute(self, context):
        try:
            plan = self.plan(context)
            result = self.run(plan)
        except Exception as exc:  # noqa: BLE001
            return self._report_failure(exc)
        return self._commit(context, plan, result)

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        if context.window_manager.spectral_job.running:
            self.report({"WARNING"}, "A spectral job is already running")
            return {"CANCELLED"}
        try:
            plan = self.plan(context)
        except Exception as exc:  # noqa: BLE001
            return self._report_failure(exc)
        self._plan = plan
        return self._start(context, lambda cb: self.run(plan, cb))

    def _finish(self, context, result) -> set[str]:
        return self._commit(context, self._plan, result)

    def _report_failure(self, exc: BaseException) -> set[str]:
        if isinstance(exc, Cancelled):
            self.report({"WARNING"}, "Cancelled; nothing was changed")
        elif isinstance(exc, _EXPECTED):
            self.report({"ERROR"}, str(exc))
        else:
            self.report({"ERROR"}, f"Unexpected error ({type(exc).__name__}: {exc}); "
                                   "nothing was changed")
        return {"CANCELLED"}

    def _start(self, context, work) -> set[str]:
        """Run ``work(callback)`` in a worker thread; the timer drives :meth:`modal`."""
        self._worker = _Worker(work)
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 1000)
        job = wm.spectral_job
        job.running, job.fraction, job.message = True, 0.0, "starting"
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _cleanup(self, context) -> None:
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        wm.spectral_job.running = False
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        for area in context.screen.areas if context.screen else ():
            area.tag_redraw()

    def modal(self, context, event):
        worker = self._worker
        if event.type == "ESC" and event.value == "PRESS":
            worker.cancel.set()
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            # The job works on a snapshot, so the user may go on working meanwhile.
            return {"PASS_THROUGH"}
        job = context.window_manager.spectral_job
        job.fraction, job.message = worker.fraction, worker.message
        context.window_manager.progress_update(int(1000 * worker.fraction))
        if context.workspace is not None:
            context.workspace.status_text_set(
                f"{self.bl_label}: {100 * worker.fraction:.0f}% {worker.message} (Esc cancels)")
        for area in context.screen.areas if context.screen else ():
            if area.type in {"PROPERTIES", "VIEW_3D"}:
                area.tag_redraw()
        if not worker.done:
            return {"RUNNING_MODAL"}
        self._cleanup(context)
        if worker.error is not None:
            return self._report_failure(worker.error)
        return self._finish(context, worker.result)


class _SceneJobOperator(_ModalJob):
    """Scene analysis and factoring; subclasses say what to plan and whether to factor."""

    bl_options = {"REGISTER", "UNDO"}
    factor_materials = True

    def run(self, plan, callback=None):
        return jobs.run_scene_job(plan, callback, factor=self.factor_materials)

    def commit(self, context, plan, result) -> str:
        return jobs.commit_scene_job(context.scene, result)


class SPECTRAL_OT_factor_material(_SceneJobOperator, bpy.types.Operator):
    """Factor the active material's spectral BRDF into factor packs and store them"""

    bl_idname = "spectral.factor_material"
    bl_label = "Factor Material"
    bl_options = {"REGISTER", "UNDO"}

    force: BoolProperty(name="Force", default=False,
                        description="Factor again even if the stored factors are up to date")

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.active_material is None:
            cls.poll_message_set("Select an object with an active material")
            return False
        return True

    def plan(self, context):
        material = context.active_object.active_material
        return scene.plan_scene(context.scene, only=[material], force=self.force)


class SPECTRAL_OT_factor_scene(_SceneJobOperator, bpy.types.Operator):
    """Analyse the scene, build its spectral basis and factor every used, out-of-date material"""

    bl_idname = "spectral.factor_scene"
    bl_label = "Factor Scene"
    bl_options = {"REGISTER", "UNDO"}

    force: BoolProperty(name="Force", default=False,
                        description="Factor every used material, even those up to date")

    def plan(self, context):
        return scene.plan_scene(context.scene, force=self.force)


class SPECTRAL_OT_build_basis(_SceneJobOperator, bpy.types.Operator):
    """Analyse the scene and build its spectral basis without factoring anything"""

    bl_idname = "spectral.build_basis"
    bl_label = "Build Spectral Basis"
    bl_options = {"REGISTER", "UNDO"}
    factor_materials = False

    def plan(self, context):
        return scene.plan_scene(context.scene)


class SPECTRAL_OT_clear_results(bpy.types.Operator):
    """Remove stored factor packs (their images and metadata)"""

    bl_idname = "spectral.clear_results"
    bl_label = "Clear Spectral Results"
    bl_options = {"REGISTER", "UNDO"}

    scope: EnumProperty(
        name="Scope", default="ACTIVE",
        items=[("ACTIVE", "Active material", "The active object's active material"),
               ("ALL", "All materials", "Every material in the file, and the scene basis")],
        description="Which results to remove")

    def execute(self, context):
        if self.scope == "ACTIVE":
            obj = context.active_object
            material = obj.active_material if obj is not None else None
            if material is None:
                self.report({"ERROR"}, "No active material")
                return {"CANCELLED"}
            targets = [material]
        else:
            targets = list(bpy.data.materials)
        for material in targets:           # the EEVEE group samples the factor image
            if eevee.applied(material) is not None:
                eevee.remove_eevee(material, context.scene)
        cleared = [m.name for m in targets if storage.clear_factored(m)]
        if self.scope == "ALL":
            jobs.clear_scene_basis(context.scene)
        self.report({"INFO"}, f"Cleared {len(cleared)} material(s)"
                    + (": " + ", ".join(cleared) if cleared else ""))
        return {"FINISHED"}


def _active_material(context):
    obj = context.active_object
    return obj.active_material if obj is not None else None


class SPECTRAL_OT_eevee_apply(bpy.types.Operator):
    """Reconstruct the active material's factor packs in an EEVEE node group (the key light
    spectrally, the other lights and the world through a fitted RGB Principled BSDF)"""

    bl_idname = "spectral.eevee_apply"
    bl_label = "Apply EEVEE Node Group"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        material = _active_material(context)
        return material is not None and material.spectral.result.image is not None

    def execute(self, context):
        material = _active_material(context)
        try:
            counts = eevee.apply_eevee(material, context.scene, measure=True)
        except _EXPECTED as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        de = counts["de94"]
        self.report({"INFO"}, f"'{material.name}': {counts['nodes']} nodes, "
                              f"{counts['images']} texture(s); key light ΔE94 mean "
                              f"{de['mean']:.3f}, p95 {de['p95']:.3f} against 5 nm")
        return {"FINISHED"}


class SPECTRAL_OT_eevee_remove(bpy.types.Operator):
    """Remove the EEVEE node group and restore the material's original node links"""

    bl_idname = "spectral.eevee_remove"
    bl_label = "Remove EEVEE Node Group"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        material = _active_material(context)
        return material is not None and eevee.applied(material) is not None

    def execute(self, context):
        material = _active_material(context)
        eevee.remove_eevee(material, context.scene)
        self.report({"INFO"}, f"'{material.name}': original node tree restored")
        return {"FINISHED"}


class SPECTRAL_OT_bake_prt(_ModalJob, bpy.types.Operator):
    """Bake the active object's PRT transfer (self-shadowing by ray casting) and store its
    spectral albedo layers; Esc cancels and leaves everything as it was"""

    bl_idname = "spectral.bake_prt"
    bl_label = "Bake PRT"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type != "MESH":
            cls.poll_message_set("Select a mesh object")
            return False
        return True

    def plan(self, context):
        return prt.plan_bake(context.active_object, context.scene)

    def run(self, plan, callback=None):
        return prt.run_bake(plan, callback)

    def commit(self, context, plan, result) -> str:
        prt.commit_bake(context.scene, plan, result)
        from ..viewport import draw

        draw.redraw_viewports()
        return (f"'{plan.object_name}': {len(plan.geometry.positions)} vertices × "
                f"{plan.rays} rays in {result.seconds:.1f} s "
                f"({result.rays_per_second / 1e6:.2f} M rays/s, {result.backend})")


class SPECTRAL_OT_clear_prt(bpy.types.Operator):
    """Remove the active object's PRT transfer and albedo layers"""

    bl_idname = "spectral.clear_prt"
    bl_label = "Clear PRT"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == "MESH"

    def execute(self, context):
        prt.clear_prt(context.active_object)
        return {"FINISHED"}


class SPECTRAL_OT_fit_btf(_ModalJob, bpy.types.Operator):
    """Fit the active material's BTF (generated or from a UBO file) as per-view reflectance
    fields and store it for the spectral viewport; Esc cancels and changes nothing"""

    bl_idname = "spectral.fit_btf"
    bl_label = "Fit BTF"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if _active_material(context) is None:
            cls.poll_message_set("Select an object with a material")
            return False
        return True

    def plan(self, context):
        return btf.plan_fit(_active_material(context))

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
        return btf_storage.has_btf(_active_material(context))

    def execute(self, context):
        btf_storage.clear_btf(_active_material(context))
        from ..viewport import draw

        draw.redraw_viewports()
        return {"FINISHED"}


CLASSES = (
    SPECTRAL_OT_factor_material,
    SPECTRAL_OT_factor_scene,
    SPECTRAL_OT_build_basis,
    SPECTRAL_OT_clear_results,
    SPECTRAL_OT_eevee_apply,
    SPECTRAL_OT_eevee_remove,
    SPECTRAL_OT_bake_prt,
    SPECTRAL_OT_clear_prt,
    SPECTRAL_OT_fit_btf,
    SPECTRAL_OT_clear_btf,
)
