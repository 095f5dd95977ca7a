"""``python -m demos``: the main job (see ``demos.main``)."""

from .main import run

run()
