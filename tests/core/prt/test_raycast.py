"""Occlusion ray casting (core.raycast): analytic scenes every backend must get right,
degenerate and empty meshes, agreement with a brute-force Möller–Trumbore reference on
random rays (incoherent, and coherent: shared directions, the ``numpy`` grid's case),
and the registry's choice and fallback when the optional embreex is missing."""

from __future__ import annotations

import functools
import sys

import numpy as np
import pytest

from spectral_materials.core.prt import raycast

# "numpy-grid": the numpy backend with its brute-force path for small direction groups
# switched off, so that single rays go through the projected grid too.
VARIANTS = ["reference", "numpy", "numpy-grid", "embree", "bvhtree"]


@pytest.fixture(params=VARIANTS)
def backend(request, monkeypatch):
    name = request.param
    if name == "numpy-grid":
        monkeypatch.setattr(raycast, "SMALL_GROUP", 1)
        name = "numpy"
    if name not in raycast.available():
        pytest.skip(f"backend {name!r} not available here")
    return name


def reference(vertices, triangles, origins, directions):
    """Möller–Trumbore, one ray and one triangle at a time, in plain Python floats
    (double precision, edges inclusive): independent of the vectorised code under test."""

    def sub(p, q):
        return (p[0] - q[0], p[1] - q[1], p[2] - q[2])

    def dot(p, q):
        return p[0] * q[0] + p[1] * q[1] + p[2] * q[2]

    def cross(p, q):
        return (p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0])

    corners = [tuple(map(tuple, np.asarray(vertices, float)[t])) for t in np.asarray(triangles)]
    out = []
    for o, d in zip(np.asarray(origins, float).tolist(), np.asarray(directions, float).tolist()):
        hit = False
        for a, b, c in corners:
            e1, e2 = sub(b, a), sub(c, a)
            p = cross(d, e2)
            det = dot(e1, p)
            if det == 0.0:
                continue
            s = sub(o, a)
            u = dot(s, p) / det
            q = cross(s, e1)
            v = dot(d, q) / det
            t = dot(e2, q) / det
            if u >= 0 and v >= 0 and u + v <= 1 and t > 0:
                hit = True
                break
        out.append(hit)
    return np.array(out, dtype=bool)


# A unit square in z = 0 split along its diagonal (0,0)-(1,1): two triangles sharing an edge.
SQUARE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
SQUARE_T = np.array([[0, 1, 2], [0, 2, 3]])

# name: (origin, direction, occluded?)
SQUARE_CASES = {
    "straight down onto it": ((0.7, 0.2, 1.0), (0.0, 0.0, -1.0), True),
    "from below (back faces count)": ((0.7, 0.2, -1.0), (0.0, 0.0, 1.0), True),
    "unnormalised direction": ((0.3, 0.6, 2.0), (0.0, 0.0, -7.5), True),
    "oblique": ((-0.5, 0.5, 1.0), (1.0, 0.0, -1.0), True),
    "beside it": ((2.0, 2.0, 1.0), (0.0, 0.0, -1.0), False),
    "pointing away": ((0.7, 0.2, 1.0), (0.0, 0.0, 1.0), False),
    "starting on the far side": ((0.7, 0.2, -1.0), (0.0, 0.0, -1.0), False),
    "passing it by obliquely": ((-0.5, 0.5, 1.0), (-1.0, 0.0, -1.0), False),
    "through the shared edge (no crack)": ((0.5, 0.5, 1.0), (0.0, 0.0, -1.0), True),
    "obliquely through the shared edge": ((0.2, 0.2, 1.0), (0.3, 0.3, -1.0), True),
    "through the shared corner": ((1.0, 1.0, 1.0), (0.0, 0.0, -1.0), True),
    "grazing: in the plane along an edge": ((-1.0, 0.0, 0.0), (1.0, 0.0, 0.0), False),
    "grazing: in the plane across it": ((-1.0, 0.5, 0.0), (1.0, 0.0, 0.0), False),
    "grazing: parallel just above": ((-1.0, 0.5, 1e-9), (1.0, 0.0, 0.0), False),
    "zero direction": ((0.7, 0.2, 1.0), (0.0, 0.0, 0.0), False),
}


def test_square_scenes(backend):
    origins = np.array([c[0] for c in SQUARE_CASES.values()], dtype=float)
    directions = np.array([c[1] for c in SQUARE_CASES.values()], dtype=float)
    expected = np.array([c[2] for c in SQUARE_CASES.values()])
    got = raycast.occluded(SQUARE_V, SQUARE_T, origins, directions, backend=backend)
    assert got.dtype == bool and got.shape == expected.shape
    wrong = [name for name, g, e in zip(SQUARE_CASES, got, expected) if g != e]
    assert not wrong, f"{backend} got these wrong: {wrong}"


def test_single_triangle_hit_and_miss_across_its_edge(backend):
    """Rays down past a lone triangle's hypotenuse x + y = 1: in just inside, out just out."""
    vertices = SQUARE_V[[0, 1, 3]]
    x = np.linspace(0.05, 0.95, 19)
    inside = np.stack([x, 1.0 - x - 1e-4, np.ones_like(x)], axis=1)
    outside = np.stack([x, 1.0 - x + 1e-4, np.ones_like(x)], axis=1)
    origins = np.concatenate([inside, outside])
    directions = np.tile([0.0, 0.0, -1.0], (len(origins), 1))
    got = raycast.occluded(vertices, [[0, 1, 2]], origins, directions, backend=backend)
    np.testing.assert_array_equal(got, np.arange(len(origins)) < len(x))


def test_degenerate_triangles_are_dropped_and_hit_nothing(backend):
    vertices = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [5, 5, 5]], dtype=float)
    degenerate = np.array([[0, 1, 2],     # collinear
                           [0, 0, 3],     # a repeated vertex
                           [4, 4, 4]])    # a point
    clean = raycast.clean_mesh(vertices, degenerate)
    assert clean.dropped == 3 and clean.triangles.shape == (0, 3)
    # Rays straight through the degenerate triangles' lines and points.
    origins = np.array([[0.5, 0.0, 1.0], [1.5, 0.0, -1.0], [0.0, 0.5, 1.0], [5, 5, 6]], float)
    directions = np.array([[0, 0, -1], [0, 0, 1], [0, 0, -1], [0, 0, -1]], dtype=float)
    got = raycast.occluded(vertices, degenerate, origins, directions, backend=backend)
    np.testing.assert_array_equal(got, False)
    # Among a real triangle, only the real one counts.
    mixed = np.concatenate([degenerate, [[0, 1, 3]]])
    got = raycast.occluded(vertices, mixed, origins, directions, backend=backend)
    np.testing.assert_array_equal(got, [True, False, True, False])


def test_empty_mesh_and_no_rays(backend):
    directions = np.array([[0.0, 0.0, -1.0]])
    origins = np.array([[0.0, 0.0, 1.0]])
    for vertices, triangles in ((np.empty((0, 3)), np.empty((0, 3), int)),
                                (SQUARE_V, np.empty((0, 3), int)), ([], [])):
        got = raycast.occluded(vertices, triangles, origins, directions, backend=backend)
        np.testing.assert_array_equal(got, [False])
    got = raycast.occluded(SQUARE_V, SQUARE_T, np.empty((0, 3)), np.empty((0, 3)),
                           backend=backend)
    assert got.shape == (0,) and got.dtype == bool


def _closed_mesh_and_soup(rng):
    """A triangulated torus (closed, self-occluding) plus a soup of random triangles."""
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 24, endpoint=False),
                       np.linspace(0, 2 * np.pi, 12, endpoint=False), indexing="ij")
    torus = np.stack([(1 + 0.4 * np.cos(v)) * np.cos(u), (1 + 0.4 * np.cos(v)) * np.sin(u),
                      0.4 * np.sin(v)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(24), np.arange(12), indexing="ij")
    a, b = i * 12 + j, ((i + 1) % 24) * 12 + j
    c, d = ((i + 1) % 24) * 12 + (j + 1) % 12, i * 12 + (j + 1) % 12
    quads = np.stack([a, b, c, d], axis=-1).reshape(-1, 4)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    soup = rng.uniform(-1.5, 1.5, (40, 3))[:, None, :] + rng.normal(0, 0.3, (40, 3, 3))
    vertices = np.concatenate([torus, soup.reshape(-1, 3)])
    triangles = np.concatenate([tris, len(torus) + np.arange(120).reshape(-1, 3)])
    return vertices, triangles


@functools.cache
def incoherent_scene():
    rng = np.random.default_rng(7)
    vertices, triangles = _closed_mesh_and_soup(rng)
    origins = rng.uniform(-2.0, 2.0, (400, 3))
    directions = rng.normal(size=(400, 3))
    expected = reference(vertices, triangles, origins, directions)
    return vertices, triangles, origins, directions, expected


@functools.cache
def coherent_scene():
    rng = np.random.default_rng(11)
    vertices, triangles = _closed_mesh_and_soup(rng)
    shared = rng.normal(size=(12, 3))
    origins = rng.uniform(-2.0, 2.0, (12 * 150, 3))
    directions = np.repeat(shared, 150, axis=0)
    expected = raycast.Occluder(vertices, triangles, backend="reference").occluded(
        origins, directions)
    some = rng.choice(len(origins), 100, replace=False)       # the slow reference, checked
    np.testing.assert_array_equal(expected[some],
                                  reference(vertices, triangles, origins[some],
                                            directions[some]))
    return vertices, triangles, origins, directions, expected


def test_random_incoherent_rays_match_the_reference(backend):
    vertices, triangles, origins, directions, expected = incoherent_scene()
    assert 0.2 < expected.mean() < 0.8           # a fair mix of hits and misses
    got = raycast.occluded(vertices, triangles, origins, directions, backend=backend)
    np.testing.assert_array_equal(got, expected)


def test_random_coherent_rays_match_the_reference(backend, monkeypatch):
    """Shared directions (the bake's pattern; the numpy backend's projected grid), with
    the grid cut into slabs and its pairs into small batches to exercise those paths."""
    vertices, triangles, origins, directions, expected = coherent_scene()
    assert 0.2 < expected.mean() < 0.8
    monkeypatch.setattr(raycast, "SLAB_ORIGINS", 64)
    monkeypatch.setattr(raycast, "PAIR_BUDGET", 500)
    got = raycast.occluded(vertices, triangles, origins, directions, backend=backend)
    np.testing.assert_array_equal(got, expected)


def test_threads_do_not_change_the_answer(backend):
    rng = np.random.default_rng(3)
    vertices, triangles = _closed_mesh_and_soup(rng)
    origins = rng.uniform(-2.0, 2.0, (40_000, 3))
    directions = np.repeat(rng.normal(size=(8, 3)), 5_000, axis=0)
    one = raycast.Occluder(vertices, triangles, backend=backend, threads=1)
    two = raycast.Occluder(vertices, triangles, backend=backend, threads=2)
    if backend == "reference":
        origins, directions = origins[::50], directions[::50]
    np.testing.assert_array_equal(one.occluded(origins, directions),
                                  two.occluded(origins, directions))


def _auto_expected() -> str:
    return next(n for n in ("embree", "bvhtree", "numpy") if n in raycast.available())


def test_auto_and_the_registry():
    assert raycast.AUTO_ORDER == ("embree", "bvhtree", "numpy")
    assert raycast.resolve("auto") == _auto_expected()
    assert raycast.Occluder(SQUARE_V, SQUARE_T).backend == _auto_expected()
    assert raycast.resolve("numpy") == "numpy"
    with pytest.raises(ValueError, match="unknown ray-casting backend"):
        raycast.resolve("optix")
    groups = raycast.group_by_direction(np.array([[0, 0, 1], [1, 0, 0], [0, 0, 1.0]]))
    assert sorted(map(list, groups)) == [[0, 2], [1]]


def test_auto_falls_back_when_embreex_is_missing(monkeypatch):
    """embreex is optional: without it "auto" takes the next backend (bvhtree where
    mathutils imports, else numpy), and asking for it by name says why not."""
    for name in ("embreex", "embreex.rtcore_scene", "embreex.mesh_construction"):
        monkeypatch.setitem(sys.modules, name, None)          # import fails
    raycast._embree.cache_clear()
    try:
        assert "embree" not in raycast.available()
        assert raycast.embree_version() is None
        assert raycast.resolve("auto") == _auto_expected() != "embree"
        occluder = raycast.Occluder(SQUARE_V, SQUARE_T)
        assert occluder.backend == _auto_expected()
        assert occluder.occluded([[0.5, 0.2, 1.0]], [[0.0, 0.0, -1.0]]).tolist() == [True]
        with pytest.raises(raycast.BackendUnavailable, match="embree"):
            raycast.Occluder(SQUARE_V, SQUARE_T, backend="embree")
    finally:
        monkeypatch.undo()
        raycast._embree.cache_clear()


def test_bad_input():
    ray = ([[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]])
    with pytest.raises(ValueError, match="vertices must be"):
        raycast.occluded(np.zeros((3, 2)), [[0, 1, 2]], *ray)
    with pytest.raises(ValueError, match="indices must be"):
        raycast.occluded(SQUARE_V, [[0, 1, 4]], *ray)
    with pytest.raises(ValueError, match="integer"):
        raycast.occluded(SQUARE_V, [[0.0, 1.0, 2.0]], *ray)
    with pytest.raises(ValueError, match="finite"):
        raycast.occluded(SQUARE_V, SQUARE_T, [[np.nan, 0.0, 1.0]], [[0.0, 0.0, -1.0]])
    with pytest.raises(ValueError, match=r"\(R, 3\)"):
        raycast.occluded(SQUARE_V, SQUARE_T, [[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]] * 2)
