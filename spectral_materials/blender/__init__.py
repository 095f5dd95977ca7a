"""Blender adapters (everything that imports ``bpy``): thin layers over :mod:`..core`.

``register()`` adds the packages of :data:`PACKAGES` in order (each one's ``CLASSES``,
then its ``register()``, which adds its pointer properties or hooks), then the viewport's
draw handlers; ``unregister()`` removes them in reverse. The order puts every
PointerProperty's target before its users: the shared groups (``ui``) first, the scene's
settings (which point to the PRT environment) last.

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

    from . import brdf, btf, eevee, library, lights, prt, scene_properties, ui

    # Each capability's drawer registers itself with the viewport's registry at import.
    from .brdf import drawer as _brdf_drawer  # noqa: F401
    from .btf import drawer as _btf_drawer  # noqa: F401
    from .prt import drawer as _prt_drawer  # noqa: F401
    from .viewport import draw

    #: Registered in this order, unregistered in reverse.
    PACKAGES = (ui, lights, brdf, prt, btf, eevee, library, scene_properties)


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
        for package in PACKAGES:
            for cls in package.CLASSES:
                bpy.utils.register_class(cls)
                undo.append(lambda cls=cls: bpy.utils.unregister_class(cls))
            package.register()
            undo.append(package.unregister)
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
    for package in reversed(PACKAGES):
        package.unregister()
        for cls in reversed(package.CLASSES):
            bpy.utils.unregister_class(cls)
