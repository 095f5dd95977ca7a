"""Session hooks shared by every test folder, and ``tests/helpers`` on ``sys.path`` (scene
builders, model builders, memory probes and hostile files, imported by bare name from any
folder of the tree)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent / "helpers"))

_STATUS: dict[str, int] = {}


def pytest_sessionfinish(session, exitstatus) -> None:
    _STATUS["exit"] = int(exitstatus)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config) -> None:
    """After the summary, leave a session that used Blender without Blender's exit handler,
    which sometimes crashes on 5.3 with Vulkan
    (``spectral_materials.blender.gpu.context.exit_process``)."""
    if "bpy" in sys.modules and "exit" in _STATUS:
        from spectral_materials.blender.gpu.context import exit_process

        exit_process(_STATUS["exit"])
