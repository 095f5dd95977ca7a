"""``python -m spectral_materials``: the command line (see :mod:`spectral_materials.cli`)."""

from .cli import main

if __name__ == "__main__":
    raise SystemExit(main())
