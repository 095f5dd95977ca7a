"""``library build`` and ``library import``: a folder of BRDF files as a spectral material
library, and that library as a Blender Asset Library .blend (core/library, blender/library)."""

from __future__ import annotations

import sys
from pathlib import Path

from .common import PROG, Progress, UsageError

#: Exit status when some files failed and the others were written.
EXIT_SOME_FAILED = 1


def cmd_build(args, progress: Progress) -> int:
    from ..core.library.build import build_library
    from ..core.library.settings import LibrarySettings

    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    if args.workers is not None and args.scheduler:
        raise UsageError("--workers sets the local pool; a Dask cluster has its own workers")
    settings = LibrarySettings(packs=args.packs, theta_cells=args.theta_cells,
                               basis=None if args.basis == 0 else args.basis,
                               parameterization=args.parameterization)
    result = build_library(args.sources, args.out, settings, scheduler=args.scheduler,
                           workers=args.workers, callback=progress)
    progress.clear()
    print(f"{result.library}: {len(result.written)} factored, {len(result.skipped)} "
          f"current, {len(result.failed)} failed ({result.executor}, "
          f"{result.seconds:.1f} s)", flush=True)
    for failure in result.failed:
        print(f"{PROG} library build: {failure['source']}: {failure['error']}",
              file=sys.stderr, flush=True)
    return EXIT_SOME_FAILED if result.failed else 0


def cmd_import(args, progress: Progress) -> int:
    import bpy

    from .. import blender as addon
    from ..blender.library.asset_library import write_asset_library

    if not hasattr(bpy.types.Material, "spectral"):
        addon.register()      # the materials carry the add-on's properties

    out = write_asset_library(args.library, args.blend, callback=progress)
    progress.clear()
    print(f"wrote {out.blend} ({out.materials} materials in {out.catalogs} catalogs) and "
          f"{out.catalog_file.name}", flush=True)
    return 0


def add_parser(sub) -> None:
    p = sub.add_parser("library", help="build a spectral material library, or import one "
                                       "into Blender's Asset Browser")
    commands = p.add_subparsers(dest="library_command", metavar="ACTION", required=True)
    build = commands.add_parser(
        "build", help="factor every MERL .binary, RGL .bsdf and project .npz under SOURCES",
        description="Factor every BRDF file under the sources into the library folder: per "
                    "material its factor packs, a ΔE94 report row and a thumbnail; the "
                    "index as library.json and index.md. Unchanged files are not factored "
                    "again; a file that fails is named and skipped.")
    build.add_argument("sources", nargs="+", metavar="SOURCE", type=Path,
                       help="files or folders (searched recursively)")
    build.add_argument("--out", required=True, type=Path, metavar="LIB",
                       help="the library folder (new, empty, or a library to update)")
    build.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                       help="run on this Dask cluster (pip install -r requirements/cli.txt)")
    build.add_argument("--workers", type=int, metavar="N",
                       help="local worker processes (default: the CPUs)")
    build.add_argument("--packs", type=int, default=4, help="factor packs (default 4)")
    build.add_argument("--theta-cells", type=int, default=32,
                       help="cells over 90° of θ (default 32)")
    build.add_argument("--basis", type=int, default=8,
                       help="spectral basis size per material; 0: wavelengths (default 8)")
    build.add_argument("--parameterization", default="io", choices=("io", "hd", "ea", "gs"),
                       help="angular parameterisation (isotropic files use its _iso layout)")
    build.add_argument("--quiet", action="store_true", help="no progress bar")
    build.set_defaults(handler=cmd_build)
    imp = commands.add_parser(
        "import", help="write a library as a Blender Asset Library .blend",
        description="Make a .blend holding every material of the library as an asset, "
                    "with its factors stored, catalogs by source and the thumbnails as "
                    "previews; register its folder in Preferences > File Paths > Asset "
                    "Libraries.")
    imp.add_argument("library", type=Path, metavar="LIB")
    imp.add_argument("--blend", type=Path, metavar="OUT.blend",
                     help="default: LIB/spectral_library.blend")
    imp.add_argument("--quiet", action="store_true", help="no progress bar")
    imp.set_defaults(handler=cmd_import)



