"""The protocol sphere (shared/PROTOCOL.md) drawn on the GPU through the viewport's shaders."""

from __future__ import annotations

import numpy as np

from ...core.brdf.factored import FactoredBRDF
from ...core.brdf.shading import protocol_sun
from ...core.lights import SpectralLight
from ..gpu.display import DisplaySettings
from ..gpu.offscreen import Target
from ..gpu.shaders import get_shader
from .gpu_material import GPUMaterial

_QUAD = np.array([[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0], [1.0, 1.0]], dtype=np.float32)


def render_sphere(model: FactoredBRDF, incidence_deg: float = 0.0,
                  illuminant: str | np.ndarray = "D65", size: int = 256, *,
                  lights: list[SpectralLight] | None = None, output: str = "XYZ",
                  packs: int | None = None, precontract: bool = True,
                  display: DisplaySettings | None = None, factors: str = "exact") -> np.ndarray:
    """The protocol sphere drawn on the GPU: (size, size, 4) float32, row 0 at the bottom.

    XYZ output is linear CIE XYZ, protocol-normalised; alpha is 1 on the sphere and 0
    off it. ``lights`` replaces the protocol's sun at ``incidence_deg``. ``packs`` draws
    the model's first packs (``FactoredBRDF.truncated``). ``factors`` is the factor
    precision (``filtered_factors.FACTOR_PRECISIONS``).
    """
    from gpu_extras.batch import batch_for_shader

    if lights is None:
        lights = [protocol_sun(incidence_deg, illuminant, model.wavelengths)]
    if packs is not None:
        model = model.truncated(packs)
    material = GPUMaterial(model, factors)
    shader = get_shader(material.key(lights, precontract=precontract, output=output,
                                     sphere=True))
    batch = batch_for_shader(shader, "TRI_STRIP", {"corner": _QUAD})
    light_texture = material.light_texture(lights, precontract)
    with Target(size, size) as target:
        params = material.params(display or DisplaySettings(), target_size=(size, size))
        material.bind(shader, light_texture, params)
        batch.draw(shader)
        return target.read()
