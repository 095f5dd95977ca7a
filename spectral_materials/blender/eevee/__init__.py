"""The EEVEE approximation: the node group that rebuilds a material's factor packs for its
spectral lights, applying and removing it (operators, and a box in the Stored Factors
panel), and EEVEE renders (:mod:`.render`).

An applied node group follows its material's factors: :func:`register` has the factor-pack
code rebuild it when factors are stored and remove it before they are cleared
(``brdf.hooks``), and adds the EEVEE box to the Stored Factors panel.

Until the next release, ``spectral_materials.blender.eevee.<name>`` also serves the names of
the old ``blender/eevee.py`` (now :mod:`.apply` and :mod:`.render`), with a
DeprecationWarning."""

from __future__ import annotations

from ..._moved import forward_to
from ..brdf import hooks, panels as brdf_panels
from . import apply, operators, panels

__getattr__ = forward_to(__name__, "apply", "render")

#: Registered by ``blender.register()`` in this order, before :func:`register` runs.
CLASSES = operators.CLASSES + panels.CLASSES


def _remove_before_clear(material, scene) -> None:
    # The group samples the factor image that is about to go.
    if apply.applied(material) is not None:
        apply.remove_eevee(material, scene)


def register() -> None:
    """Make applied node groups follow their factors; show the EEVEE box."""
    hooks.AFTER_STORE.append(apply.refresh)
    hooks.BEFORE_CLEAR.append(_remove_before_clear)
    brdf_panels.RESULT_SECTIONS.append(panels.draw_eevee)


def unregister() -> None:
    brdf_panels.RESULT_SECTIONS.remove(panels.draw_eevee)
    hooks.BEFORE_CLEAR.remove(_remove_before_clear)
    hooks.AFTER_STORE.remove(apply.refresh)
