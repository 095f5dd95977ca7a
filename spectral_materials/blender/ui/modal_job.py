"""The base of the long operators (factoring, PRT bake, BTF fit) and the job's progress bar.

Long jobs run modal in the UI: the work runs in a worker thread (it never touches
``bpy``), a timer moves the progress bar, Esc cancels, and the result is committed
on the main thread when the thread is done. In background mode, or when called
with ``EXEC_DEFAULT`` (as ``bpy.ops`` does from scripts), they run synchronously.
A failure or a cancel commits nothing. One job runs at a time, whatever its capability:
:class:`SPECTRAL_PG_job` on the window manager says which.
"""

from __future__ import annotations

import threading

import bpy
from bpy.props import BoolProperty, FloatProperty, StringProperty

from ...core.errors import Cancelled

#: Bad input, said plainly (SourceError, SceneError and StorageError are ValueErrors).
EXPECTED_ERRORS = (ValueError, OSError)


class SPECTRAL_PG_job(bpy.types.PropertyGroup):
    """State of the running job, shown as a progress bar (not saved meaningfully)."""

    running: BoolProperty(default=False)
    fraction: FloatProperty(default=0.0, min=0.0, max=1.0, subtype="FACTOR")
    message: StringProperty(default="")


def draw_job(layout, context) -> bool:
    """The running job's progress bar; True while a job runs (its buttons are then hidden)."""
    job = context.window_manager.spectral_job
    if job.running:
        layout.progress(factor=job.fraction, type="BAR",
                        text=f"{100 * job.fraction:.0f}% {job.message}  (Esc cancels)")
    return job.running


class Worker:
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


class ModalJob:
    """A job planned on the main thread, run in a worker thread behind a progress bar and
    committed on the main thread. Subclasses (which also derive from
    ``bpy.types.Operator``) give :meth:`plan` (reads ``bpy``), :meth:`run` (must not
    touch ``bpy``: it runs in the worker thread) and :meth:`commit` (stores the result,
    returns the message to report)."""

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
        elif isinstance(exc, EXPECTED_ERRORS):
            self.report({"ERROR"}, str(exc))
        else:
            self.report({"ERROR"}, f"Unexpected error ({type(exc).__name__}: {exc}); "
                                   "nothing was changed")
        return {"CANCELLED"}

    def _start(self, context, work) -> set[str]:
        """Run ``work(callback)`` in a worker thread; the timer drives :meth:`modal`."""
        self._worker = Worker(work)
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
