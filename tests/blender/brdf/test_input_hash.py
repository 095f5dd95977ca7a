"""What a material's input hash names (blender/brdf/sources.py): a change in how the
add-on factors a material with a lobe, or in what Automatic chooses, marks such materials
out of date, and leaves the others' hashes as they were."""

from __future__ import annotations

from dataclasses import replace

import pytest

pytest.importorskip("bpy")

pytestmark = pytest.mark.bpy

from spectral_materials.blender.brdf import sources  # noqa: E402
from spectral_materials.core.brdf import job, lobe  # noqa: E402


def _glossy(lobe_setting: str) -> sources.MaterialInputs:
    return sources.MaterialInputs(name="Gloss", source="analytic", model="ashikhmin_shirley",
                                  scalars={"nu": 32.0, "nv": 32.0}, lobe=lobe_setting)


@pytest.mark.parametrize("setting", ["auto", "ashikhmin_shirley", "oren_nayar"])
def test_the_invisible_rest_is_in_a_lobe_materials_hash(monkeypatch, setting):
    before = sources.input_hash(_glossy(setting), None)
    monkeypatch.setattr(sources, "INVISIBLE_REST", lobe.INVISIBLE_REST * 2)
    assert sources.input_hash(_glossy(setting), None) != before


def test_a_material_without_a_lobe_keeps_its_hash(monkeypatch):
    inputs = _glossy("off")
    before = sources.input_hash(inputs, None)
    monkeypatch.setattr(sources, "INVISIBLE_REST", lobe.INVISIBLE_REST * 2)
    assert sources.input_hash(inputs, None) == before
    assert sources.input_hash(replace(inputs, packs=5), None) != before


def test_automatics_rules_are_in_an_automatic_materials_hash(monkeypatch):
    """A change to what Automatic chooses marks the materials under it out of date, and
    leaves a material with a parameterisation set by hand as it was."""
    automatic = replace(_glossy("off"), automatic=True)
    by_hand = _glossy("off")
    before = [sources.input_hash(m, None) for m in (automatic, by_hand)]
    monkeypatch.setattr(sources, "AUTOMATIC_RULES", job.AUTOMATIC_RULES + 1)
    assert sources.input_hash(automatic, None) != before[0]
    assert sources.input_hash(by_hand, None) == before[1]
