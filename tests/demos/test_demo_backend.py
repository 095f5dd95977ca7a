"""The demo's backend choice (demos/backend.py): OpenGL on a Linux machine whose only
Vulkan driver would be lavapipe, the user's explicit choice everywhere else."""

import subprocess
import sys
from pathlib import Path

import pytest

from demos.backend import HIDE_VULKAN, choose_backend, requested_backend

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("argv", "wanted"), [
    ([], "auto"), (["--quick"], "auto"), (["--gpu-backend", "vulkan"], "vulkan"),
    (["--quick", "--gpu-backend=opengl"], "opengl"), (["--gpu-backend"], "auto"),
])
def test_requested_backend_reads_both_spellings(argv, wanted):
    assert requested_backend(argv) == wanted


def test_auto_takes_opengl_on_linux_without_a_gpu_device():
    env: dict[str, str] = {}
    assert choose_backend([], env, platform="linux", gpu_device_node=False) == "opengl"
    assert env == {"VK_ICD_FILENAMES": HIDE_VULKAN, "VK_DRIVER_FILES": HIDE_VULKAN}


@pytest.mark.parametrize(("platform", "node", "env"), [
    ("linux", True, {}),                                  # a GPU may drive Vulkan
    ("win32", False, {}), ("darwin", False, {}),          # no lavapipe there
    ("linux", False, {"VK_ICD_FILENAMES": "/x/lvp_icd.json"}),   # the user chose
    ("linux", False, {"VK_DRIVER_FILES": "/x/lvp_icd.json"}),    # newer loaders' list
    ("linux", False, {"VK_ADD_DRIVER_FILES": "/x/nv.json"}),
])
def test_auto_leaves_blender_to_choose_elsewhere(platform, node, env):
    before = dict(env)
    assert choose_backend([], env, platform=platform, gpu_device_node=node) == "blender"
    assert env == before


def test_explicit_choices_override_the_environment():
    env = {"VK_ICD_FILENAMES": HIDE_VULKAN, "VK_DRIVER_FILES": HIDE_VULKAN}
    assert choose_backend(["--gpu-backend", "vulkan"], env, platform="linux") == "vulkan"
    assert env == {}
    env = {"VK_ADD_DRIVER_FILES": "/x/nv.json"}
    assert choose_backend(["--gpu-backend", "opengl"], env, platform="darwin") == "opengl"
    assert env == {"VK_ICD_FILENAMES": HIDE_VULKAN, "VK_DRIVER_FILES": HIDE_VULKAN}


def test_a_bad_value_is_left_to_the_parser_which_names_it():
    env: dict[str, str] = {}
    assert choose_backend(["--gpu-backend", "metal"], env, platform="linux",
                          gpu_device_node=False) == "blender"
    code = "from demos.main import parse_args; parse_args(['--gpu-backend', 'metal'])"
    proc = subprocess.run([sys.executable, "-c", code],
                          cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "metal" in proc.stderr and "--gpu-backend" in proc.stderr


def test_an_abbreviated_option_is_refused_not_misread():
    """The backend is read before the parser runs, so the parser takes no abbreviation
    (``--gpu opengl`` would parse while the backend stayed ``auto``)."""
    code = "from demos.main import parse_args; parse_args(['--gpu', 'opengl'])"
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 2 and "--gpu" in proc.stderr
