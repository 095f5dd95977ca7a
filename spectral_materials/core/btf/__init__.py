"""BTFs: the container and view interpolation, procedural BTFs, reflectance-field and lobe
fits (with batched Levenberg–Marquardt), the drawable layout and its Python mirror, and the
material job.

Until the next release, ``spectral_materials.core.btf.<name>`` also serves the names of the
old ``core/btf.py`` (now :mod:`.container`), with a DeprecationWarning."""

from ..._moved import forward_to

__getattr__ = forward_to(__name__, "container")
