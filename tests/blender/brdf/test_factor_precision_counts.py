"""The factor-precision benchmark counts its fetches from glsl/brdf/factor_packs.glsl: the
sites it counts must be there (a shader edit once turned its filtered count into 0)."""

import pytest

pytest.importorskip("bpy")
pytestmark = pytest.mark.bpy


def test_fetch_counts_find_the_shaders_fetch_sites():
    from benchmarks.factor_precision import fetch_counts

    rows = {row["precision"]: row for row in fetch_counts()}
    assert {p: (r["fetches"], r["bytes"]) for p, r in rows.items()} == {
        "exact": (2, 32), "unorm16": (2, 16), "unorm16_filtered": (1, 8),
        "half_filtered": (1, 8)}
