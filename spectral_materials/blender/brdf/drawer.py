"""The factor-pack drawer: materials with stored factors, drawn slot by slot in the viewport.

Registered with the viewport's registry at import. It claims every material another
drawer did not claim first; a material without current factors is then drawn as an
occluder. :class:`~.gpu_material.GPUMaterial`\\ s are cached per material and rebuilt
when the stored factors change; a material that failed is not retried until they do.
"""

from __future__ import annotations

from ...core.brdf.filtered_factors import choose_precision
from ..gpu import shaders
from ..viewport import registry
from . import storage
from .gpu_material import GPUMaterial

_MATERIALS: dict[str, tuple] = {}
#: Materials that failed to draw: name → (factor key, reason); shown in the panel and
#: not retried until their factors change.
FAILED: dict[str, tuple] = {}


def _material_key(material) -> tuple | None:
    result = material.spectral.result
    if not material.spectral.enabled or result.image is None:
        return None
    return (result.image.name, result.input_hash, result.terms, result.spectral_size,
            result.image.size[0], result.image.size[1], draw_precision(material))


def draw_precision(material) -> str:
    """The material's factor precision setting: ``"auto"`` or one of
    ``filtered_factors.FACTOR_PRECISIONS``."""
    return material.spectral.draw_precision.lower()


def _gpu_material(model, setting: str) -> GPUMaterial:
    return GPUMaterial(model, choose_precision(model)[0] if setting == "auto" else setting)


def gpu_material(material) -> GPUMaterial | None:
    """The cached :class:`GPUMaterial` of a material with stored factors (else None)."""
    key = _material_key(material)
    if key is None:
        return None
    cached = _MATERIALS.get(material.name)
    if cached is not None and cached[0] == key:
        return cached[1]
    if FAILED.get(material.name, (None,))[0] == key:
        return None
    try:
        resource = _gpu_material(storage.load_factored(material), draw_precision(material))
    except ValueError as exc:
        FAILED[material.name] = (key, str(exc))
        print(f"Spectral Materials: not drawing '{material.name}': {exc}")
        return None
    _MATERIALS[material.name] = (key, resource)
    return resource


def bind(resource: GPUMaterial, frame: registry.DrawFrame) -> registry.BoundSlot:
    """Bind the factor-pack variant of ``resource`` for one draw."""
    key = resource.key(frame.lights, output=frame.output)
    shader = shaders.get_shader(key)
    # Held until the draw: a freed uniform buffer leaves the block unbound.
    params = resource.params(frame.display, view_origin=frame.view.uniform(),
                             view_projection=frame.view_projection)
    resource.bind(shader, resource.light_texture(frame.lights, key.precontract,
                                                 frame.lights_key), params)
    return registry.BoundSlot(key, shader, params)


def drawn_precision(material) -> str | None:
    """The precision the viewport draws ``material`` with, once it has drawn it."""
    cached = _MATERIALS.get(material.name)
    return None if cached is None else cached[1].precision


def failures() -> dict[str, str]:
    return {name: reason for name, (_, reason) in FAILED.items()}


def clear_cache() -> None:
    _MATERIALS.clear()
    FAILED.clear()


DRAWER = registry.MaterialDrawer(
    name="factor packs", order=100, claims=lambda material: True, resource=gpu_material,
    bind=bind, clear_cache=clear_cache, failures=failures)
registry.register(DRAWER)
