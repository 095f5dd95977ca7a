"""Colours of the PRT albedo precisions as a GPU draws them: ΔE94 of each replayed image
(``run_gpu.py --save-images``) against the exact layers' image as the project draws it
on llvmpipe (the ``*_layers`` case's reference), on the reference's strided subsample.

    python benchmarks/gpu_replay/patch_cases.py .replay/data --set albedo_precision
    python benchmarks/gpu_replay/run_gpu.py ... --save-images $OUT/images    # on the GPU
    python -m benchmarks.gpu_replay.albedo_precision IMAGES --data .replay/data \
        --pack docs/gpu/h200_albedo_precision.npz
    python -m benchmarks.gpu_replay.albedo_precision docs/gpu/h200_albedo_precision.npz

White: FL4 (the benchmark's illuminant) at Y = 1, the images' white (the drawer divides
by the environment's white Y). Pixels covered in both images only.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

#: The exact layers' cases, and the cases and variants drawn from the same albedo.
GROUPS = {"prt_spectral_m8_layers": "ColorChecker chart",
          "prt_image_spectral_m8_layers": "RGB image"}


def _stored(data: Path | None, images: Path) -> tuple[dict, dict]:
    """(GPU images by case, exact references by ``*_layers`` case): from a folder of
    ``.npy`` and the export's refs, or from an .npz :func:`pack` wrote."""
    if images.suffix == ".npz":
        z = np.load(images)
        split = {k.split("/", 1)[0] for k in z.files}
        if split != {"gpu", "reference"}:
            raise SystemExit(f"{images}: not an albedo-precision archive")
        return ({k[4:]: z[k] for k in z.files if k.startswith("gpu/")},
                {k[10:]: z[k] for k in z.files if k.startswith("reference/")})
    if data is None:
        raise SystemExit("a folder of images needs the export (DATA) for its references")
    manifest = json.loads((data / "manifest.json").read_text())
    cases = {c["name"]: c for c in manifest["cases"]}
    refs = {b: np.load(data / cases[b]["reference"]["file"])["subsample"] for b in GROUPS}
    prefixes = tuple(b.removesuffix("_layers") for b in GROUPS)
    return {p.stem: np.load(p) for p in images.glob("*.npy")
            if p.stem.startswith(prefixes)}, refs


def precision_rows(gpu: dict, refs: dict) -> list[dict]:
    from spectral_materials.core.colour.pipeline import delta_e94, white_xyz
    from spectral_materials.core.colour.spectra import WAVELENGTHS_REFERENCE

    white = white_xyz("FL4", WAVELENGTHS_REFERENCE)
    rows = []
    for base, albedo in GROUPS.items():
        exact = refs[base]
        prefix = base.removesuffix("_layers")
        for name in sorted(n for n in gpu if n.startswith(prefix)):
            image = gpu[name]
            if image.shape != exact.shape:
                raise SystemExit(f"{name}: subsample {image.shape} is not {exact.shape}")
            both = (exact[..., 3] > 0) & (image[..., 3] > 0)
            de = delta_e94(exact[both, :3].astype(np.float64),
                           image[both, :3].astype(np.float64), white)
            rows.append({"albedo": albedo, "case": name, "pixels": int(both.sum()),
                         "mean": float(de.mean()), "p95": float(np.percentile(de, 95)),
                         "max": float(de.max())})
    return rows


def markdown(rows: list[dict]) -> list[str]:
    lines = ["| albedo | case | pixels | ΔE94 mean | p95 | max |", "|---|---|---|---|---|---|"]
    lines += [f"| {r['albedo']} | `{r['case']}` | {r['pixels']} | {r['mean']:.4f} | "
              f"{r['p95']:.4f} | {r['max']:.4f} |" for r in rows]
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("images", help="a folder of run_gpu.py --save-images, or its .npz")
    parser.add_argument("--data", default=None, help="the export (for a folder's references)")
    parser.add_argument("--pack", default=None, metavar="NPZ",
                        help="also write the images and references to one .npz")
    args = parser.parse_args(argv)
    gpu, refs = _stored(Path(args.data) if args.data else None, Path(args.images))
    if args.pack:
        np.savez_compressed(args.pack, **{f"gpu/{k}": v for k, v in gpu.items()},
                            **{f"reference/{k}": v for k, v in refs.items()})
    print("\n".join(markdown(precision_rows(gpu, refs))))


if __name__ == "__main__":
    main()
