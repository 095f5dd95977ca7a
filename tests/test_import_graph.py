"""The import graph: no module imports itself back through others, and a package imports
only from the layers below it (its own layer's packages do not import each other)."""

from __future__ import annotations

from import_graph import cycles, group_graph, module_graph

# Lowest first. A package may import from any earlier layer, never from its own or a later one.
LAYERS = [
    ["_moved", "core.errors", "core.sample_limits"],
    ["core.progress"],
    ["core.colour"],
    ["core.decomposition", "core.lights", "core.raster_plots"],
    ["core.brdf"],
    ["core.formats"],
    ["core.prt", "core.btf", "core.library"],
    ["core", "(root)"],
]
BLENDER_LAYERS = [
    ["blender.compat", "blender.images", "blender.ui"],
    ["blender.gpu"],
    ["blender.lights"],
    ["blender.viewport"],
    ["blender.brdf"],
    ["blender.eevee", "blender.prt", "blender.btf", "blender.library"],
    ["blender.scene_properties"],
    ["blender"],
    ["cli"],
    ["__main__"],
]


def _rank(layers) -> dict[str, int]:
    return {group: i for i, layer in enumerate(layers) for group in layer}


def test_no_module_imports_itself_back():
    found = cycles(module_graph())
    assert not found, "modules that import each other round a circle:\n" + "\n".join(
        ", ".join(c) for c in found)


def test_core_packages_import_only_from_layers_below():
    rank = _rank(LAYERS)
    groups = group_graph(module_graph())
    core = {g: t for g, t in groups.items() if g in rank}
    assert set(core) == {g for g in groups if g.startswith("core") or g in rank}, \
        "a core package is missing from LAYERS"
    wrong = [f"{g} -> {t}" for g, targets in core.items() for t in targets
             if rank.get(t, 10**6) >= rank[g]]
    assert not wrong, wrong


def test_blender_packages_import_only_from_layers_below():
    rank = {**_rank(LAYERS), **{g: i + len(LAYERS) for g, i in _rank(BLENDER_LAYERS).items()}}
    groups = group_graph(module_graph())
    missing = set(groups) - set(rank)
    assert not missing, f"packages missing from the layer lists: {missing}"
    wrong = [f"{g} -> {t}" for g, targets in groups.items() for t in targets
             if rank[t] >= rank[g]]
    assert not wrong, wrong
