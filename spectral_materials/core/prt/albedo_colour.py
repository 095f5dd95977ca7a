"""The colour a drawn albedo texture makes against the exact R̃ layers.

Every cheaper form of the albedo that spectral PRT draws (16-bit layers, a texture
basis: :mod:`.albedo_forms`) is accepted only where no texel moves by more than
:data:`COLOUR_BOUND_DE94` against the float32 layers under each of
:data:`COLOUR_ILLUMINANTS`: a daylight, a spiky fluorescent and an incandescent light.
"""

from __future__ import annotations

import numpy as np

from .albedo import TEXELS_PER_BLOCK, AlbedoLayers, albedo_layers_from_spectra

#: The largest ΔE94 a drawn form may make against the layers, per texel, under each of
#: :data:`COLOUR_ILLUMINANTS` (the factor precisions' *Automatic* bound).
COLOUR_BOUND_DE94 = 0.05
COLOUR_ILLUMINANTS = ("D65", "FL11", "A")


def layers_colour_error(albedo: AlbedoLayers, drawn: np.ndarray,
                        illuminants: tuple[str, ...] = COLOUR_ILLUMINANTS,
                        lights: tuple[np.ndarray, ...] = ()) -> float:
    """Largest ΔE94 over the texels between the albedo lit by each light through its
    layers and through ``drawn`` (m, H, W, 3): ``XYZ_c = Σ_j L̂_j R̃_jc`` with ``L̂`` the
    light on the layers' spectral basis, white = a unit albedo's XYZ under it.

    Parameters
    ----------
    illuminants : tuple of str
        Named illuminants (``pipeline.illuminant_spd``), projected on the basis.
    lights : tuple of ndarray (m,)
        Lights already on the basis (a scene's environment). One under which a unit
        albedo is not lit (white Y ≤ 0) is skipped.

    Raises
    ------
    ValueError
        ``drawn`` is not the shape of ``albedo.layers``, or a light is not (m,) finite.
    """
    from ..colour.pipeline import delta_e94, illuminant_spd

    drawn = np.asarray(drawn)
    if drawn.shape != albedo.layers.shape:
        raise ValueError(f"drawn layers {drawn.shape} are not the albedo's "
                         f"{albedo.layers.shape}")
    wl = albedo.wavelengths
    psi = np.eye(wl.size) if albedo.basis is None else np.asarray(albedo.basis, np.float64)
    unit = albedo_layers_from_spectra(np.ones((1, 1, wl.size)), wl, albedo.basis)
    m, h, w, _ = albedo.layers.shape
    full = albedo.layers.reshape(m, h * w, 3)
    drawn = drawn.reshape(m, h * w, 3)
    given = [np.asarray(light, dtype=np.float64) for light in lights]
    if any(light.shape != (m,) or not np.isfinite(light).all() for light in given):
        raise ValueError(f"lights must be finite ({m},) vectors on the albedo's basis")
    worst = 0.0
    for light in [psi.T @ illuminant_spd(i, wl) for i in illuminants] + given:   # L̂ (m,)
        white = light @ unit.layers[:, 0, 0].astype(np.float64)
        if not white[1] > 0.0:
            continue
        light, white = light / white[1], white / white[1]          # white Y = 1
        for begin in range(0, h * w, TEXELS_PER_BLOCK):
            block = slice(begin, begin + TEXELS_PER_BLOCK)
            xyz = np.einsum("j,jtc->tc", light, full[:, block].astype(np.float64))
            approx = np.einsum("j,jtc->tc", light, drawn[:, block].astype(np.float64))
            de = delta_e94(xyz, approx, white)
            worst = max(worst, float(de.max()))
    return worst
