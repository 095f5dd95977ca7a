"""The packaged extension installs into a fresh Blender and runs from its own copy.

``scripts/build_extension.py`` builds the zip for this machine's platform (once per
module; ``SPECTRAL_EXTENSION_ZIP=path`` tests a prebuilt zip instead). ``extension_probe.py``
then runs in a fresh process of the interpreter running these tests (``sys.executable``:
each test leg's venv, so the bpy 4.5, 5.0, 5.2 or 5.3 of that leg) with a temporary
Blender user directory (``BLENDER_USER_RESOURCES``), installs the zip with
``bpy.ops.extensions.package_install_files(repo="user_default", enable_on_install=True)``,
factors one material through the installed add-on, draws it offscreen and writes EXR
images. The probe hides the checkout's ``spectral_materials`` and the venv's colour,
scipy, imageio, PIL, typing_extensions and OpenEXR, so only the installed copy and the
bundled wheels matching that Blender's Python can run.

Bad input: a Blender older than ``blender_version_min`` refuses the zip with Blender's own
message (``blender_ext.py``'s ``repository_filter_skip``, the check behind install), and
``register()`` refuses, with one error naming the package and the version it needs and
having registered nothing, when an older colour-science or SciPy comes first on
``sys.path`` (as another extension's wheel would).
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
BUILD = ROOT / "scripts" / "build_extension.py"
PROBE = Path(__file__).with_name("extension_probe.py")
ADDON = "bl_ext.user_default.spectral_materials"
BUNDLED = ("colour", "scipy", "imageio", "PIL", "typing_extensions", "OpenEXR")
STAGES = ("start", "import bpy", "read_homefile", "install", "enabled", "bundled wheels",
          "operator", "factor", "draw", "done")

pytestmark = [pytest.mark.bpy, pytest.mark.gpu, pytest.mark.skipif(
    importlib.util.find_spec("bpy") is None,
    reason="needs the bpy module (requirements/blender.txt)",
)]


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
    # This interpreter's bpy validates the zip too (with the newest of .venvs/*/, if newer).
    done = subprocess.run(
        [sys.executable, str(BUILD), "--out", str(out), "--platform", target,
         "--stage", str(tmp_path_factory.mktemp("stage"))],
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
    result_path = work / "result.json"
    done = subprocess.run(
        [sys.executable, str(PROBE), str(extension_zip), str(result_path)],
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
    # Only typing_extensions may be Blender's own (bpy 5.2+ imports it through cattrs).
    assert set(probe["blender_own"]) <= {"typing_extensions"}, probe["blender_own"]
    checked = [name for name in BUNDLED if name not in probe["blender_own"]]
    assert probe["blocked_before_install"] == {
        name: True for name in (*checked, "spectral_materials")
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
    require(probe, "factor")
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


def test_probe_ran_this_blender_with_the_wheels_for_its_python(probe):
    # The probe is this leg's Blender: Blender installed only the wheels for its Python.
    require(probe, "bundled wheels")
    import bpy

    assert probe["blender_version"] == list(bpy.app.version)
    assert probe["python_version"] == list(sys.version_info[:2])
    tag = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    tags = probe["wheel_tags"]
    assert {name.split("-")[0].lower() for name in tags} >= {
        "scipy", "colour_science", "pillow", "openexr", "imageio", "typing_extensions"}, tags
    for name, wheel_tags in tags.items():
        assert all(t.startswith((f"{tag}-{tag}-", "py3-none-any")) for t in wheel_tags), (
            name, wheel_tags)
    assert tags[next(n for n in tags if n.startswith("scipy-"))][0].startswith(tag)


# --- Bad input -----------------------------------------------------------------------------

def load_blender_ext():
    """This interpreter's Blender extension tool, imported (never through bpy)."""
    spec = importlib.util.find_spec("bpy")
    assert spec is not None and spec.origin is not None
    found = sorted(Path(spec.origin).parent.glob(
        "*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    assert found, "no blender_ext.py in this bpy"
    loaded = importlib.util.spec_from_file_location("_blender_ext_for_tests", found[-1])
    module = importlib.util.module_from_spec(loaded)
    loaded.loader.exec_module(module)
    return module


def manifest_item(ext) -> dict:
    """The manifest as Blender's install check reads it (with the wheels' Python versions)."""
    import tomllib

    item = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    versions = ext.python_versions_from_wheels(item["wheels"])
    assert not isinstance(versions, str), versions
    item["python_versions"] = sorted(".".join(map(str, v)) for v in versions)
    return item


def install_refusal(ext, item, blender, platform_name, python) -> str | None:
    """Blender's message for refusing ``item`` on that system, or None if it installs."""
    messages, errors = [], []
    skipped = ext.repository_filter_skip(
        item, filter_blender_version=blender, filter_platform=platform_name,
        filter_python_version=python, skip_message_fn=messages.append,
        error_fn=errors.append,
    )
    assert not errors, errors
    assert skipped == bool(messages)
    return messages[0] if messages else None


@pytest.mark.parametrize("blender, platform_name, python", [
    ((4, 5, 0), "linux-x64", (3, 11, 0)),
    ((4, 5, 0), "macos-x64", (3, 11, 0)),
    ((5, 0, 1), "windows-x64", (3, 11, 0)),
    ((5, 1, 0), "windows-arm64", (3, 13, 0)),
    ((5, 2, 0), "macos-arm64", (3, 13, 0)),
    ((5, 3, 0), "linux-x64", (3, 13, 0)),
])
def test_every_supported_blender_accepts_the_manifest(blender, platform_name, python):
    ext = load_blender_ext()
    assert install_refusal(ext, manifest_item(ext), blender, platform_name, python) is None


@pytest.mark.parametrize("blender, platform_name, python, expected", [
    ((4, 4, 3), "linux-x64", (3, 11, 0), "4.5.0"),       # too old: blender_version_min
    ((4, 2, 0), "windows-x64", (3, 11, 0), "4.5.0"),
    ((6, 0, 0), "linux-x64", (3, 13, 0), "6.0.0"),       # the declared maximum
    ((5, 3, 0), "linux-x64", (3, 14, 0), "3.14"),        # a Python no wheel is built for
    ((4, 5, 0), "linux-arm64", (3, 11, 0), "linux-arm64"),
])
def test_blender_outside_the_range_refuses_with_its_own_message(
        blender, platform_name, python, expected):
    ext = load_blender_ext()
    message = install_refusal(ext, manifest_item(ext), blender, platform_name, python)
    assert message is not None and expected in message, message


REGISTER_WITH_OLD = """
import json, sys
sys.path.insert(0, sys.argv[1])         # the old copy, first (as another extension's wheel)
import bpy
import spectral_materials.blender as adapters
try:
    adapters.register()
    error = None
except Exception as exc:
    error = [type(exc).__name__, str(exc)]
print(json.dumps({
    "error": error,
    "operator": hasattr(bpy.types, "SPECTRAL_OT_factor_material"),
    "material_property": hasattr(bpy.types.Material, "spectral"),
    "submodules": sorted(m for m in sys.modules if m.startswith("spectral_materials.blender.")),
    "imported": sorted(m for m in ("colour", "scipy") if m in sys.modules),
}))
"""


@pytest.mark.parametrize("dist, module, old, needed", [
    ("scipy", "scipy", "1.5.4", "1.13.0"),
    ("colour-science", "colour", "0.3.16", "0.4.6"),
])
def test_register_refuses_an_old_dependency_with_one_message(tmp_path, dist, module, old,
                                                            needed):
    # An old copy as an installed wheel leaves it: the package and its .dist-info.
    (tmp_path / module).mkdir()
    (tmp_path / module / "__init__.py").write_text(
        f"raise ImportError('the old {module} must never be imported')\n")
    info = tmp_path / f"{dist.replace('-', '_')}-{old}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: {old}\n")
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env["PYTHONPATH"] = str(ROOT)
    done = subprocess.run(
        [sys.executable, "-c", REGISTER_WITH_OLD, str(tmp_path)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
    )
    assert done.returncode == 0, tail(done.stdout + done.stderr)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["error"] is not None, "register() accepted an old " + dist
    kind, message = result["error"]
    assert kind == "DependencyError"
    assert f"{dist} {old}" in message and f"{dist} >= {needed}" in message, message
    assert message.startswith("Spectral Materials cannot start: ") and "\n" not in message
    assert message.count("cannot start") == 1
    # Nothing registered, nothing half-imported.
    assert not result["operator"] and not result["material_property"]
    assert result["submodules"] == [] and result["imported"] == []


ENABLE_WITH_OLD = """
import json, sys
import bpy
import addon_utils
bpy.ops.wm.read_homefile(use_empty=True)
bpy.ops.extensions.package_install_files(
    filepath=sys.argv[1], repo="user_default", enable_on_install=False)
sys.path.insert(0, sys.argv[2])         # another extension's old scipy comes first
errors = []
addon_utils.enable("ADDON", default_set=True, handle_error=errors.append)
print(json.dumps({
    "errors": [[type(e).__name__, str(e)] for e in errors],
    "enabled": "ADDON" in bpy.context.preferences.addons,
    "operator": hasattr(bpy.types, "SPECTRAL_OT_factor_material"),
    "material_property": hasattr(bpy.types.Material, "spectral"),
}))
""".replace("ADDON", ADDON)


def test_blender_enabling_the_installed_extension_over_an_old_scipy_reports_one_error(
        extension_zip, tmp_path):
    fake = tmp_path / "old"
    (fake / "scipy").mkdir(parents=True)
    (fake / "scipy" / "__init__.py").write_text("raise ImportError('old scipy imported')\n")
    (fake / "scipy-1.5.4.dist-info").mkdir()
    (fake / "scipy-1.5.4.dist-info" / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: scipy\nVersion: 1.5.4\n")
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("BLENDER_USER_", "BLENDER_SYSTEM_", "PYTHON"))}
    env.update(BLENDER_USER_RESOURCES=str(tmp_path / "user"), PYTHONNOUSERSITE="1")
    done = subprocess.run(
        [sys.executable, "-c", ENABLE_WITH_OLD, str(extension_zip), str(fake)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, tail(done.stdout + done.stderr)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert len(result["errors"]) == 1, result
    kind, message = result["errors"][0]
    assert kind == "DependencyError", result
    assert "scipy 1.5.4" in message and "scipy >= 1.13.0" in message, message
    assert not result["enabled"] and not result["operator"] and not result["material_property"]
