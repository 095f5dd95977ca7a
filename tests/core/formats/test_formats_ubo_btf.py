"""UBO2003 (zip of JPEGs) and UBO2014 (.btf SVD) readers: round trips, validation, fuzzing."""

from __future__ import annotations

import io
import struct
import tracemalloc
import zipfile
from collections import Counter

import numpy as np
import pytest
from bombs_archives import BOMBS

from spectral_materials.core.errors import InvalidBRDFData
from spectral_materials.core.formats.ubo_btf import (
    BTFFileNotFound,
    InvalidBTFData,
    read_ubo2003,
    read_ubo2014,
    write_ubo2003,
    write_ubo2014,
)

VIEWS = np.array([[0, 0], [30, 90], [60, 180]])
LIGHTS = np.array([[0, 0], [15, 0], [45, 90], [75, 300]])


def smooth_images(rng, views=3, lights=4, h=8, w=8):
    """Smooth colour gradients (JPEG-friendly) with a distinct level per (view, light)."""
    y, x = np.mgrid[0:h, 0:w] / max(h, w)
    out = np.empty((views, lights, h, w, 3))
    for v in range(views):
        for l in range(lights):
            base = rng.uniform(0.2, 0.8, 3)
            slope = rng.uniform(-0.15, 0.15, (2, 3))
            out[v, l] = base + x[..., None] * slope[0] + y[..., None] * slope[1]
    return np.clip(out, 0, 1)


@pytest.fixture()
def archive(tmp_path):
    images = smooth_images(np.random.default_rng(1))
    path = write_ubo2003(tmp_path / "btf.zip", images, LIGHTS, VIEWS)
    return path, images


def zip_with(tmp_path, members: dict[str, bytes], name="custom.zip",
             compression=zipfile.ZIP_STORED):
    path = tmp_path / name
    with zipfile.ZipFile(path, "w", compression=compression) as zf:
        for member, data in members.items():
            zf.writestr(member, data)
    return path


def jpeg_bytes(value=(128, 64, 32), size=(8, 8)):
    from PIL import Image

    buffer = io.BytesIO()
    Image.new("RGB", size, value).save(buffer, format="JPEG", quality=100, subsampling=0)
    return buffer.getvalue()


# --------------------------------------------------------------------------- UBO2003


def test_round_trip(archive):
    path, images = archive
    btf = read_ubo2003(path)
    assert btf.images.shape == (3, 4, 8, 8, 3) and btf.images.dtype == np.float32
    assert btf.encoding == "srgb"
    np.testing.assert_array_equal(btf.view_angles, VIEWS)
    np.testing.assert_array_equal(btf.light_angles, LIGHTS)
    assert btf.present.all() and btf.defects["missing"] == 0
    # JPEG is lossy even at quality 100 with 4:4:4 chroma: a few codes at most.
    assert np.abs(btf.images - images).max() < 4 / 255
    np.testing.assert_array_equal(btf.lookup(2, 1), btf.images[2, 1])
    assert btf.index(15, 0, 60, 180) == (2, 1)
    assert btf.describe()["views"] == 3


def test_directions(archive):
    btf = read_ubo2003(archive[0])
    np.testing.assert_allclose(np.linalg.norm(btf.view_directions, axis=1), 1.0)
    np.testing.assert_allclose(btf.view_directions[0], [0, 0, 1], atol=1e-12)
    s = np.sin(np.radians(30))
    np.testing.assert_allclose(btf.view_directions[1], [0, s, np.cos(np.radians(30))],
                               atol=1e-12)
    np.testing.assert_allclose(btf.light_directions[3, 2], np.cos(np.radians(75)))


def test_linear_undoes_srgb(archive):
    import colour

    encoded = read_ubo2003(archive[0]).images
    linear = read_ubo2003(archive[0], linear=True)
    assert linear.encoding == "linear"
    np.testing.assert_allclose(linear.images, colour.models.eotf_sRGB(encoded.astype(float)),
                               atol=1e-6)


def test_lazy(archive):
    eager = read_ubo2003(archive[0])
    lazy = read_ubo2003(archive[0], lazy=True)
    assert lazy._images is None
    np.testing.assert_array_equal(lazy.lookup(1, 3), eager.images[1, 3])
    np.testing.assert_array_equal(lazy.images, eager.images)
    with pytest.raises(IndexError):
        lazy.lookup(3, 0)


def test_folder_and_uint8(tmp_path):
    codes = (smooth_images(np.random.default_rng(2), 1, 2) * 255).astype(np.uint8)
    path = write_ubo2003(tmp_path / "f.zip", codes, LIGHTS[:2], VIEWS[:1], folder="UBO_X")
    with zipfile.ZipFile(path) as zf:
        assert sorted(zf.namelist())[0] == "UBO_X/tl000 pl000 tv000 pv000.jpg"
    btf = read_ubo2003(path)
    assert np.abs(btf.images * 255 - codes).max() <= 4


def test_missing_pairs_are_masked(tmp_path):
    images = smooth_images(np.random.default_rng(3))
    present = np.ones((3, 4), dtype=bool)
    present[0, 1] = present[2, 3] = False
    btf = read_ubo2003(write_ubo2003(tmp_path / "m.zip", images, LIGHTS, VIEWS,
                                     present=present))
    assert btf.defects["missing"] == 2
    assert (15, 0, 0, 0) in btf.defects["missing_pairs"]
    np.testing.assert_array_equal(btf.present, present)
    assert np.isnan(btf.images[0, 1]).all() and np.isfinite(btf.images[present]).all()
    with pytest.raises(KeyError, match="missing"):
        btf.lookup(0, 1)


def test_wrong_names(tmp_path, archive):
    good = jpeg_bytes()
    for bad in ("foo.jpg", "tl000_pl000_tv000_pv000.jpg", "tl00 pl000 tv000 pv000.jpg",
                "tl000 pl000 tv000 pv000.png"):
        path = zip_with(tmp_path, {"tl000 pl000 tv000 pv000.jpg": good, bad: good})
        with pytest.raises(InvalidBTFData, match="name pattern") as info:
            read_ubo2003(path)
        assert str(path) in str(info.value) and repr(bad) in str(info.value)
    path = zip_with(tmp_path, {"tl000 pl000 tv000 pv000.jpg": good, "readme.txt": b"hi",
                               "sub/": b""})
    btf = read_ubo2003(path, strict=False)
    assert btf.defects["skipped_members"] == ["readme.txt"]


def test_duplicate_angles(tmp_path):
    good = jpeg_bytes()
    path = zip_with(tmp_path, {"a/tl000 pl000 tv000 pv000.jpg": good,
                               "b/tl000 pl000 tv000 pv000.jpg": good})
    with pytest.raises(InvalidBTFData, match=r"duplicated angle.*\(0, 0, 0, 0\)"):
        read_ubo2003(path)


def test_angles_out_of_range(tmp_path):
    good = jpeg_bytes()
    for bad in ("tl095 pl000 tv000 pv000.jpg", "tl000 pl000 tv000 pv360.jpg"):
        path = zip_with(tmp_path, {bad: good})
        with pytest.raises(InvalidBTFData, match="out of range"):
            read_ubo2003(path)


def test_truncated_zip(archive, tmp_path):
    data = archive[0].read_bytes()
    for cut in (len(data) // 2, len(data) - 10, 30):
        path = tmp_path / "cut.zip"
        path.write_bytes(data[:cut])
        with pytest.raises(InvalidBTFData) as info:
            read_ubo2003(path)
        assert str(path) in str(info.value)


def test_corrupt_jpeg_member(tmp_path):
    good = jpeg_bytes()
    path = zip_with(tmp_path, {"tl000 pl000 tv000 pv000.jpg": good,
                               "tl015 pl000 tv000 pv000.jpg": b"not a jpeg at all"})
    with pytest.raises(InvalidBTFData, match="tl015 pl000 tv000 pv000.jpg"):
        read_ubo2003(path)
    path = zip_with(tmp_path, {"tl000 pl000 tv000 pv000.jpg": good,
                               "tl015 pl000 tv000 pv000.jpg": good[: len(good) // 2]})
    with pytest.raises(InvalidBTFData, match="damaged JPEG|not a readable JPEG"):
        read_ubo2003(path)


def test_image_size_mismatch(tmp_path):
    path = zip_with(tmp_path, {"tl000 pl000 tv000 pv000.jpg": jpeg_bytes(),
                               "tl015 pl000 tv000 pv000.jpg": jpeg_bytes(size=(16, 8))})
    with pytest.raises(InvalidBTFData, match="16×8"):
        read_ubo2003(path)


def test_member_declaring_huge_size(tmp_path):
    # A well-compressing member: 4 MB of zeros deflates to a few kB.
    path = zip_with(tmp_path, {"tl000 pl000 tv000 pv000.jpg": bytes(4 << 20)},
                    compression=zipfile.ZIP_DEFLATED)
    assert path.stat().st_size < 100_000
    with pytest.raises(InvalidBTFData, match="declares 4,194,304 uncompressed"):
        read_ubo2003(path, max_member_bytes=1 << 20)
    # A forged central directory: the member claims ~4 GiB, refused under default limits.
    path = zip_with(tmp_path, {"tl000 pl000 tv000 pv000.jpg": jpeg_bytes()}, name="forged.zip")
    data = bytearray(path.read_bytes())
    central = data.index(b"PK\x01\x02")
    data[central + 24 : central + 28] = struct.pack("<I", 0xFFFFFFF0)
    path.write_bytes(bytes(data))
    with pytest.raises(InvalidBTFData, match="over the 67,108,864-byte limit per member"):
        read_ubo2003(path)


def test_total_size_limit(archive):
    with pytest.raises(InvalidBTFData, match="in all, over the 2,000-byte limit"):
        read_ubo2003(archive[0], max_bytes=2000)


def test_decoded_size_limit(tmp_path):
    images = np.full((1, 2, 32, 32, 3), 0.5)
    path = write_ubo2003(tmp_path / "d.zip", images, LIGHTS[:2], VIEWS[:1])
    with pytest.raises(InvalidBTFData, match="decoding all images needs 24,576 bytes"):
        read_ubo2003(path, max_bytes=10_000)
    lazy = read_ubo2003(path, max_bytes=10_000, lazy=True)
    assert lazy.lookup(0, 1).shape == (32, 32, 3)
    with pytest.raises(InvalidBTFData, match="decoding all images"):
        _ = lazy.images


def test_jpeg_header_declaring_huge_image(tmp_path):
    data = bytearray(jpeg_bytes(size=(1, 1)))
    sof = data.index(b"\xff\xc0")
    data[sof + 5 : sof + 9] = struct.pack(">HH", 5000, 5000)
    path = zip_with(tmp_path, {"tl000 pl000 tv000 pv000.jpg": bytes(data)})
    with pytest.raises(InvalidBTFData, match="5000×5000 pixels, over the 67,108,864-byte"):
        read_ubo2003(path)


def _peak_python_bytes(function) -> int:
    """Peak bytes allocated through Python (numpy included) while ``function`` runs."""
    tracemalloc.start()
    try:
        function()
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak


def test_every_jpeg_header_checked_before_allocation(tmp_path):
    claim = BOMBS["ubo2003_size_claim"].make(tmp_path)

    def read_claim():
        with pytest.raises(InvalidBTFData, match=r"ubo2003_size_claim.zip: member 'tl000 pl000 "
                                                 r"tv000 pv000.jpg' claims 4096×4096 pixels in "
                                                 r"\d+ bytes; a JPEG encodes at most 512"):
            read_ubo2003(claim)

    assert _peak_python_bytes(read_claim) < 4 << 20
    # A size mismatch in the last member is found before the (1, 2, 512, 512, 3) array.
    path = zip_with(tmp_path, {"tl000 pl000 tv000 pv000.jpg": jpeg_bytes(size=(512, 512)),
                               "tl015 pl000 tv000 pv000.jpg": jpeg_bytes()})

    def read_mismatch():
        with pytest.raises(InvalidBTFData, match="is 8×8; the first image is 512×512"):
            read_ubo2003(path)

    assert _peak_python_bytes(read_mismatch) < 2 << 20


def test_sparse_sets_need_lazy(tmp_path):
    path = BOMBS["ubo2003_diagonal"].make(tmp_path)
    with pytest.raises(InvalidBTFData, match=r"ubo2003_diagonal.zip: only 300 of the 300 × 300 "
                                             r"\(view, light\) pairs have an image: all images "
                                             r"as one array would take 622,080,000 bytes.*"
                                             r"lazy=True"):
        read_ubo2003(path)
    lazy = read_ubo2003(path, lazy=True)
    assert lazy.present.sum() == 300 and lazy.defects["missing"] == 300 * 299
    assert len(lazy.defects["missing_pairs"]) == 10
    image = lazy.lookup(7, 7)  # the bomb's flat colour (128, 64, 32)
    assert image.shape == (24, 24, 3)
    np.testing.assert_allclose(image, np.broadcast_to([128 / 255, 64 / 255, 32 / 255],
                                                      image.shape), atol=3 / 255)
    with pytest.raises(KeyError):
        lazy.lookup(7, 8)
    with pytest.raises(InvalidBTFData, match="lazy=True"):
        _ = lazy.images
    # Missing pairs are fine while their NaN images stay within the present ones + slack.
    images = smooth_images(np.random.default_rng(12))
    present = np.eye(3, 4, dtype=bool)
    present[0, 3] = True
    btf = read_ubo2003(write_ubo2003(tmp_path / "few.zip", images, LIGHTS, VIEWS,
                                     present=present))
    assert np.isnan(btf.images[~present]).all() and np.isfinite(btf.images[present]).all()


def test_too_many_pairs(tmp_path):
    angles = [(t, p) for t in range(91) for p in range(0, 360, 4)][:4097]
    path = tmp_path / "pairs.zip"
    with zipfile.ZipFile(path, "w") as zf:
        for t, p in angles:
            zf.writestr(f"tl{t:03d} pl{p:03d} tv{t:03d} pv{p:03d}.jpg", b"")
    with pytest.raises(InvalidBTFData, match=r"pairs.zip: 4,097 views × 4,097 lights from "
                                             r"4,097 images: over the 16,777,216-pair limit"):
        read_ubo2003(path, lazy=True)


def test_padded_members_refused_before_inflating(tmp_path):
    path = BOMBS["ubo2003_zip_bomb"].make(tmp_path)
    with pytest.raises(InvalidBTFData, match=r"ubo2003_zip_bomb.zip: member 'tl000 pl000 tv000 "
                                             r"pv000.jpg' declares 67,108,864 bytes from [\d,]+ "
                                             r"compressed \(1,005:1; at most 64:1"):
        read_ubo2003(path)
    # Deflated JPEG members as a zip tool writes them are read as stored ones.
    images = smooth_images(np.random.default_rng(13), 2, 2)
    stored = read_ubo2003(write_ubo2003(tmp_path / "s.zip", images, LIGHTS[:2], VIEWS[:2]))
    packed = read_ubo2003(write_ubo2003(tmp_path / "d.zip", images, LIGHTS[:2], VIEWS[:2],
                                        compression=zipfile.ZIP_DEFLATED))
    np.testing.assert_array_equal(packed.images, stored.images)


def test_missing_path_not_zip_empty_dir(tmp_path):
    missing = tmp_path / "nope.zip"
    with pytest.raises(BTFFileNotFound, match="no such file") as info:
        read_ubo2003(missing)
    assert isinstance(info.value, ValueError) and isinstance(info.value, FileNotFoundError)
    assert isinstance(info.value, InvalidBRDFData) and str(missing) in str(info.value)
    text = tmp_path / "text.zip"
    text.write_text("hello, not a zip")
    with pytest.raises(InvalidBTFData, match="not a valid zip") as info:
        read_ubo2003(text)
    assert str(text) in str(info.value)
    empty = tmp_path / "empty.zip"
    empty.write_bytes(b"")
    with pytest.raises(InvalidBTFData, match="empty file"):
        read_ubo2003(empty)
    with pytest.raises(InvalidBTFData, match="not a regular file"):
        read_ubo2003(tmp_path)
    with pytest.raises(InvalidBTFData, match="no 'tl%03d"):
        read_ubo2003(zip_with(tmp_path, {"sub/": b""}))


def test_writer_validates(tmp_path):
    images = smooth_images(np.random.default_rng(4), 1, 2)
    with pytest.raises(ValueError, match="integer degrees"):
        write_ubo2003(tmp_path / "x.zip", images, [[0, 0], [15.5, 0]], [[0, 0]])
    with pytest.raises(ValueError, match="repeated"):
        write_ubo2003(tmp_path / "x.zip", images, [[0, 0], [0, 0]], [[0, 0]])
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        write_ubo2003(tmp_path / "x.zip", images * 2, LIGHTS[:2], [[0, 0]])
    assert not (tmp_path / "x.zip").exists()


def mutate(data: bytes, rng) -> bytes:
    buf = bytearray(data)
    kind = rng.integers(3)
    if kind in (0, 2):
        for _ in range(int(rng.integers(1, 9))):
            buf[int(rng.integers(len(buf)))] = int(rng.integers(256))
    if kind in (1, 2):
        del buf[int(rng.integers(1, len(buf))):]
    return bytes(buf)


def test_fuzz_ubo2003(tmp_path):
    images = smooth_images(np.random.default_rng(5), 2, 2)
    data = write_ubo2003(tmp_path / "ok.zip", images, LIGHTS[:2], VIEWS[:2]).read_bytes()
    rng = np.random.default_rng(2024)
    outcomes = Counter()
    path = tmp_path / "fuzz.zip"
    for _ in range(200):
        path.write_bytes(mutate(data, rng))
        try:
            btf = read_ubo2003(path, max_bytes=1 << 24)
            assert btf.images.shape[:2] == btf.present.shape
            outcomes["ok"] += 1
        except InvalidBTFData as exc:
            assert str(path) in str(exc)
            outcomes["InvalidBTFData"] += 1
    assert sum(outcomes.values()) == 200 and outcomes["InvalidBTFData"] > 100


# --------------------------------------------------------------------------- UBO2014

V14 = np.radians([[0.0, 0.0], [30.0, 90.0]])
L14 = np.radians([[0.0, 0.0], [45.0, 0.0], [60.0, 270.0]])
H14, W14 = 4, 5


def truth(rng, channels=3):
    """A (V, L, H, W, C) BTF of rank ≤ 3 per channel, positive."""
    a = rng.uniform(0.2, 1.0, (2, 3, channels, 3))
    b = rng.uniform(0.2, 1.0, (H14, W14, 3))
    return np.einsum("vlck,hwk->vlhwc", a, b) / 3


def stored_columns(t):
    """(..., H, W, C) → texels bottom row first, flattened: (..., H·W, C)."""
    return t[..., ::-1, :, :].reshape(*t.shape[:-3], H14 * W14, t.shape[-1])


def fmf_factors(t):
    cols = stored_columns(t)  # (V, L, T, C)
    m = np.moveaxis(cols, 2, 3).reshape(-1, H14 * W14)  # rows (v, l, c)
    u, s, vt = np.linalg.svd(m, full_matrices=False)
    k = int((s > 1e-12 * s[0]).sum())
    return u[:, :k], (s[:k, None] * vt[:k]).T, s[:k]


@pytest.mark.parametrize(("data_size", "tol"), [(8, 1e-6), (4, 1e-5), (2, 5e-3)])
def test_fmf0_round_trip(tmp_path, data_size, tol):
    t = truth(np.random.default_rng(6))
    u, sxv, s = fmf_factors(t)
    path = write_ubo2014(tmp_path / "a.btf", view_angles=V14, light_angles=L14, width=W14,
                         height=H14, u=u, sxv=sxv, singular_values=s, data_size=data_size,
                         xml="<btf/>", measurement_setup="synthetic")
    btf = read_ubo2014(path)
    assert btf.signature == "FMF0" and btf.data_size == data_size
    assert btf.header["xml"] == "<btf/>" and btf.header["measurement_setup"] == "synthetic"
    assert btf.channels == ["R", "G", "B"] and btf.u[0].shape == (6, u.shape[1])
    np.testing.assert_allclose(btf.singular_values[0], s, rtol=tol)
    for v in range(2):
        for l in range(3):
            np.testing.assert_allclose(btf.lookup(v, l), t[v, l], atol=tol, rtol=tol)
    np.testing.assert_allclose(btf.texel(4, 1), t[:, :, 1, 4], atol=tol, rtol=tol)
    np.testing.assert_allclose(btf.light_directions[2],
                               [0, -np.sin(np.radians(60)), 0.5], atol=1e-6)
    assert btf.describe()["components"] == [u.shape[1]] * 3


def test_dfmf_round_trip_with_rotations(tmp_path):
    t = truth(np.random.default_rng(7))
    cols = stored_columns(t)  # (V, L, T, C)
    us, sxvs, svs = [], [], []
    for c in range(3):
        u, s, vt = np.linalg.svd(cols[..., c].reshape(6, -1), full_matrices=False)
        k = c + 3  # different component counts per channel
        us.append(u[:, :k])
        sxvs.append((s[:k, None] * vt[:k]).T)
        svs.append(s[:k])
    rot = np.eye(3)[None].repeat(2, axis=0)
    path = write_ubo2014(tmp_path / "d.btf", signature="DFMF", view_angles=V14,
                         light_angles=L14, width=W14, height=H14, u=us, sxv=sxvs,
                         singular_values=svs, data_size=8, rotations=rot)
    btf = read_ubo2014(path)
    assert btf.signature == "DFMF" and [u.shape[1] for u in btf.u] == [3, 4, 5]
    np.testing.assert_allclose(btf.rotations, rot)
    np.testing.assert_allclose(btf.lookup(1, 2), t[1, 2], atol=1e-6)
    np.testing.assert_allclose(btf.texel(0, 3), t[:, :, 3, 0], atol=1e-6)


def test_fmf1_dynamic_range_and_height_map(tmp_path):
    t = truth(np.random.default_rng(8))
    u, sxv, s = fmf_factors(np.log(t + 1e-5))
    hm = np.arange(6, dtype=np.uint16).reshape(2, 3)
    path = write_ubo2014(tmp_path / "e.btf", signature="FMF1", view_angles=V14,
                         light_angles=L14, width=W14, height=H14, u=u, sxv=sxv,
                         singular_values=s, data_size=8, dynamic_range_reduction=True,
                         height_map=hm)
    btf = read_ubo2014(path)
    assert btf.dynamic_range_reduction
    np.testing.assert_array_equal(btf.height_map, hm)
    np.testing.assert_allclose(btf.lookup(0, 1), t[0, 1], rtol=1e-6)


@pytest.mark.parametrize("version", [1, 2, 3])
def test_old_header_versions(tmp_path, version):
    t = truth(np.random.default_rng(9))
    u, sxv, _ = fmf_factors(t)
    path = write_ubo2014(tmp_path / "v.btf", view_angles=V14, light_angles=L14, width=W14,
                         height=H14, u=u, sxv=sxv, data_size=8, version=version,
                         cosine_flag=1, xml="x")
    btf = read_ubo2014(path)
    assert btf.header["version"] == version and btf.channels == ["R", "G", "B"]
    assert btf.header["cosine_flag"] == (1 if version > 1 else 0)
    assert btf.header["xml"] == ("x" if version > 2 else "")
    np.testing.assert_allclose(btf.lookup(1, 1), t[1, 1], atol=1e-6)


def test_single_channel(tmp_path):
    t = truth(np.random.default_rng(10), channels=1)
    u, sxv, _ = fmf_factors(t)
    path = write_ubo2014(tmp_path / "g.btf", view_angles=V14, light_angles=L14, width=W14,
                         height=H14, u=u, sxv=sxv, data_size=8, channels=["Y"])
    btf = read_ubo2014(path)
    assert btf.channels == ["Y"]
    np.testing.assert_allclose(btf.lookup(0, 2), t[0, 2], atol=1e-6)


@pytest.fixture()
def btf14(tmp_path):
    u, sxv, s = fmf_factors(truth(np.random.default_rng(11)))
    path = write_ubo2014(tmp_path / "ok.btf", view_angles=V14, light_angles=L14, width=W14,
                         height=H14, u=u, sxv=sxv, singular_values=s, data_size=4)
    return path, path.read_bytes()


def _header_end(data: bytes) -> int:
    """Offset just after the common header (version 4, FMF0, no 'R')."""
    start = 1 + 4 + 3
    return start + struct.unpack_from("<I", data, start)[0]


@pytest.mark.parametrize(("patch", "message"), [
    (lambda d: b"?" + d[1:], "does not start with '!'"),
    (lambda d: b"!PVF0" + d[5:], "signature b'PVF0'"),
    (lambda d: d[:5] + b"7FC" + d[8:], "must be followed by '6FC'"),
    (lambda d: d[:8] + struct.pack("<I", 999) + d[12:], "size field says 999"),
    (lambda d: d[: _header_end(d)] + struct.pack("<I", 10**9) + d[_header_end(d) + 4 :],
     "view count 1,000,000,000 is impossible"),
    (lambda d: d + b"\0", "1 unexpected bytes"),
    (lambda d: d[:-1], "truncated"),
    (lambda d: d[:40], "truncated"),
])
def test_ubo2014_header_errors(tmp_path, btf14, patch, message):
    path = tmp_path / "bad.btf"
    path.write_bytes(patch(btf14[1]))
    with pytest.raises(InvalidBTFData, match=message) as info:
        read_ubo2014(path)
    assert str(path) in str(info.value)


def _factor_header(data: bytes) -> int:
    """Offset of the FMF0 factor block (k0, size, k1, rows, cols) in the fixture file."""
    pos = _header_end(data)
    pos += 4 + 2 * (8 + 4 + 3 * 8)  # views, each with angles, count and 3 lights
    return pos + 8  # width, height


def test_ubo2014_factor_block_errors(tmp_path, btf14):
    data = btf14[1]
    pos = _factor_header(data)
    k0, size, k1, rows, cols = struct.unpack_from("<IBIII", data, pos)
    assert (size, rows, cols) == (4, 18, 20)
    cases = {
        "element size 3 is not": struct.pack("<IBI", k0, 3, k1),
        "0 components": struct.pack("<IBI", 0, 4, k1),
        "19 rows": struct.pack("<IBIII", k0, 4, k1, 19, cols),
        "21 columns": struct.pack("<IBIII", k0, 4, k1, rows, 21),
    }
    for message, patch in cases.items():
        path = tmp_path / "bad.btf"
        path.write_bytes(data[:pos] + patch + data[pos + len(patch):])
        with pytest.raises(InvalidBTFData, match=message):
            read_ubo2014(path)
    # A component count far beyond the file is refused before allocation.
    path.write_bytes(data[:pos] + struct.pack("<IBI", 10**8, 4, 10**8) + data[pos + 9:])
    with pytest.raises(InvalidBTFData, match="truncated: the factors"):
        read_ubo2014(path)
    with pytest.raises(InvalidBTFData, match="max_bytes limit"):
        read_ubo2014(btf14[0], max_bytes=100)


def test_ubo2014_missing_path(tmp_path):
    with pytest.raises(BTFFileNotFound):
        read_ubo2014(tmp_path / "none.btf")


def test_fuzz_ubo2014(tmp_path, btf14):
    rng = np.random.default_rng(99)
    outcomes = Counter()
    path = tmp_path / "fuzz.btf"
    for _ in range(200):
        path.write_bytes(mutate(btf14[1], rng))
        try:
            btf = read_ubo2014(path)
            btf.lookup(0, 0)
            btf.texel(0, 0)
            outcomes["ok"] += 1
        except InvalidBTFData:
            outcomes["InvalidBTFData"] += 1
    assert sum(outcomes.values()) == 200 and outcomes["InvalidBTFData"] > 50


def test_ubo2014_overflowing_factors_refused(tmp_path):
    u, sxv, s = fmf_factors(truth(np.random.default_rng(14)))
    u[3, 0] = 2.5e38
    path = write_ubo2014(tmp_path / "loud.btf", view_angles=V14, light_angles=L14, width=W14,
                         height=H14, u=u, sxv=sxv, data_size=4)
    with pytest.raises(InvalidBTFData, match=r"loud.btf: its factors reach values up to "
                                             r"[\d.]+e\+38 .*beyond float32's 3.4e\+38"):
        read_ubo2014(path)
    u[3, 0] = 1e30  # large, but no sum can leave float32
    path = write_ubo2014(tmp_path / "ok.btf", view_angles=V14, light_angles=L14, width=W14,
                         height=H14, u=u, sxv=sxv, data_size=4)
    btf = read_ubo2014(path)
    assert not btf.defects["may_overflow"]
    assert np.isfinite(btf.lookup(0, 1)).all() and np.isfinite(btf.texel(2, 1)).all()


def test_ubo2014_log_encoded_overflow_flagged(tmp_path):
    t = truth(np.random.default_rng(15))
    u, sxv, s = fmf_factors(np.log(t + 1e-5))
    kwargs = dict(signature="FMF1", view_angles=V14, light_angles=L14, width=W14, height=H14,
                  sxv=sxv, singular_values=s, data_size=8, dynamic_range_reduction=True)
    btf = read_ubo2014(write_ubo2014(tmp_path / "fine.btf", u=u, **kwargs))
    assert btf.defects["may_overflow"] is False
    u[0] *= -1e3  # view 0, light 0, channel R: log values in the thousands
    btf = read_ubo2014(write_ubo2014(tmp_path / "bright.btf", u=u, **kwargs))
    assert btf.defects["may_overflow"] is True
    assert np.isinf(btf.lookup(0, 0)).any()


def test_ubo2014_non_finite_factors_counted(tmp_path):
    u, sxv, s = fmf_factors(truth(np.random.default_rng(12)))
    u[0, 0] = np.nan
    sxv[3, 0] = np.inf
    path = write_ubo2014(tmp_path / "n.btf", view_angles=V14, light_angles=L14, width=W14,
                         height=H14, u=u, sxv=sxv, data_size=4)
    btf = read_ubo2014(path)
    assert btf.defects["non_finite_factors"] == 2
    assert np.isnan(btf.lookup(0, 0)[..., 0]).all()
    assert np.isfinite(btf.lookup(1, 1)).sum() == H14 * W14 * 3 - 3
