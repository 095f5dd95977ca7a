"""shaders.shares_view_axes against the GPU replay it was chosen from
(docs/gpu/h200_variants_results.json): wherever the H200 drew one light-loop order more
than 3 % faster, the rule picks that order."""

import json
from pathlib import Path

import pytest

pytest.importorskip("bpy")

from spectral_materials.blender.gpu import shaders  # noqa: E402

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "gpu" / "h200_variants_results.json"
#: Within this the two orders tie (the replays' run-to-run spread is ~0.5 %).
TIE = 0.03


def _sweep() -> dict:
    cases = {c["name"]: c for c in json.loads(RESULTS.read_text())["cases"]}
    out = {}
    for name, case in cases.items():
        if name.startswith("variant_light_loop_") and name.endswith("_after"):
            before = cases[name[:-len("after")] + "before"]
            p = case["params"]
            out[p["packs"], p["lights"]] = (case["runs"]["blender"]["draw_ms"]["median"]
                                            / before["runs"]["blender"]["draw_ms"]["median"])
    return out


def test_the_rule_follows_every_clear_measurement():
    sweep = _sweep()
    assert len(sweep) >= 15
    decided = 0
    for (packs, lights), hoisted_over_single in sweep.items():
        if abs(hoisted_over_single - 1.0) > TIE:
            decided += 1
            assert shaders.shares_view_axes("io_iso", packs, lights) == \
                (hoisted_over_single < 1.0), (packs, lights, hoisted_over_single)
    assert decided >= 10


def test_the_rule_outside_the_sweep():
    key = shaders.ShaderKey("io_iso", 3, 12, 8, 4, frozenset({"SUN"}))
    assert key.defines()["SM_SHARE_VIEW"] == "1"
    assert not shaders.shares_view_axes("io_iso", 48, 1)
    assert not shaders.shares_view_axes("io_iso", 48, shaders.MAX_SHARED_VIEW_LIGHTS + 1)
    assert not shaders.shares_view_axes("hd", 48, 4)          # no axis depends on the view
