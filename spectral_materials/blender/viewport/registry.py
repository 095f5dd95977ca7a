"""The drawers the viewport handler draws with: each capability registers its own.

The handler (:mod:`.draw`) knows none of them. It asks, per draw:

* every :class:`ObjectDrawer` which objects it draws whole (PRT objects): those are
  left out of the slot-by-slot drawing and handed to it after the other objects;
* per material slot of every other object, the :class:`MaterialDrawer`\\ s in ``order``
  (lowest first) whether they claim the material; the first that does draws it, or, when
  it cannot (its resource is None), the slot is drawn as an occluder. A BTF drawer claims
  materials with a stored BTF before the factor-pack drawer, which claims the rest.

Every drawer empties its caches in :func:`clear_caches` (file load, unregister, exit)
and reports what it refused to draw in :func:`failures` (shown in the panel).
A drawer registered again under the same name replaces the earlier one (module reloads).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from ...core.brdf.shading import View
from ...core.lights import SpectralLight
from ..gpu.display import DisplaySettings


@dataclass(frozen=True)
class DrawFrame:
    """What every drawer needs of one draw: where from, which lights, which output."""

    view_projection: np.ndarray
    view: View
    lights: list[SpectralLight]
    lights_key: Hashable
    display: DisplaySettings
    output: str


class BoundSlot(NamedTuple):
    """A material slot's shader, bound with its textures and parameters, ready to draw."""

    key: Hashable           # the shader variant (``DrawStats.variants``)
    shader: Any
    keep: Any               # held until the draw: a freed uniform buffer leaves the block unbound


@dataclass(frozen=True)
class MaterialDrawer:
    """Draws material slots, one batch each, on the shared mesh batches.

    ``resource(material)`` is the material's GPU resource (with an ``nbytes``), or None
    when it cannot be drawn; ``bind(resource, frame)`` binds it for one draw.
    """

    name: str
    order: int
    claims: Callable[[Any], bool]
    resource: Callable[[Any], Any]
    bind: Callable[[Any, DrawFrame], BoundSlot]
    clear_cache: Callable[[], None]
    failures: Callable[[], dict[str, str]]


@dataclass(frozen=True)
class ObjectDrawer:
    """Draws whole objects with its own batches (``draw`` returns the names drawn)."""

    name: str
    order: int
    objects: Callable[[Any], list]
    draw: Callable[[Any, Any, list, DrawFrame], list[str]]
    clear_cache: Callable[[], None]
    failures: Callable[[], dict[str, str]]


_DRAWERS: dict[str, MaterialDrawer | ObjectDrawer] = {}


def register(drawer: MaterialDrawer | ObjectDrawer) -> None:
    """Add ``drawer`` (replacing one of the same name)."""
    _DRAWERS[drawer.name] = drawer


def unregister(name: str) -> None:
    _DRAWERS.pop(name, None)


def drawers() -> list[MaterialDrawer | ObjectDrawer]:
    return sorted(_DRAWERS.values(), key=lambda d: (d.order, d.name))


def material_drawers() -> list[MaterialDrawer]:
    return [d for d in drawers() if isinstance(d, MaterialDrawer)]


def object_drawers() -> list[ObjectDrawer]:
    return [d for d in drawers() if isinstance(d, ObjectDrawer)]


def drawer_names() -> list[str]:
    return [d.name for d in drawers()]


def claiming_drawer(material) -> MaterialDrawer | None:
    """The first material drawer that claims ``material`` (None: an occluder)."""
    for drawer in material_drawers():
        if drawer.claims(material):
            return drawer
    return None


def failure(name: str, what: str) -> str | None:
    """Why drawer ``name`` did not draw ``what`` (a material or object), or None."""
    drawer = _DRAWERS.get(name)
    return None if drawer is None else drawer.failures().get(what)


def failures() -> list[tuple[str, str]]:
    """(what, reason) of everything a drawer refused, each drawer's sorted by name."""
    return [item for drawer in drawers() for item in sorted(drawer.failures().items())]


def clear_caches() -> None:
    """Empty every drawer's caches (the handler empties the shared ones below them)."""
    for drawer in drawers():
        drawer.clear_cache()
