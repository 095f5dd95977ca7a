"""Real orthonormal spherical harmonics for (spectral) precomputed radiance transfer.

The directional basis of spectral PRT (Sloan, Kautz & Snyder 2002; the
spectral PRT paper, §3.3: "the first five bands of spherical harmonics") only
needs to be orthonormal on the sphere. This module provides that basis, the
quadrature to project onto it, the analytic zonal kernels used for diffuse
transfer (clamped cosine, spherical caps), zonal convolution (Funk–Hecke),
rotation of coefficient vectors and ringing-suppression windows.

Conventions
-----------
* ``bands`` ``L`` (1 ≤ L ≤ :data:`MAX_BANDS`) means degrees ``l = 0 … L − 1`` and
  ``L²`` coefficients (:func:`sh_count`); the default is :data:`DEFAULT_BANDS`
  = 5 bands = 25 coefficients, as in the spectral PRT paper.
* Ordering: coefficient index ``i = l² + l + m`` with ``m = −l … l`` (so band 1
  is ``(m = −1, 0, 1)``). The SH axis is always the **last** axis of a
  coefficient array; directions are ``(..., 3)`` arrays (any leading shape).
* Sign: the usual graphics real SH **without** the Condon–Shortley phase
  (Sloan 2008; Green 2003)::

      Y_l0  = N_l^0 P̄_l^0(z)
      Y_lm  = √2 N_l^m P̄_l^m(z) Re((x + iy)^m)       m > 0
      Y_l−m = √2 N_l^m P̄_l^m(z) Im((x + iy)^m)       m > 0

  with ``N_l^m = √((2l+1)/(4π) (l−m)!/(l+m)!)`` and ``P̄_l^m = P_l^m / sin^m θ``
  the Legendre function without the Condon–Shortley phase. Band 1 is
  ``√(3/(4π)) (y, z, x)``: every ``Y_l,±l`` is positive along +x / +y.
  Relation to the complex ``scipy.special.sph_harm`` (which *includes* the
  Condon–Shortley phase ``(−1)^m``)::

      Y_lm  = √2 (−1)^m Re(Y_l^m)      m > 0
      Y_l0  =            Y_l^0
      Y_l−m = √2 (−1)^m Im(Y_l^m)      m > 0

* Rotation: :func:`rotation_matrix_sh` returns the block-diagonal ``M(R)`` with
  ``sh_basis(d @ R.T) == sh_basis(d) @ M.T`` (i.e. ``y(R d) = M y(d)``). A
  function ``f`` with coefficients ``c`` rotated by ``R`` (``g(d) = f(Rᵀ d)``,
  what was at ``d`` is now at ``R d``) has coefficients ``M @ c``, written
  ``c @ M.T`` for stacked coefficient rows (:func:`rotate`). ``M`` is a group
  homomorphism: ``M(R1 @ R2) = M(R1) @ M(R2)``, orthogonal, and ``det M = 1``
  for proper rotations.
* Zonal harmonics: a function symmetric about +z is ``Σ_l z_l Y_l0``; the
  per-band ``z_l`` arrays (length ``L``) are what :func:`clamped_cosine_zonal`,
  :func:`cap_zonal` and :func:`window` return and what :func:`zonal_to_sh`
  and :func:`convolve_zonal` take.

Numerical policy
----------------
:func:`sh_basis` evaluates the basis by the normalised associated-Legendre
recurrence in ``z`` and the recurrence ``(x + iy)^m`` in ``x, y`` — polynomials
in the unit vector's components, no trigonometry, exact at the poles. Input
directions are normalised (after scaling by their largest component, so
tiny and huge vectors are fine); zero vectors and non-finite components raise
:class:`ValueError`. Orthonormality by :func:`sphere_quadrature` holds to
~1e-14 up to 32 bands; agreement with scipy to ~1e-13.

References
----------
Sloan, P.-P., Kautz, J., Snyder, J. (2002). Precomputed radiance transfer for
real-time rendering in dynamic, low-frequency lighting environments.
SIGGRAPH 2002, 527–536.
Green, R. (2003). Spherical harmonic lighting: the gritty details. GDC 2003.
Sloan, P.-P. (2008). Stupid spherical harmonics (SH) tricks. GDC 2008
(real-SH convention, Hanning and Lanczos windowing against ringing).
Ramamoorthi, R., Hanrahan, P. (2001). An efficient representation for
irradiance environment maps. SIGGRAPH 2001, 497–500 (clamped-cosine
zonal coefficients, Funk–Hecke convolution).
Ivanic, J., Ruedenberg, K. (1996). Rotation matrices for real spherical
harmonics. Direct determination by recursion. J. Phys. Chem. 100(15),
6342–6347; Additions and corrections (1998), J. Phys. Chem. A 102(45), 9099–9100.
Abramowitz, M., Stegun, I. A. (1964). Handbook of Mathematical Functions,
§25.4.29 (Gauss–Legendre quadrature).

The functions live in :mod:`.sh_functions` (basis, evaluation, quadrature, projection),
:mod:`.sh_zonal`, :mod:`.sh_rotation` and :mod:`.sh_window`; this module re-exports them.
"""

from __future__ import annotations

from .sh_functions import (
    DEFAULT_BANDS,
    MAX_BANDS,
    evaluate,
    project,
    project_function,
    sh_basis,
    sh_count,
    sh_indices,
    sphere_quadrature,
)
from .sh_rotation import rotate, rotation_matrix_sh
from .sh_window import apply_window, window
from .sh_zonal import cap_zonal, clamped_cosine_zonal, convolve_zonal, zonal_to_sh

__all__ = [
    "DEFAULT_BANDS",
    "MAX_BANDS",
    "sh_count",
    "sh_indices",
    "sh_basis",
    "sphere_quadrature",
    "project",
    "project_function",
    "evaluate",
    "clamped_cosine_zonal",
    "cap_zonal",
    "zonal_to_sh",
    "convolve_zonal",
    "rotation_matrix_sh",
    "rotate",
    "window",
    "apply_window",
]
