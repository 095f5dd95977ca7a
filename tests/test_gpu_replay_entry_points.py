"""The names ../shared/gpu-replay/export_cases.py reads from the benchmark scripts: it
imports scripts/bench_draw.py, bench_btf.py, bench_prt.py and bench_common.py as modules
to record the benchmarks' draws for a machine with a GPU and no Blender (issue 19)."""

import importlib
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.bpy

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
READ = {
    "bench_draw": ["Bench", "DISC_FRACTION", "MODES", "VIEW_ORIGIN", "make_lights",
                   "mesh_batches", "sphere_arrays", "synthetic_model", "view_projection"],
    "bench_btf": ["frame_times"],
    "bench_prt": ["DEFAULT_WINDOW", "FLOOR_SUBDIVISIONS", "ILLUMINANTS", "MAIN_BANDS",
                  "MAIN_BASIS", "MAIN_RAYS", "RAYS", "SIZE", "SUBDIVISIONS", "FrameBench",
                  "build_scene"],
    "bench_common": ["gpu_machine"],
}


@pytest.mark.parametrize("script", list(READ))
def test_the_exporter_finds_what_it_reads(script, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPTS))
    module = importlib.import_module(script)
    try:
        missing = [name for name in READ[script] if not hasattr(module, name)]
        assert not missing, f"scripts/{script}.py lacks {missing}"
    finally:
        sys.modules.pop(script, None)


def test_the_adapted_exporter_finds_the_precision_and_prt_names():
    from benchmarks.draw_variants import material_binder
    from benchmarks.factor_precision import FAST

    assert callable(material_binder) and set(FAST) == {"unorm16", "unorm16_filtered",
                                                        "half_filtered"}
    assert "albedo_texture" in bpy_prt_properties()


def bpy_prt_properties() -> set[str]:
    from spectral_materials.blender.prt.properties import SPECTRAL_PG_prt_object

    return set(SPECTRAL_PG_prt_object.__annotations__)
