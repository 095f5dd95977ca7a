"""What the capabilities' user interfaces share: the modal-job base of the long operators
and its progress bar (:mod:`.modal_job`), the reflectance-spectrum group and widget
(:mod:`.spectrum`), shared enum items (:mod:`.enums`) and small draw helpers
(:mod:`.widgets`). Nothing here knows a capability."""

from __future__ import annotations

import bpy
from bpy.props import PointerProperty

from .modal_job import SPECTRAL_PG_job
from .spectrum import SPECTRAL_PG_spectrum

#: Registered by ``blender.register()`` before every capability's classes.
CLASSES = (SPECTRAL_PG_spectrum, SPECTRAL_PG_job)


def register() -> None:
    """Give the window manager the job's state (after :data:`CLASSES` are registered)."""
    bpy.types.WindowManager.spectral_job = PointerProperty(type=SPECTRAL_PG_job)


def unregister() -> None:
    del bpy.types.WindowManager.spectral_job
