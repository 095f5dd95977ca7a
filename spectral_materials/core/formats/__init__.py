"""File formats read and written by the core.

``tabulated``     the project's sampled spectral BRDF ``.npz``
``merl``          MERL ``.binary`` (RGB, half/difference angles), uplifted to spectra
``rgl_bsdf``      RGL ``.bsdf`` tensor files (EPFL spectral database; Dupuy & Jakob 2018)
``exr``           plain OpenEXR images of named float channels
``spectral_exr``  spectral OpenEXR (Fichet, Pacanowski, Wilkie 2021 layout)
``ubo_btf``       Bonn BTF archives: UBO2003 zips of JPEGs, UBO2014 ``.btf`` (DFMF/FMF)
``brdf_files``    the BRDF readers by file suffix

Every reader validates headers and sizes before allocating, counts invalid samples,
and turns damage into a ``ValueError`` subclass naming the file and the problem.
"""
