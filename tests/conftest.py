"""Session hooks shared by every test folder."""

from __future__ import annotations

import sys

import pytest

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
