"""Shared pieces of the GPU tests: the models factored, and GPU-vs-mirror comparisons."""

from __future__ import annotations

import numpy as np

from spectral_materials.blender.brdf.sphere import render_sphere
from spectral_materials.core.brdf import models, shading
from spectral_materials.core.brdf.factor import factor_brdf
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

WL = spectra.WAVELENGTHS_REFERENCE
PARAMETERIZATIONS = ("io", "io_iso", "hd", "hd_iso", "gs", "ea")
#: Cells per axis, kept small so that each factorisation takes well under 2 s.
RESOLUTIONS = {
    "io": (12, 12, 12, 12),
    "hd": (12, 12, 12, 12),
    "gs": (12, 12, 12, 12),
    "ea": (12, 12, 12, 12),
    "io_iso": (16, 32, 16),
    "hd_iso": (16, 16, 32),
}
#: Ashikhmin–Shirley BRDFs factored: an anisotropic glossy orange for the 4-D
#: layouts, an isotropic glossy blue sky for the isotropic ones, a near-mirror lobe.
BRDFS = {
    "anisotropic": {"nu": 48.0, "nv": 12.0, "patch": 7},
    "isotropic": {"nu": 32.0, "nv": 32.0, "patch": 3},
    "mirror": {"nu": 1e4, "nv": 1e4, "patch": 3},
}
#: The issue's bound on the GPU image against the float64 mirror.
MAX_DE94 = 0.1
#: Reference luminance below which a pixel counts as dark: compared in absolute XYZ.
DARK_Y = 1e-3
SIZE = 64


def build_model(parameterization: str, brdf: str | None = None, packs: int = 4,
                cosine_weighted: bool = True):
    """A BRDF of :data:`BRDFS` factored on ``parameterization`` with an 8-vector basis."""
    if brdf is None:
        brdf = "isotropic" if parameterization.endswith("_iso") else "anisotropic"
    spec = BRDFS[brdf]
    model = models.make_model("ashikhmin_shirley", nu=spec["nu"], nv=spec["nv"],
                              diffuse=(WL, spectra.colorchecker(spec["patch"])),
                              specular=0.05)
    return factor_brdf(model, parameterization=parameterization,
                       isotropic=parameterization.endswith("_iso"),
                       resolution=RESOLUTIONS[parameterization], packs=packs,
                       spectral_basis=8, cosine_weighted=cosine_weighted)


def four_lights() -> list:
    """A sun, a point, a spot and an area light of four spectra around the protocol sphere."""
    from spectral_materials.core.lights import SpectralLight

    return [SpectralLight("SUN", spd("D65"), WL, 1.0, axis=(-0.5, -0.2, -0.84)),
            SpectralLight("POINT", spd("FL2"), WL, 40.0, position=(1.5, 0.5, 2.0)),
            SpectralLight("SPOT", spd("A"), WL, 60.0, position=(-1.0, 1.0, 2.5),
                          axis=(0.35, -0.35, -0.87), spot_size=np.radians(60.0),
                          spot_blend=0.2),
            SpectralLight("AREA", spd("FL11"), WL, 30.0, position=(0.2, -1.5, 1.5),
                          axis=(-0.1, 0.7, -0.7))]


def spd(name: str) -> np.ndarray:
    return colour_pipeline.illuminant_spd(name, WL)


def check_image(image: np.ndarray, mask: np.ndarray) -> None:
    """Finite everywhere, alpha 1 exactly on the sphere, transparent black off it."""
    assert image.shape == (*mask.shape, 4) and image.dtype == np.float32
    assert np.isfinite(image).all(), f"{int((~np.isfinite(image)).sum())} non-finite values"
    np.testing.assert_array_equal(image[..., 3], mask.astype(np.float32))
    assert not image[~mask].any()


def protocol_pair(model, incidence_deg: float, illuminant: str = "D65", size: int = SIZE, **kw):
    """(GPU XYZ (P, 3), mirror XYZ (P, 3)) on the protocol sphere's pixels."""
    image = render_sphere(model, incidence_deg, illuminant, size, **kw)
    reference, mask = shading.sphere_xyz(model, incidence_deg, illuminant, size)
    check_image(image, mask)
    return image[mask][:, :3].astype(np.float64), reference[mask]


def lights_pair(model, lights, size: int = SIZE, **kw):
    """(GPU XYZ (P, 3), mirror XYZ (P, 3)) on the sphere's pixels lit by ``lights``."""
    image = render_sphere(model, lights=lights, size=size, **kw)
    points, mask = shading.sphere_pixels(size)
    reference = shading.shade_xyz(model, points, points, np.zeros_like(points),
                                  shading.View(), lights, two_sided=False)
    check_image(image, mask)
    return image[mask][:, :3].astype(np.float64), reference


def delta_e(reference: np.ndarray, test: np.ndarray, illuminant="D65") -> np.ndarray:
    """ΔE94 per pixel, white = the white Lambertian under ``illuminant``."""
    white = colour_pipeline.white_xyz(illuminant, WL)
    return colour_pipeline.delta_e94(reference, test, white)


def compare_lit(got: np.ndarray, reference: np.ndarray, *, max_de: float = MAX_DE94,
                dark_abs: float = 1e-5) -> float:
    """ΔE94 (D65 white) where the reference Y > :data:`DARK_Y`, absolute XYZ elsewhere.

    Returns the max ΔE94 over the bright pixels (asserting there are some).
    """
    bright = reference[:, 1] > DARK_Y
    assert bright.sum() > 20, f"only {int(bright.sum())} bright pixels: nothing to compare"
    de = delta_e(reference[bright], got[bright])
    assert de.max() <= max_de, f"max ΔE94 {de.max():.4g} > {max_de} over {bright.sum()} pixels"
    if (~bright).any():
        error = np.abs(got[~bright] - reference[~bright]).max()
        assert error <= dark_abs, f"dark pixels differ by {error:.3g} in XYZ"
    return float(de.max())
