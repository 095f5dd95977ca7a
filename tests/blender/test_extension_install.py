"""The packaged extension installs into a fresh Blender and runs from its own copy.

``scripts/build_extension`` builds the zip for this machine's platform (once per module;
``SPECTRAL_EXTENSION_ZIP=path`` tests a prebuilt zip instead). ``extension_probe.py`` then
runs in a fresh ``.venv`` Python with a temporary Blender user directory
(``BLENDER_USER_RESOURCES``), installs the zip with
``bpy.ops.extensions.package_install_files(repo="user_default", enable_on_install=True)``
and factors one material through the installed add-on. The probe hides the checkout's
editable ``spectral_materials`` and the .venv's colour, scipy, imageio, PIL and
typing_extensions, so only the installed copy and its bundled wheels can run.
"""

from __future__ import annotations

import importlib.util
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BUILD = ROOT / "scripts" / "build_extension"
PROBE = Path(__file__).with_name("extension_probe.py")
VENV_PYTHON = ROOT / ".venv" / "bin" / "python"
ADDON = "bl_ext.user_default.spectral_materials"
BUNDLED = ("colour", "scipy", "imageio", "PIL", "typing_extensions", "OpenEXR")
STAGES = ("start", "import bpy", "read_homefile", "install", "enabled", "bundled wheels",
          "operator", "factor", "done")

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("bpy") is None,
    reason="needs the bpy module (requirements/blender.txt)",
)


def this_platform() -> str | None:
    """Blender's name for this machine's platform (as in the manifest's ``platforms``)."""
    system = {"linux": "linux", "windows": "windows", "darwin": "macos"}.get(
        platform.system().lower())
    machine = {"x86_64": "x64", "amd64": "x64", "arm64": "arm64", "aarch64": "arm64"}.get(
        platform.machine().lower())
    return f"{system}-{machine}" if system and machine else None


def tail(text: str, lines: int = 40) -> str:
    return "\n".join(text.strip().splitlines()[-lines:])


@pytest.fixture(scope="module")
def extension_zip(tmp_path_factory) -> Path:
    if prebuilt := os.environ.get("SPECTRAL_EXTENSION_ZIP"):
        return Path(prebuilt).resolve()
    target = this_platform()
    if target is None:
        pytest.skip(f"no Blender platform name for {platform.system()} {platform.machine()}")
    out = tmp_path_factory.mktemp("dist")
    done = subprocess.run(
        [str(BUILD), "--out", str(out), "--platform", target],
        capture_output=True, text=True, timeout=600,
    )
    output = tail(done.stdout + done.stderr)
    assert done.returncode == 0, f"scripts/build_extension failed:\n{output}"
    zips = sorted(out.glob("*.zip"))
    assert len(zips) == 1, f"expected one zip in {out}, found {[z.name for z in zips]}"
    return zips[0]


@pytest.fixture(scope="module")
def probe(extension_zip, tmp_path_factory) -> dict:
    """Run extension_probe.py in a clean subprocess; its JSON result plus its output."""
    user = tmp_path_factory.mktemp("blender_user")
    work = tmp_path_factory.mktemp("probe")
    env = {
        k: v for k, v in os.environ.items()
        if not k.startswith(("BLENDER_USER_", "BLENDER_SYSTEM_", "PYTHON"))
    }
    env.update(BLENDER_USER_RESOURCES=str(user), PYTHONNOUSERSITE="1")
    python = str(VENV_PYTHON) if VENV_PYTHON.exists() else sys.executable
    result_path = work / "result.json"
    done = subprocess.run(
        [python, str(PROBE), str(extension_zip), str(result_path)],
        cwd=work, env=env, capture_output=True, text=True, timeout=600,
    )
    output = tail(done.stdout + done.stderr)
    assert done.returncode == 0 and result_path.exists(), f"probe crashed:\n{output}"
    result = json.loads(result_path.read_text())
    result["output"] = output
    return result


def require(result: dict, stage: str) -> None:
    """Fail with the probe's traceback and output unless it got through ``stage``."""
    if "error" in result and STAGES.index(result["stage"]) <= STAGES.index(stage):
        pytest.fail(
            f"probe failed at stage {result['stage']!r} (needed {stage!r}):\n"
            f"{result['error']}\n--- probe output ---\n{result['output']}",
            pytrace=False,
        )


def under(path: str | None, root: str) -> bool:
    return path is not None and Path(path).resolve().is_relative_to(Path(root).resolve())


def test_probe_hides_the_checkout_and_venv_copies(probe):
    # Without this the assertions below could be satisfied by the .venv's packages.
    assert probe["blocked_before_install"] == {
        name: True for name in (*BUNDLED, "spectral_materials")
    }


def test_installed_and_enabled_from_the_user_repository(probe):
    require(probe, "enabled")
    user = probe["user_resources"]
    assert probe["install_result"] == ["FINISHED"]
    assert probe["repos"]["user_default"] == str(Path(user) / "extensions" / "user_default")
    assert probe["addon_in_preferences"], f"{ADDON} not enabled:\n{probe['output']}"
    assert probe["addon_check"] == [True, True]
    assert probe["addon_file"] == str(
        Path(user, "extensions", "user_default", "spectral_materials", "__init__.py"))
    assert "spectral_materials/core/__init__.py" in probe["installed_files"]


def test_bundled_wheels_are_what_runs(probe):
    require(probe, "bundled wheels")
    site = probe["site_packages"]
    assert site == str(Path(probe["extensions_dir"], ".local", "lib",
                            f"python{sys.version_info[0]}.{sys.version_info[1]}",
                            "site-packages"))
    assert probe["site_on_sys_path"]
    assert not any(name.startswith("numpy") for name in probe["site_packages_entries"])
    # What the add-on imported while enabling, then each bundled top-level package.
    for name, origin in [*probe["imported_by_addon"].items(), *probe["bundled_origins"].items()]:
        assert under(origin, site), f"{name} imported from {origin}, not from {site}"
    assert probe["refused_imports"] == [], "something looked for a bundled package elsewhere"


def test_installed_operator_factors_a_material(probe):
    require(probe, "bundled wheels")
    if not probe["operator_registered"]:
        pytest.fail(
            "the extension installs and enables, but registers no "
            "bpy.types.SPECTRAL_OT_factor_material: spectral_materials.blender.register() "
            "does not provide the factor operator (yet)",
            pytrace=False,
        )
    require(probe, "done")
    assert probe["operator_module"].startswith(ADDON + "."), probe["operator_module"]
    assert probe["factor_result"] == ["FINISHED"]
    assert probe["result_packs"] == 1
    site = probe["site_packages"]
    assert under(probe["modules_after_factor"]["colour"], site)
    assert under(probe["modules_after_factor"]["scipy"], site)


def test_installed_extension_draws_through_its_glsl_and_writes_exr(probe):
    require(probe, "done")
    package = Path(probe["user_resources"], "extensions", "user_default", "spectral_materials")
    assert Path(probe["glsl_dir"]) == package / "glsl"
    assert probe["draw_objects"] == ["probe"] and probe["draw_covered"] > 0
    assert under(probe["openexr_origin"], probe["site_packages"])
    assert all(Path(p).is_file() for p in probe["draw_paths"].values())
