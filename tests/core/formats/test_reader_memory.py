"""Peak memory of every file reader on hostile files, and on valid files of each kind.

The bombs of ``bombs_archives`` (EXR, spectral EXR, ``.npz``, UBO BTFs) and
``bombs_binary`` (RGL ``.bsdf``, MERL, spectrum CSV) are each read in a fresh interpreter
(``peak_memory.check_read``): the peak resident memory the read added must stay within
``2 × decoded_bytes + 100 MB``, where ``decoded_bytes`` is what the file can really hold,
and the read must either succeed or raise a project error (a ValueError subclass defined
in spectral_materials) whose message names the file. ``scripts/bench_reader_memory.py``
prints the same figures as a table.
"""

from __future__ import annotations

from pathlib import Path

import bombs_archives
import bombs_binary
import numpy as np
import pytest
from peak_memory import check_read

BOMBS = {**bombs_archives.BOMBS, **bombs_binary.BOMBS}


def test_registries_do_not_shadow_each_other():
    assert not set(bombs_archives.BOMBS) & set(bombs_binary.BOMBS)


@pytest.mark.parametrize("name", sorted(BOMBS))
def test_reader_memory_stays_in_proportion(tmp_path, name):
    bomb = BOMBS[name]
    check_read(name, bomb.make(tmp_path), bomb.setup, bomb.call, bomb.decoded_bytes)


# --------------------------------------------------------------------------- valid files


def _exr(directory: Path) -> tuple[Path, int]:
    from spectral_materials.core.formats.exr import write_exr

    rng = np.random.default_rng(0)
    channels = {c: rng.random((1024, 2048), dtype=np.float32) for c in "RGB"}
    return write_exr(directory / "frame.exr", channels), 3 * 1024 * 2048 * 4


def _spectral(directory: Path) -> tuple[Path, int]:
    from spectral_materials.core.formats.spectral_exr import write_spectral_exr

    values = np.random.default_rng(1).random((512, 512, 16), dtype=np.float32)
    path = write_spectral_exr(directory / "spectral.exr", np.linspace(400, 700, 16), values,
                              rgb_preview=False)  # the preview takes seconds to compute
    return path, values.nbytes


def _tabulated(directory: Path) -> tuple[Path, int]:
    from spectral_materials.core.formats.tabulated import write_tabulated

    values = np.random.default_rng(2).random((45, 90, 45, 31), dtype=np.float32)
    path = write_tabulated(directory / "table.npz", values, np.linspace(400, 700, 31),
                           "io_iso")
    return path, values.nbytes


def _ubo2003(directory: Path) -> tuple[Path, int]:
    from spectral_materials.core.formats.ubo_btf import write_ubo2003

    y, x = np.mgrid[0:128, 0:128] / 128
    images = np.empty((6, 6, 128, 128, 3))
    for i in range(36):
        images.reshape(36, 128, 128, 3)[i] = (0.2 + 0.01 * i + 0.3 * x * y)[..., None]
    angles = np.array([[0, 0], [15, 0], [30, 60], [45, 120], [60, 180], [75, 240]])
    path = write_ubo2003(directory / "btf.zip", images, angles, angles, quality=90)
    return path, images.size * 4


def _ubo2014(directory: Path) -> tuple[Path, int]:
    from spectral_materials.core.formats.ubo_btf import write_ubo2014

    rng = np.random.default_rng(3)
    angles = np.radians(np.stack([np.linspace(0, 80, 40), np.zeros(40)], axis=1))
    u, sxv = rng.random((40 * 40 * 3, 16)), rng.random((256 * 256, 16))
    path = write_ubo2014(directory / "btf.btf", view_angles=angles, light_angles=angles,
                         width=256, height=256, u=u, sxv=sxv)
    return path, path.stat().st_size


VALID = {
    "exr": (_exr, "from spectral_materials.core.formats import exr", "exr.read_exr(PATH)"),
    "spectral_exr": (_spectral, "from spectral_materials.core.formats import spectral_exr",
                     "spectral_exr.read_spectral_exr(PATH)"),
    "tabulated": (_tabulated, "from spectral_materials.core.formats import tabulated",
                  "tabulated.read_tabulated(PATH)"),
    "ubo2003": (_ubo2003, "from spectral_materials.core.formats import ubo_btf",
                "ubo_btf.read_ubo2003(PATH)"),
    "ubo2014": (_ubo2014, "from spectral_materials.core.formats import ubo_btf",
                "ubo_btf.read_ubo2014(PATH)"),
}


@pytest.mark.parametrize("name", sorted(VALID))
def test_valid_files_are_read_in_proportion(tmp_path, name):
    make, setup, call = VALID[name]
    path, decoded_bytes = make(tmp_path)
    assert check_read(name, path, setup, call, decoded_bytes) == "ok"
