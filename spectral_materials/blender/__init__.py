"""Blender adapters (everything that imports ``bpy``): thin layers over :mod:`..core`.

``register()`` / ``unregister()`` add and remove, in order, the property groups, the
operators, the panels and the draw handlers; explicit class lists live in each module.

Before anything else, the colour-science and SciPy that would load are checked
(:func:`spectral_materials.dependency_problems`): if another extension supplied a copy too
old for this add-on, the submodules (which import them) are not imported and
``register()`` raises one :class:`~spectral_materials.DependencyError` naming the package
and the version it needs, having registered nothing. Should a step of ``register()`` fail
for any other reason, the steps already done are undone before the error propagates.
"""

from __future__ import annotations

import atexit

from .. import DependencyError, dependency_message, dependency_problems

_PROBLEMS = dependency_problems()
if not _PROBLEMS:
    import bpy

    from .ui import operators, panels, properties
    from .viewport import draw


_STATE = {"registered": False, "exit_hook": False}


def _unregister_at_exit() -> None:
    if _STATE["registered"]:
        unregister()


def register() -> None:
    # Checked at import (the submodules import colour and scipy) and again here.
    if problems := _PROBLEMS or dependency_problems():
        raise DependencyError(dependency_message(problems))
    undo = []
    try:
        properties.register()
        undo.append(properties.unregister)
        for cls in operators.CLASSES + panels.CLASSES:
            bpy.utils.register_class(cls)
            undo.append(lambda cls=cls: bpy.utils.unregister_class(cls))
        draw.register()
        _STATE["registered"] = True
        # The bpy module (no Blender binary) never unregisters add-ons itself, and bpy 4.5
        # hangs for good in its exit handler while property groups are still registered;
        # atexit runs this before that handler, which import bpy registered earlier.
        if not bpy.app.binary_path and not _STATE["exit_hook"]:
            atexit.register(_unregister_at_exit)
            _STATE["exit_hook"] = True
    except BaseException:
        for step in reversed(undo):
            try:
                step()
            except Exception:  # noqa: BLE001 - the original error is the one to report
                pass
        raise


def unregister() -> None:
    if _PROBLEMS or not _STATE["registered"]:
        return  # register() refused or never ran: nothing is registered
    _STATE["registered"] = False
    draw.unregister()
    for cls in reversed(operators.CLASSES + panels.CLASSES):
        bpy.utils.unregister_class(cls)
    properties.unregister()
