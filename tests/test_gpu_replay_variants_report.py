"""docs/bench_gpu_variants.md's script against the committed H200 replay: its ratios are
the replay's own timings beside llvmpipe's, and its cell-edge table is recomputed from the
stored images."""

import json
from pathlib import Path

import numpy as np

from benchmarks.gpu_replay import variants_report

DOCS = Path(__file__).resolve().parents[1] / "docs"
GPU = DOCS / "gpu"
RESULTS = GPU / "h200_variants_results.json"
_ms = variants_report._ms
#: Comparisons added to benchmarks/draw_variants.py after the committed replay: the page
#: leaves them out until a GPU replays them.
NOT_REPLAYED = {"Oren–Nayar term"}


def _cases() -> dict:
    return {c["name"]: c for c in json.loads(RESULTS.read_text())["cases"]}


def test_every_comparison_is_stated_with_the_replays_and_llvmpipes_ratios():
    cases = _cases()
    llvmpipe = json.loads((DOCS / "bench_draw_variants.json").read_text())
    soft = {(r["comparison"], r["packs"], r["lights"]): r["after_over_before"]
            for r in llvmpipe["rows"]}
    lines = variants_report.variant_table(cases, llvmpipe)
    for comparison, packs, lights in variants_report.CASES:
        stem = variants_report.variant_stem(comparison, packs, lights)
        if comparison in NOT_REPLAYED:
            assert f"{stem}_before" not in cases
            assert not any(line.startswith(f"| {comparison} |") for line in lines)
            continue
        before, after = _ms(cases[f"{stem}_before"]), _ms(cases[f"{stem}_after"])
        row = [line for line in lines if line.startswith(f"| {comparison} | {packs} | {lights} |")]
        assert len(row) == 1, (comparison, packs, lights)
        assert f"| {before:.3f} |" in row[0]
        assert row[0].endswith(f"| {after / before:.3f} | {soft[comparison, packs, lights]:.3f} |")


def test_light_loop_table_covers_the_sweep():
    cases = _cases()
    table = variants_report.light_loop_table(cases)
    assert table[0] == "| io_iso packs | 2 lights | 4 lights | 8 lights |"
    ratio = _ms(cases["variant_light_loop_p8_l2_after"]) / \
        _ms(cases["variant_light_loop_p8_l2_before"])
    row = next(line for line in table if line.startswith("| 8 |"))
    assert row.split(" | ")[1] == f"{ratio:.3f}"


def test_patched_copies_are_left_out_of_the_agreement_table():
    unclamped = json.loads((GPU / "h200_variants_unclamped_results.json").read_text())
    table = "\n".join(variants_report.agreement_table(
        {c["name"]: c for c in unclamped["cases"]}))
    assert "| xyz_measured_cells_p4_l4_after |" in table and "__" not in table


def test_image_agreement_counts_differing_pixels():
    reference = np.zeros((4, 4, 4), np.float32)
    reference[:2, :, :] = 1.0  # 8 covered pixels
    gpu = reference.copy()
    gpu[0, 0, 1] = 1.5  # 50 % off
    gpu[0, 1, 2] = 1.0005  # under 1e-3
    gpu[3, 3, :3] = 9.0  # uncovered: not compared
    a = variants_report.image_agreement(gpu, reference)
    assert (a["pixels"], a["over"], a["over_1e-2"]) == (8, 1, 1)


def test_off_edge_agreement_is_the_other_cells_edges_only():
    images = dict(np.load(GPU / "h200_cells_edge.npz"))
    on = variants_report.image_agreement(images["h200_on_edge"], images["llvmpipe_on_edge"])
    off = variants_report.image_agreement(images["h200_off_edge"], images["llvmpipe_off_edge"])
    assert on["over"] > 0.3 * on["pixels"]
    assert off["over"] < 0.01 * off["pixels"]


def test_the_committed_page_is_the_scripts_output(monkeypatch):
    monkeypatch.chdir(DOCS.parent)
    page = (DOCS / "bench_gpu_variants.md").read_text()
    assert page == variants_report.page("docs/gpu/h200_variants_results.json")
