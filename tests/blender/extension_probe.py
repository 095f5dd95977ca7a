"""Install the extension zip into a fresh Blender user directory and use it (a subprocess).

``python extension_probe.py ZIP RESULT_JSON``, run by ``test_extension_install.py`` in a
fresh process of the interpreter running the tests (each leg's venv and its bpy) with
``BLENDER_USER_RESOURCES`` pointing at a temporary directory. Before ``import bpy`` it
installs a ``sys.meta_path`` finder that lets the top-level names the extension bundles
(``colour``, ``scipy``, ``imageio``, ``PIL``, ``typing_extensions``, ``OpenEXR``) import
only from under that directory, and ``spectral_materials`` never (the extension imports
itself as ``bl_ext.user_default.spectral_materials``): the checkout's editable install and
the venv's copies are invisible, so whatever runs is the installed copy and its wheels. It
installs, enables, factors one material with the add-on's operator, draws the scene
offscreen through the installed glsl/ and writes the EXR images. Each stage's outcome goes
to RESULT_JSON, which the test reads; stages stop at the first failure, whose traceback is
recorded.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import json
import os
import sys
import time
import traceback
from pathlib import Path

REPO = "user_default"
PKG_ID = "spectral_materials"
ADDON = f"bl_ext.{REPO}.{PKG_ID}"
# What the extension bundles as wheels (numpy is Blender's own and stays visible).
BUNDLED = ("colour", "scipy", "imageio", "PIL", "typing_extensions", "OpenEXR")
NEVER = ("spectral_materials",)


def blender_own(names: tuple[str, ...]) -> tuple[str, ...]:
    """Those of ``names`` that Blender itself imports, through its own dependencies.

    bpy 5.2+ requires cattrs, which imports typing_extensions while Blender starts (a real
    Blender 5.2 ships both in its own Python): that copy is Blender's, loaded before any
    extension, so the probe neither hides nor checks it.
    """
    import importlib.metadata as metadata

    seen, todo = set(), ["bpy"]
    while todo:
        dist = todo.pop()
        key = dist.lower().replace("_", "-")
        if key in seen:
            continue
        seen.add(key)
        try:
            requires = metadata.requires(dist) or []
        except metadata.PackageNotFoundError:
            continue
        for req in requires:
            if "extra ==" in req:
                continue
            name = req.split(";")[0].strip()
            for sep in "<>=!~[ (":
                name = name.split(sep)[0]
            todo.append(name)
    seen.discard("bpy")
    providers = metadata.packages_distributions()
    return tuple(
        n for n in names
        if any(d.lower().replace("_", "-") in seen for d in providers.get(n, ()))
    )


OWN = blender_own(BUNDLED)
CHECKED = tuple(n for n in BUNDLED if n not in OWN)


class OnlyUnder(importlib.abc.MetaPathFinder):
    """Top-level ``CHECKED`` names import only from sys.path entries under ``root``."""

    def __init__(self, root: Path):
        self.root = str(root.resolve())
        self.refused: list[str] = []

    def find_spec(self, fullname, path=None, target=None):
        if "." in fullname or fullname not in (*CHECKED, *NEVER):
            return None  # submodules follow their (already vetted) parent package
        if fullname in CHECKED:
            allowed = [p for p in sys.path if os.path.realpath(p or ".").startswith(self.root)]
            spec = importlib.machinery.PathFinder.find_spec(fullname, allowed)
            if spec is not None:
                return spec
        self.refused.append(fullname)
        raise ModuleNotFoundError(
            f"{fullname} refused by the probe: not under {self.root}", name=fullname
        )


def under(path: str | None, root: Path) -> bool:
    return path is not None and Path(path).resolve().is_relative_to(root.resolve())


def main(zip_path: str, result_path: str) -> int:
    user = Path(os.environ["BLENDER_USER_RESOURCES"])
    finder = OnlyUnder(user)
    sys.meta_path.insert(0, finder)
    result: dict = {"stage": "start", "zip": zip_path, "user_resources": str(user),
                    "blender_own": list(OWN)}
    times = result["seconds"] = {}

    def save() -> None:
        result["refused_imports"] = finder.refused
        Path(result_path).write_text(json.dumps(result, indent=1, default=str))

    # What the finder hides: the .venv copies a plain import would have found.
    result["hidden"] = {
        name: getattr(importlib.machinery.PathFinder.find_spec(name), "origin", None)
        for name in (*CHECKED, *NEVER)
    }
    # ... and that the finder hides them: nothing is installed yet, so each import fails.
    result["blocked_before_install"] = {}
    for name in (*CHECKED, *NEVER):
        try:
            __import__(name)
        except ModuleNotFoundError:
            result["blocked_before_install"][name] = True
        else:
            result["blocked_before_install"][name] = False
    finder.refused.clear()
    try:
        start = time.perf_counter()
        result["stage"] = "import bpy"
        import bpy

        times["import_bpy"] = time.perf_counter() - start
        result["blender_version"] = list(bpy.app.version)
        result["python_version"] = list(sys.version_info[:2])
        extensions = Path(bpy.utils.user_resource("EXTENSIONS"))
        site = extensions / ".local" / "lib" / f"python{sys.version_info[0]}.{sys.version_info[1]}"
        site = site / "site-packages"
        result.update(extensions_dir=str(extensions), site_packages=str(site))
        result["repos"] = {r.module: r.directory for r in bpy.context.preferences.extensions.repos}
        assert under(str(extensions), user), f"extensions dir {extensions} not under {user}"

        result["stage"] = "read_homefile"
        bpy.ops.wm.read_homefile(use_empty=True)

        result["stage"] = "install"
        start = time.perf_counter()
        result["install_result"] = sorted(bpy.ops.extensions.package_install_files(
            filepath=zip_path, repo=REPO, enable_on_install=True,
        ))
        times["install"] = time.perf_counter() - start
        package_dir = extensions / REPO / PKG_ID
        result["installed_files"] = sorted(
            str(p.relative_to(package_dir)) for p in package_dir.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts
        ) if package_dir.is_dir() else []
        result["site_packages_entries"] = sorted(p.name for p in site.iterdir()) \
            if site.is_dir() else []
        result["site_on_sys_path"] = str(site) in sys.path
        # Tags of the wheels Blender installed (it picks those matching its own Python).
        result["wheel_tags"] = {
            info.name: [line.split(":", 1)[1].strip()
                        for line in (info / "WHEEL").read_text().splitlines()
                        if line.startswith("Tag:")]
            for info in sorted(site.glob("*.dist-info")) if (info / "WHEEL").is_file()
        } if site.is_dir() else {}

        result["stage"] = "enabled"
        import addon_utils

        result["addon_in_preferences"] = ADDON in bpy.context.preferences.addons
        result["addon_check"] = list(addon_utils.check(ADDON))
        module = sys.modules.get(ADDON)
        result["addon_file"] = getattr(module, "__file__", None)
        assert result["addon_in_preferences"] and module is not None, "add-on not enabled"

        result["stage"] = "bundled wheels"
        # Imported by the add-on itself while enabling (before the probe imports any).
        result["imported_by_addon"] = {
            name: getattr(sys.modules[name], "__file__", None)
            for name in CHECKED if name in sys.modules
        }
        origins = {}
        for name in CHECKED:
            imported = __import__(name)
            origins[name] = imported.__file__
        result["bundled_origins"] = origins

        result["stage"] = "operator"
        cls = getattr(bpy.types, "SPECTRAL_OT_factor_material", None)
        result["operator_module"] = getattr(cls, "__module__", None)
        result["operator_registered"] = cls is not None
        assert cls is not None, "bpy.types.SPECTRAL_OT_factor_material is not registered"

        result["stage"] = "factor"
        mesh = bpy.data.meshes.new("probe")
        mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
        obj = bpy.data.objects.new("probe", mesh)
        bpy.context.scene.collection.objects.link(obj)
        mat = bpy.data.materials.new("probe")
        obj.data.materials.append(mat)
        bpy.context.view_layer.objects.active = obj
        obj.select_set(True)
        s = mat.spectral
        s.source = "ANALYTIC"
        s.model = "LAMBERT"
        s.theta_cells = 8
        s.packs = 1
        start = time.perf_counter()
        result["factor_result"] = sorted(bpy.ops.spectral.factor_material())
        times["factor"] = time.perf_counter() - start
        result["result_packs"] = mat.spectral.result.packs
        # Anything the add-on imported lazily during the run came from the wheels too.
        result["modules_after_factor"] = {
            name: getattr(sys.modules.get(name), "__file__", None) for name in CHECKED
        }

        result["stage"] = "draw"
        blender_pkg = cls.__module__[: cls.__module__.rindex(".blender.") + len(".blender")]
        result["glsl_dir"] = str(importlib.import_module(blender_pkg + ".gpu.shaders").GLSL_DIR)
        camera = bpy.data.objects.new("probe camera", bpy.data.cameras.new("probe camera"))
        camera.location = (0.0, 0.0, 4.0)
        bpy.context.scene.collection.objects.link(camera)
        bpy.context.scene.camera = camera
        mat.spectral.enabled = True
        start = time.perf_counter()
        drawn = importlib.import_module(blender_pkg + ".viewport.render_output").write_scene_images(
            bpy.context.scene, Path(result_path).with_name("probe_frame"), width=32, height=24)
        times["draw"] = time.perf_counter() - start
        result["draw_objects"] = drawn["objects"]
        result["draw_paths"] = drawn["paths"]
        result["draw_covered"] = float(drawn["xyz"][..., 3].sum())
        result["openexr_origin"] = getattr(sys.modules.get("OpenEXR"), "__file__", None)
        result["stage"] = "done"
    except BaseException:  # noqa: BLE001 - recorded for the test, which reports it
        result["error"] = traceback.format_exc()
    finally:
        save()
    return 0


if __name__ == "__main__":
    # The result is saved; leave without Blender's exit handler, which sometimes crashes on
    # 5.3 with Vulkan (the installed add-on's gpu_context.exit_process does the same; the
    # checkout's copy is hidden here).
    status = main(*sys.argv[1:3])
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)
