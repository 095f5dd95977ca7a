"""Build the Spectral Materials Blender extension: stage, bundle wheels, build, validate.

Run it through the wrapper, ``scripts/build_extension [--out DIR] [--platform P ...]``:

1. stages a clean copy in ``build/extension/``: the ``spectral_materials/`` package and
   ``glsl/`` (no ``__pycache__``), ``blender_manifest.toml`` and a thin root
   ``__init__.py`` (a copy of ``scripts/extension_init.py``);
2. puts the wheels the manifest lists under ``build/extension/wheels/``, downloading them
   first (``pip download --no-deps --only-binary=:all:`` per platform, versions from
   ``requirements/extension_wheels.txt``) into the cache ``build/wheels/`` unless there;
3. runs Blender's ``blender_ext.py build --split-platforms`` (one zip per platform) with
   Blender's own tag list, then ``blender_ext.py validate`` on each zip, printing both;
4. prints, and writes to ``DIR/build_summary.txt``, one summary line: zips and sizes.

``--platform`` (repeatable) builds a subset of the manifest's platforms; the staged
manifest then declares only those and lists only their wheels. Exit status 0 on success,
1 on any failure, with a one-line ``build_extension: error: ...`` on stderr.
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "blender_manifest.toml"
REQUIREMENTS = ROOT / "requirements" / "extension_wheels.txt"
INIT_TEMPLATE = ROOT / "scripts" / "extension_init.py"
STAGE = ROOT / "build" / "extension"
WHEEL_CACHE = ROOT / "build" / "wheels"
DEFAULT_OUT = ROOT / "dist"
# Staged next to the root __init__.py, as in the checkout (glsl/ is read by blender/draw.py).
STAGED_DIRS = ("spectral_materials", "glsl")
IGNORED = shutil.ignore_patterns("__pycache__", "*.py[co]", ".*", "*~", "*.orig", "*.rej")
# Files the installed add-on cannot work without (checked in every zip).
REQUIRED_IN_ZIP = (
    "blender_manifest.toml",
    "__init__.py",
    "spectral_materials/__init__.py",
    "spectral_materials/blender/__init__.py",
    "spectral_materials/core/__init__.py",
)
# Blender ships numpy; a bundled copy would shadow it for every add-on.
NEVER_BUNDLE = ("numpy",)
PYTHON_VERSION = "3.11"
# pip --platform tags per Blender platform. pip does not widen a manylinux_2_x tag to older
# glibc versions, so list them all up to 2.28 (Blender 5.0's Linux baseline). scipy 1.13.1
# has arm64 macOS wheels only for macOS 12+; pip widens macOS tags downwards by itself.
PIP_PLATFORMS = {
    "linux-x64": [f"manylinux_2_{minor}_x86_64" for minor in range(28, 16, -1)]
    + ["manylinux2014_x86_64"],
    "windows-x64": ["win_amd64"],
    "macos-arm64": ["macosx_12_0_arm64"],
    "macos-x64": ["macosx_11_0_x86_64"],
}


class BuildError(Exception):
    """A failure with a message for the user; ends the build with exit status 1."""


def rel(path: Path) -> str:
    """``path`` relative to the repository root when it lies inside, else absolute."""
    path = Path(path).resolve()
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


def normalize(name: str) -> str:
    """Distribution name as wheel file names spell it (PEP 427/503)."""
    return re.sub(r"[-_.]+", "_", name).lower()


def find_blender_ext() -> Path:
    """Blender's extension tool, from the bpy module in this Python (never imports bpy)."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        raise BuildError(f"bpy is not installed in {sys.executable}; run scripts/setup_env.sh")
    found = sorted(
        Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py")
    )
    if not found:
        raise BuildError(f"blender_ext.py not found under {Path(spec.origin).parent}")
    return found[-1]


def load_blender_ext(path: Path) -> ModuleType:
    """Import blender_ext.py for its wheel/platform matching (the same --split-platforms uses)."""
    spec = importlib.util.spec_from_file_location("_blender_ext", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def read_pins(path: Path) -> dict[str, str]:
    """``name==version`` lines of a requirements file, as {normalized name: version}."""
    pins: dict[str, str] = {}
    for number, raw in enumerate(path.read_text().splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        match = re.fullmatch(r"([A-Za-z0-9][A-Za-z0-9._-]*)\s*==\s*([A-Za-z0-9.+!_-]+)", line)
        if match is None:
            raise BuildError(f"{rel(path)}:{number}: expected an exact pin name==version: {raw!r}")
        pins[normalize(match[1])] = match[2]
    if not pins:
        raise BuildError(f"{rel(path)} pins nothing")
    return pins


def plan_wheels(
    manifest: dict, pins: dict[str, str], platforms: list[str], ext: ModuleType
) -> dict[str, list[str]]:
    """Wheel file names per platform, checked against the pins: one wheel per pin and platform."""
    wheels = [w.removeprefix("./") for w in manifest.get("wheels", [])]
    if not wheels:
        raise BuildError(
            f"{rel(MANIFEST)} has no top-level wheels = [...] list "
            "(it must come before the first [table] such as [permissions])"
        )
    for wheel in wheels:
        if not wheel.startswith("wheels/") or "/" in wheel.removeprefix("wheels/"):
            raise BuildError(f"manifest wheel {wheel!r} must be a file directly under ./wheels/")
        name, version = wheel.removeprefix("wheels/").split("-")[:2]
        if normalize(name) in NEVER_BUNDLE:
            raise BuildError(f"manifest bundles {wheel}: Blender ships numpy, never bundle it")
        if pins.get(normalize(name)) != version:
            raise BuildError(
                f"manifest wheel {wheel} does not match {rel(REQUIREMENTS)} "
                f"({name}=={pins.get(normalize(name), 'unpinned')})"
            )
    for name in pins:
        if name in NEVER_BUNDLE:
            raise BuildError(f"{rel(REQUIREMENTS)} pins {name}: Blender ships it, never bundle it")
    plan: dict[str, list[str]] = {}
    for platform in platforms:
        chosen = [
            w for w in wheels
            if ext.blender_platform_compatible_with_wheel_platform_from_filepath(platform, w)
        ]
        for name, version in pins.items():
            matching = [w for w in chosen if normalize(Path(w).name.split("-")[0]) == name]
            if len(matching) != 1:
                raise BuildError(
                    f"manifest lists {len(matching)} wheels of {name}=={version} for {platform} "
                    f"(want exactly 1): {matching or 'none'}"
                )
        plan[platform] = chosen
    return plan


def wheel_ok(path: Path) -> bool:
    """A readable wheel: a zip archive with a .dist-info/RECORD (catches truncated files)."""
    try:
        with zipfile.ZipFile(path) as archive:
            return any(n.endswith(".dist-info/RECORD") for n in archive.namelist())
    except (OSError, zipfile.BadZipFile):
        return False


def ensure_wheels(plan: dict[str, list[str]], cache: Path) -> None:
    """Download into ``cache`` the wheels of each platform that are missing there."""
    cache.mkdir(parents=True, exist_ok=True)
    for platform, wheels in plan.items():
        missing = [w for w in wheels if not wheel_ok(cache / Path(w).name)]
        if not missing:
            print(f"wheels for {platform}: all {len(wheels)} in {rel(cache)}/ (no download)")
            continue
        if platform not in PIP_PLATFORMS:
            raise BuildError(f"no pip platform tags known for {platform}; add it to PIP_PLATFORMS")
        for name in missing:
            (cache / Path(name).name).unlink(missing_ok=True)
        print(f"wheels for {platform}: downloading {len(missing)} into {rel(cache)}/")
        command = [
            sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:",
            "--disable-pip-version-check", "--python-version", PYTHON_VERSION,
            "--implementation", "cp", "--dest", str(cache), "--requirement", str(REQUIREMENTS),
        ]
        for tag in PIP_PLATFORMS[platform]:
            command += ["--platform", tag]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            sys.stderr.write(done.stdout + done.stderr)
            raise BuildError(f"pip download for {platform} failed (exit {done.returncode})")
        still = [w for w in missing if not wheel_ok(cache / Path(w).name)]
        if still:
            saved = re.findall(r"(?:Saved|File was already downloaded) (\S+)", done.stdout)
            raise BuildError(
                f"pip chose other files for {platform} than blender_manifest.toml lists; "
                f"missing {[Path(w).name for w in still]}; pip has "
                f"{sorted(Path(s).name for s in saved)}: update the manifest's wheels list"
            )


def staged_manifest(text: str, platforms: list[str], wheels: list[str]) -> str:
    """The manifest text declaring only ``platforms`` and listing only ``wheels``."""

    def toml_list(key: str, items: list[str]) -> str:
        return f"{key} = [\n" + "".join(f'  "./{item}",\n' for item in items) + "]"

    new = re.sub(
        r"^platforms\s*=\s*\[[^\]]*\]",
        lambda _: "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]",
        text, count=1, flags=re.MULTILINE,
    )
    new = re.sub(
        r"^wheels\s*=\s*\[[^\]]*\]",
        lambda _: toml_list("wheels", wheels), new, count=1, flags=re.MULTILINE,
    )
    data = tomllib.loads(new)
    if data.get("platforms") != platforms or [
        w.removeprefix("./") for w in data.get("wheels", [])
    ] != wheels:
        raise BuildError("could not restrict the manifest's platforms/wheels lists for staging")
    return new


def stage(manifest_text: str, wheels: list[str], cache: Path) -> None:
    """A clean build/extension/: package, glsl, root __init__.py, manifest, wheels."""
    if STAGE.exists():
        shutil.rmtree(STAGE)
    STAGE.mkdir(parents=True)
    for name in STAGED_DIRS:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, STAGE / name, ignore=IGNORED)
    shutil.copy2(INIT_TEMPLATE, STAGE / "__init__.py")
    (STAGE / "blender_manifest.toml").write_text(manifest_text)
    (STAGE / "wheels").mkdir()
    for wheel in wheels:
        shutil.copy2(cache / Path(wheel).name, STAGE / wheel)


def run_tool(command: list[str], what: str) -> str:
    """Run a blender_ext.py command, echo its output, fail with ``what`` on non-zero exit."""
    print("$ " + " ".join(rel(Path(c)) if c.startswith("/") else c for c in command[1:]))
    done = subprocess.run(command, capture_output=True, text=True)
    output = (done.stdout + done.stderr).rstrip()
    if output:
        print(output)
    if done.returncode != 0:
        raise BuildError(f"{what} failed (exit {done.returncode}); see the output above")
    return output


def check_zip(path: Path, wheels: list[str]) -> None:
    """The zip holds the files the add-on needs, its platform's wheels, and no caches."""
    with zipfile.ZipFile(path) as archive:
        names = set(archive.namelist())
    missing = [n for n in (*REQUIRED_IN_ZIP, *wheels) if n not in names]
    if missing:
        raise BuildError(f"{path.name} lacks {missing}")
    stray = sorted(n for n in names if "__pycache__" in n or n.endswith((".pyc", ".pyo")))
    stray += sorted(n for n in names if n.startswith("wheels/") and n not in wheels)
    if stray:
        raise BuildError(f"{path.name} holds files it should not: {stray[:5]}")


def build(out: Path, platforms: list[str] | None) -> str:
    """Everything: returns the summary line."""
    blender_ext_path = find_blender_ext()
    ext = load_blender_ext(blender_ext_path)
    valid_tags = blender_ext_path.parents[3] / "modules/_bpy_internal/extensions/tags.py"
    manifest_text = MANIFEST.read_text()
    try:
        manifest = tomllib.loads(manifest_text)
    except tomllib.TOMLDecodeError as error:
        raise BuildError(f"{rel(MANIFEST)}: {error}") from None
    declared = manifest.get("platforms") or []
    if not declared:
        raise BuildError(f"{rel(MANIFEST)} declares no platforms")
    targets = platforms or declared
    unknown = [p for p in targets if p not in declared]
    if unknown:
        raise BuildError(f"platform(s) {unknown} not declared in the manifest ({declared})")
    targets = [p for p in declared if p in targets]  # manifest order, no duplicates

    plan = plan_wheels(manifest, read_pins(REQUIREMENTS), targets, ext)
    ensure_wheels(plan, WHEEL_CACHE)
    wheels = [w for w in (x.removeprefix("./") for x in manifest["wheels"])
              if any(w in plan[p] for p in targets)]
    if targets != declared:
        manifest_text = staged_manifest(manifest_text, targets, wheels)
    stage(manifest_text, wheels, WHEEL_CACHE)
    print(f"staged {rel(STAGE)}/ ({len(wheels)} wheels)")

    out.mkdir(parents=True, exist_ok=True)
    zips = {
        p: out / f"{manifest['id']}-{manifest['version']}-{p.replace('-', '_')}.zip"
        for p in targets
    }
    for path in zips.values():
        path.unlink(missing_ok=True)
    command = [sys.executable, str(blender_ext_path), "build", "--source-dir", str(STAGE),
               "--output-dir", str(out), "--split-platforms"]
    if valid_tags.is_file():
        command += ["--valid-tags", str(valid_tags)]
    run_tool(command, "blender_ext.py build")

    parts = []
    for platform, path in zips.items():
        if not path.is_file():
            raise BuildError(f"blender_ext.py build did not write {rel(path)}")
        command = [sys.executable, str(blender_ext_path), "validate"]
        if valid_tags.is_file():
            command += ["--valid-tags", str(valid_tags)]
        run_tool([*command, str(path)], f"blender_ext.py validate {path.name}")
        check_zip(path, plan[platform])
        size = path.stat().st_size
        print(f"{rel(path)}: {size} bytes ({size / 1e6:.1f} MB)")
        parts.append(f"{rel(path)} ({size / 1e6:.1f} MB)")
    versions = manifest["blender_version_min"] + (
        f" to <{manifest['blender_version_max']}" if "blender_version_max" in manifest else "+"
    )
    return f"{manifest['id']} {manifest['version']} (Blender {versions}): " + ", ".join(parts)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="scripts/build_extension", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="directory for the zip(s) (default: dist/)")
    parser.add_argument("--platform", action="append", metavar="PLATFORM",
                        help="build only this manifest platform, e.g. linux-x64 (repeatable)")
    args = parser.parse_args(argv)
    out = args.out.resolve()
    try:
        summary = build(out, args.platform)
    except BuildError as error:
        print(f"build_extension: error: {error}", file=sys.stderr)
        return 1
    (out / "build_summary.txt").write_text(summary + "\n")
    print(summary)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
