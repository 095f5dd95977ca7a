"""Build the Spectral Materials Blender extension: stage, bundle wheels, build, validate.

Run it through the wrapper,
``scripts/build_extension [--out DIR] [--platform P ...] [--blender-ext PATH]
[--stage DIR]``:

1. stages a clean copy in ``build/extension/``: the ``spectral_materials/`` package and
   ``glsl/`` (no ``__pycache__``), ``blender_manifest.toml`` and a thin root
   ``__init__.py`` (a copy of ``scripts/extension_init.py``);
2. puts the wheels the manifest lists under ``build/extension/wheels/``, downloading them
   first (``pip download --no-deps --only-binary=:all:`` per platform and per Python of
   ``PYTHONS``, versions from ``requirements/extension_wheels.txt``) into the cache
   ``build/wheels/`` unless there;
3. runs the newest Blender's ``blender_ext.py build --split-platforms`` (one zip per
   platform) with that Blender's tag list, then ``blender_ext.py validate`` on each zip
   with the newest Blender's tool and, when it differs, this interpreter's, printing all;
4. prints, and writes to ``DIR/build_summary.txt``, the zips, their sizes and wheels.

Which ``blender_ext.py``: ``--blender-ext PATH`` or ``$SPECTRAL_BLENDER_EXT``, where PATH
is a ``blender_ext.py``, a Python interpreter with bpy, or a venv holding one; otherwise
the newest bpy among this interpreter and the per-leg venvs ``.venvs/*/`` (newest by
Blender version). The tool runs under the interpreter it came with.

``--platform`` (repeatable) builds a subset of the manifest's platforms; the staged
manifest then declares only those and lists only their wheels. Exit status 0 on success,
1 on any failure, with a one-line ``build_extension: error: ...`` on stderr.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path
from types import ModuleType
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "blender_manifest.toml"
REQUIREMENTS = ROOT / "requirements" / "extension_wheels.txt"
INIT_TEMPLATE = ROOT / "scripts" / "extension_init.py"
STAGE = ROOT / "build" / "extension"
WHEEL_CACHE = ROOT / "build" / "wheels"
DEFAULT_OUT = ROOT / "dist"
# Staged next to the root __init__.py, as in the checkout (glsl/ is read by blender/gpu/shaders.py).
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
# Python versions per Blender platform: Blender 4.5 LTS and 5.0 run 3.11, 5.1 to 5.3 run
# 3.13. Windows on Arm builds start at 5.1 (3.13 only); Intel macOS builds end with 4.5
# (3.11 only). Each (platform, Python) needs exactly one wheel of every pin.
PYTHONS = {
    "linux-x64": ("3.11", "3.13"),
    "windows-x64": ("3.11", "3.13"),
    "windows-arm64": ("3.13",),
    "macos-arm64": ("3.11", "3.13"),
    "macos-x64": ("3.11",),
}
# pip --platform tags per Blender platform. pip does not widen a manylinux_2_x tag to older
# glibc versions, so list them all up to 2.28 (Blender's Linux baseline). scipy 1.17.1's
# arm64 macOS wheels are for macOS 12+ (OpenBLAS) and 14+ (Accelerate): asking for 12_0
# picks the former; pip widens macOS tags downwards by itself.
PIP_PLATFORMS = {
    "linux-x64": [f"manylinux_2_{minor}_x86_64" for minor in range(28, 16, -1)]
    + ["manylinux2014_x86_64"],
    "windows-x64": ["win_amd64"],
    "windows-arm64": ["win_arm64"],
    "macos-arm64": ["macosx_12_0_arm64"],
    "macos-x64": ["macosx_11_0_x86_64"],
}
BLENDER_EXT_GLOB = "*/scripts/addons_core/bl_pkg/cli/blender_ext.py"


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


class BlenderExt(NamedTuple):
    """One Blender's extension tool and the Python it runs under."""

    path: Path
    python: Path

    @property
    def version(self) -> tuple[int, ...]:
        """The Blender version of the bpy it belongs to (the ``bpy/<X.Y>/`` folder)."""
        return tuple(int(x) for x in self.path.parents[4].name.split("."))

    def label(self) -> str:
        return "Blender " + ".".join(map(str, self.version))


def _version_key(path: Path) -> tuple[int, ...]:
    try:
        return tuple(int(x) for x in path.parents[4].name.split("."))
    except ValueError:
        return (0,)


def _ext_in_site(python: Path) -> BlenderExt | None:
    """The blender_ext.py of the bpy installed for ``python`` (a venv's bin/python)."""
    venv = python.parent.parent
    found = sorted(
        (p for p in venv.glob(f"lib/python3*/site-packages/bpy/{BLENDER_EXT_GLOB}")),
        key=_version_key,
    )
    return BlenderExt(found[-1], python) if found else None


def _ext_from(value: str) -> BlenderExt:
    """``--blender-ext``: a blender_ext.py, a Python interpreter with bpy, or a venv."""
    path = Path(value).expanduser()
    if path.is_file() and path.name == "blender_ext.py":
        return BlenderExt(path.resolve(), Path(sys.executable))
    python = path / "bin" / "python" if path.is_dir() else path
    if python.is_file() and (found := _ext_in_site(python)) is not None:
        return found
    raise BuildError(
        f"--blender-ext {value}: neither a blender_ext.py nor a Python/venv with bpy installed"
    )


def find_blender_exts(choice: str | None = None) -> list[BlenderExt]:
    """Blender extension tools, newest first (never imports bpy).

    ``choice`` (``--blender-ext``, else ``$SPECTRAL_BLENDER_EXT``) names the newest one;
    otherwise it is the newest of this interpreter's bpy and those of ``.venvs/*/``. This
    interpreter's comes second when it is another Blender version.
    """
    choice = choice or os.environ.get("SPECTRAL_BLENDER_EXT") or None
    own = None
    spec = importlib.util.find_spec("bpy")
    if spec is not None and spec.origin is not None:
        found = sorted(Path(spec.origin).parent.glob(BLENDER_EXT_GLOB), key=_version_key)
        if found:
            own = BlenderExt(found[-1], Path(sys.executable))
    if choice:
        newest = _ext_from(choice)
    else:
        candidates = [own] if own else []
        for python in sorted(ROOT.glob(".venvs/*/bin/python")):
            if (found := _ext_in_site(python)) is not None:
                candidates.append(found)
        if not candidates:
            raise BuildError(
                f"bpy is not installed in {sys.executable} nor in .venvs/*/; run "
                "scripts/setup_env.sh or pass --blender-ext PATH"
            )
        newest = max(candidates, key=lambda e: e.version)
    tools = [newest]
    if own is not None and own.version != newest.version:
        tools.append(own)
    return tools


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
        if platform not in PYTHONS:
            raise BuildError(f"no Python versions known for {platform}; add it to PYTHONS")
        chosen = [
            w for w in wheels
            if ext.blender_platform_compatible_with_wheel_platform_from_filepath(platform, w)
        ]
        for python in PYTHONS[platform]:
            for name, version in pins.items():
                matching = [
                    w for w in chosen
                    if normalize(Path(w).name.split("-")[0]) == name
                    and python_matches(ext, Path(w).name, python)
                ]
                if len(matching) != 1:
                    raise BuildError(
                        f"manifest lists {len(matching)} wheels of {name}=={version} for "
                        f"{platform} with Python {python} (want exactly 1): {matching or 'none'}"
                    )
        unused = [
            w for w in chosen
            if not any(python_matches(ext, Path(w).name, p) for p in PYTHONS[platform])
        ]
        if unused:
            raise BuildError(
                f"manifest lists wheels for {platform} that no Blender on it can load "
                f"(Pythons {', '.join(PYTHONS[platform])}): {unused}"
            )
        plan[platform] = chosen
    return plan


def python_matches(ext: ModuleType, wheel: str, python: str) -> bool:
    """Whether a wheel loads in Python ``python`` ("3.11"), by Blender's own tag reading."""
    versions = ext.python_versions_from_wheel(wheel)
    if isinstance(versions, str):
        raise BuildError(f"{wheel}: {versions}")
    major, minor = (int(x) for x in python.split("."))
    return not versions or (major,) in versions or (major, minor) in versions


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
        saved: list[str] = []
        for python in PYTHONS[platform]:
            print(f"wheels for {platform}, Python {python}: downloading into {rel(cache)}/")
            command = [
                sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:",
                "--disable-pip-version-check", "--python-version", python,
                "--implementation", "cp", "--dest", str(cache),
                "--requirement", str(REQUIREMENTS),
            ]
            for tag in PIP_PLATFORMS[platform]:
                command += ["--platform", tag]
            done = subprocess.run(command, capture_output=True, text=True)
            if done.returncode != 0:
                sys.stderr.write(done.stdout + done.stderr)
                raise BuildError(
                    f"pip download for {platform}, Python {python} failed "
                    f"(exit {done.returncode})"
                )
            saved += re.findall(r"(?:Saved|File was already downloaded) (\S+)", done.stdout)
        still = [w for w in missing if not wheel_ok(cache / Path(w).name)]
        if still:
            raise BuildError(
                f"pip chose other files for {platform} than blender_manifest.toml lists; "
                f"missing {[Path(w).name for w in still]}; pip has "
                f"{sorted({Path(s).name for s in saved})}: update the manifest's wheels list"
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


def stage(manifest_text: str, wheels: list[str], cache: Path, where: Path) -> None:
    """A clean ``where`` (build/extension/): package, glsl, root __init__.py, manifest, wheels."""
    if where.exists():
        if any(where.iterdir()) and not (where / "blender_manifest.toml").is_file():
            raise BuildError(f"--stage {where} is neither empty nor an earlier staging "
                             "directory; refusing to empty it")
        shutil.rmtree(where)
    where.mkdir(parents=True)
    for name in STAGED_DIRS:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, where / name, ignore=IGNORED)
    shutil.copy2(INIT_TEMPLATE, where / "__init__.py")
    (where / "blender_manifest.toml").write_text(manifest_text)
    (where / "wheels").mkdir()
    for wheel in wheels:
        shutil.copy2(cache / Path(wheel).name, where / wheel)


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


def tool_command(tool: BlenderExt, *args: str) -> list[str]:
    """``python blender_ext.py ARGS [--valid-tags TAGS]`` with that Blender's own tag list."""
    command = [str(tool.python), str(tool.path), *args]
    valid_tags = tool.path.parents[3] / "modules/_bpy_internal/extensions/tags.py"
    if valid_tags.is_file():
        command += ["--valid-tags", str(valid_tags)]
    return command


def build(out: Path, platforms: list[str] | None, blender_ext: str | None = None,
          staging: Path = STAGE) -> str:
    """Everything: returns the summary (first line: zips and sizes, then wheels per zip)."""
    tools = find_blender_exts(blender_ext)
    newest = tools[0]
    print(f"blender_ext.py of {newest.label()}: {rel(newest.path)} (run by {newest.python})")
    ext = load_blender_ext(newest.path)
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
    stage(manifest_text, wheels, WHEEL_CACHE, staging)
    print(f"staged {rel(staging)}/ ({len(wheels)} wheels)")

    out.mkdir(parents=True, exist_ok=True)
    zips = {
        p: out / f"{manifest['id']}-{manifest['version']}-{p.replace('-', '_')}.zip"
        for p in targets
    }
    for path in zips.values():
        path.unlink(missing_ok=True)
    command = tool_command(newest, "build", "--source-dir", str(staging),
                           "--output-dir", str(out), "--split-platforms")
    run_tool(command, f"blender_ext.py build ({newest.label()})")

    parts, details = [], []
    for platform, path in zips.items():
        if not path.is_file():
            raise BuildError(f"blender_ext.py build did not write {rel(path)}")
        for tool in tools:
            run_tool([*tool_command(tool, "validate"), str(path)],
                     f"blender_ext.py validate {path.name} ({tool.label()})")
        check_zip(path, plan[platform])
        size = path.stat().st_size
        print(f"{rel(path)}: {size} bytes ({size / 1e6:.1f} MB)")
        parts.append(f"{rel(path)} ({size / 1e6:.1f} MB)")
        pythons = ", ".join(PYTHONS[platform])
        details.append(f"{path.name}: {size} bytes, {len(plan[platform])} wheels "
                       f"(Python {pythons}):")
        details += [f"  {Path(w).name}" for w in sorted(plan[platform])]
    versions = manifest["blender_version_min"] + (
        f" to <{manifest['blender_version_max']}" if "blender_version_max" in manifest else "+"
    )
    validated = " and ".join(t.label() for t in tools)
    return "\n".join([
        f"{manifest['id']} {manifest['version']} (Blender {versions}): " + ", ".join(parts),
        f"built and validated with the blender_ext.py of {validated}",
        *details,
    ])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="scripts/build_extension", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="directory for the zip(s) (default: dist/)")
    parser.add_argument("--platform", action="append", metavar="PLATFORM",
                        help="build only this manifest platform, e.g. linux-x64 (repeatable)")
    parser.add_argument("--blender-ext", metavar="PATH",
                        help="the newest Blender's blender_ext.py, or a Python/venv with that "
                        "bpy (default: $SPECTRAL_BLENDER_EXT, else the newest bpy of this "
                        "interpreter and .venvs/*/)")
    parser.add_argument("--stage", type=Path, default=STAGE,
                        help="staging directory, emptied first (default: build/extension/; "
                        "give each concurrent build its own)")
    args = parser.parse_args(argv)
    out = args.out.resolve()
    try:
        summary = build(out, args.platform, args.blender_ext, args.stage.resolve())
    except BuildError as error:
        print(f"build_extension: error: {error}", file=sys.stderr)
        return 1
    (out / "build_summary.txt").write_text(summary + "\n")
    print(summary)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
