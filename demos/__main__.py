"""``python -m demos``: the main job (see ``demos.main``)."""

import sys

from .backend import choose_backend

choose_backend(sys.argv[1:])    # before .main imports bpy

from .main import run  # noqa: E402

run()
