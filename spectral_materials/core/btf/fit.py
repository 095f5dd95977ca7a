"""Fitting compact models to a BTF: reflectance fields (RFP, RFNL), Lafortune lobes, CP.

Meseth, Müller and Klein (2003) render a BTF by interpolating between per-view
*reflectance fields* ``RF_v(x, l) = BTF(x, l, v)`` (§3.1), each fitted per texel by a
compact function of the light direction (§4), and compare the fits by the mean absolute
error ε of eq. (2) (Table 1). This module fits, stores and evaluates four models of a
:class:`~.btf.BTF` (``values = π f cos θ_l``: foreshortening included, NaN for missing
(view, light) images):

``RFP`` (:func:`fit_rfp`)
    Per view and texel the biquadratic polynomial of Malzbender et al. (2001)
    ``Y ≈ a0 lu² + a1 lv² + a2 lu lv + a3 lu + a4 lv + a5`` in ``(lu, lv) = (l_x, l_y)``;
    linear least squares.
``RFNL`` (:func:`fit_rfnl`)
    Per view and texel the paper's eq. (1) ``Y ≈ ρd + Σ_j a_j max(t̂_j · l, 0)^{n_j}`` in a
    *stable parameterisation* (below), fitted by Levenberg–Marquardt from a high-pass
    initialisation of the lobe axes (§4.1).
``LAF`` (:func:`fit_lafortune`)
    Per texel over all views and lights, isotropic generalised cosine lobes (Lafortune et
    al. 1997; McAllister et al. 2002) times the foreshortening that the data include —
    the comparison model of Table 1.
``CP`` (:func:`fit_cp`)
    The whole (texels, views, lights, channels) tensor as CP factor packs
    (:func:`.cp.fit_packs`).

Colour (RFP, RFNL, LAF)
    "Since we apply the function for luminance data only, the final color is computed as
    in [PTM]" (§4.1): every model fits the luminance ``Y = values · w`` (``w`` =
    :meth:`BTF.channel_weights`), and each texel gets one spectral (or RGB) albedo
    ``albedo(x) = Σ_{v,l present} values / Σ_{v,l present} Y`` (:func:`spectral_albedo`),
    so ``albedo · w = 1`` and the reconstruction is ``Y_fit(x, l, v) · albedo(x)``. A texel
    whose spectrum is a constant times its luminance is therefore reproduced exactly
    wherever its luminance is. CP factors the spectral data directly (no albedo).

Stable RFNL parameterisation (the paper's white pixels)
    The paper stores ``ρs`` and a lobe vector ``t`` of any length and evaluates
    ``ρs (t·l)^n`` on the GPU; with ``|t| > 1`` and large n that overflows — "disturbing
    white pixels … more frequently" in 16-bit floats (§5.3). Since
    ``ρs (t·l)^n = ρs |t|^n (t̂·l)^n``, we store the unit axis t̂ and the amplitude
    ``a = ρs |t|^n`` separately, clamp ``a ∈ [0, A_MAX]`` (A_MAX = 60000 < 65504, the
    float16 maximum) and ``n ∈ [0.5, 10000]``. Then ``(t̂·l)^n ≤ 1`` and every lobe value is
    ``≤ a``: nothing overflows in float32 or float16. :func:`paper_overflows` shows the
    paper form overflowing, :func:`lobes_from_paper` converts paper parameters in log space.

Parameter layouts (float32; the GPU reads each group of 4 as one RGBA texel)
    RFP ``params (V', H, W, 6)``: ``[a0, a1, a2, a3, a4, a5]``; GPU: 2 RGBA texels per
    view and texel, ``(a0, a1, a2, a3)`` and ``(a4, a5, 0, 0)``.
    RFNL ``params (V', H, W, 4·(h + k))`` with ``h = ceil((1 + k)/4)`` header texels
    (h = 1 for k ≤ 3, so the width is ``4·(1 + k)``):
    ``[ρd, a_1, …, a_k, 0 …]`` padded with zeros to 4·h, then per lobe j (sorted by
    decreasing a_j) ``(t̂x, t̂y, t̂z, n)``. A lobe with ``a_j = 0`` is absent (its axis is
    (0, 0, 1), n = 1). GPU: h + k RGBA texels per view and texel.
    LAF ``params (H, W, 1 + 3·lobes)``: ``[ρd, C_xy,1, C_z,1, n_1, C_xy,2, …]``; GPU:
    ``ceil((1 + 3·lobes)/4)`` RGBA texels per texel (zero padded).
    CP ``factors``: ``[texels (H·W, R), views (V, R), lights (L, R), channels (C, R)]``,
    R = 4·packs; GPU: every factor float once (one RGBA texel per pack and row).
    RF and LAF models also store ``albedo (H, W, C)``: ``ceil(C/4)`` RGBA texels per texel.
    :attr:`BTFModel.nbytes_gpu` counts exactly these (float32) bytes.

Views
    An RF model has one fit per *modelled* view: ``model.views (V', 3)`` and
    ``model.view_indices (V',)`` (their indices in the fitted BTF). A view with fewer
    present lights than the model has unknowns is left out and listed in
    ``model.dropped_views`` (view interpolation then spans its neighbours).
    ``reconstruct``/``luminance_at`` take *positions* in ``model.views``. LAF and CP model
    all views.

References
----------
Meseth, J., Müller, G., Klein, R. (2003). Reflectance field based real-time, high quality
rendering of bidirectional texture functions. Computers & Graphics 28(1), 105–112.
Malzbender, T., Gelb, D., Wolters, H. (2001). Polynomial texture maps. SIGGRAPH 2001.
Lafortune, E. P. F., Foo, S.-C., Torrance, K. E., Greenberg, D. P. (1997). Non-linear
approximation of reflectance functions. SIGGRAPH '97.
McAllister, D. K., Lastra, A., Heidrich, W. (2002). Efficient rendering of spatial
bi-directional reflectance distribution functions. Graphics Hardware 2002.
Kolda, T. G., Bader, B. W. (2009). Tensor decompositions and applications. SIAM Review.

The fits live in sibling modules, re-exported here: :mod:`.fit_models` (the model classes,
the albedo), :mod:`.fit_rf` (RFP, RFNL; its start in :mod:`.fit_rfnl_start`),
:mod:`.fit_lafortune`, :mod:`.fit_cp` and :mod:`.fit_error` (ε, Table 1).
"""

from __future__ import annotations

from collections.abc import Callable

# The ``noqa: F401`` names are not public: they stay importable from here as before the
# split (tests reach ``_rfnl_init``).
from .fit_cp import (
    _cp_tensor,  # noqa: F401
    fit_cp,
)
from .fit_error import epsilon, error_table
from .fit_lafortune import (
    LAF_TEMPLATES,  # noqa: F401
    fit_lafortune,
)
from .fit_models import (  # noqa: F401
    TEXEL_BYTES,
    BTFModel,
    CPModel,
    InsufficientBTFData,
    LafortuneModel,
    RFNLModel,
    RFPModel,
    rfnl_evaluate,
    rfp_basis,
    spectral_albedo,
)
from .fit_rf import (
    RFNL_SOLVERS,
    fit_rfnl,
    fit_rfp,
    lobes_from_paper,
    paper_overflows,
)
from .fit_rfnl_start import RFNL_EXPONENT_GRID, _rfnl_init  # noqa: F401
from .lm import A_MAX, N_MAX, N_MIN

__all__ = [
    "A_MAX", "N_MIN", "N_MAX", "METHODS", "RFNL_SOLVERS", "InsufficientBTFData", "BTFModel",
    "RFPModel", "RFNLModel", "LafortuneModel", "CPModel", "spectral_albedo", "rfp_basis",
    "fit_rfp", "fit_rfnl", "fit_lafortune", "fit_cp", "lobes_from_paper", "paper_overflows",
    "epsilon", "error_table",
]


#: Fitters by the names of Table 1. Each is ``fit(btf, *, callback=None, seed=0, …)``.
METHODS: dict[str, Callable[..., BTFModel]] = {
    "RFP": fit_rfp, "RFNL": fit_rfnl, "LAF": fit_lafortune, "CP": fit_cp}
