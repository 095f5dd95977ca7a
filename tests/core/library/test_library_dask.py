"""Library builds on a Dask cluster: a LocalCluster with 2 worker processes builds the
generated library of 10 materials; one worker is killed mid-run and the library still
completes, nothing lost and nothing written twice; an unreachable scheduler is named.

Reference: the same library built on the local process pool (the factors are seeded,
so both must hold the same arrays)."""

from __future__ import annotations

import json
import os
import signal

import numpy as np
import pytest
from library_sources import make_sources, write_merl_file

distributed = pytest.importorskip("distributed")

from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.library import layout
from spectral_materials.core.library.build import build_library
from spectral_materials.core.library.executors import SchedulerUnreachable
from spectral_materials.core.library.settings import LibrarySettings

SETTINGS = LibrarySettings(packs=1, theta_cells=8, basis=4, thumbnail_size=24)


@pytest.fixture(scope="module")
def cluster():
    # The nannies leave their workers' environment (OMP_NUM_THREADS=1, ...) in this
    # process's os.environ; later tests must not inherit it.
    saved = dict(os.environ)
    try:
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as local:
            yield local
    finally:
        os.environ.clear()
        os.environ.update(saved)


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    root = tmp_path_factory.mktemp("dask-src")
    make_sources(root / "src", write_merl_file(root / "red.binary"))
    return root / "src"


def _arrays(lib) -> dict:
    index = json.loads((lib / layout.INDEX_FILE).read_text())
    out = {}
    for entry in index["entries"]:
        model = FactoredBRDF.load(lib / layout.MATERIALS / entry["id"] / "factors.npz")
        out[entry["id"]] = [*model.factors, model.spectral]
    return out


def test_a_cluster_builds_what_the_local_pool_builds(cluster, sources, tmp_path):
    on_cluster = build_library([sources], tmp_path / "dask", SETTINGS,
                               scheduler=cluster.scheduler_address)
    assert "Dask cluster" in on_cluster.executor and "2 workers" in on_cluster.executor
    local = build_library([sources], tmp_path / "local", SETTINGS, workers=2)
    assert len(on_cluster.written) == len(local.written) == 10
    a, b = _arrays(tmp_path / "dask"), _arrays(tmp_path / "local")
    assert a.keys() == b.keys()
    for key in a:
        for x, y in zip(a[key], b[key]):
            np.testing.assert_array_equal(x, y)


def test_a_killed_worker_loses_nothing_and_duplicates_nothing(cluster, sources, tmp_path):
    client = distributed.Client(cluster)
    killed: dict = {}

    def kill_a_busy_worker(fraction, message):
        if killed or fraction <= 0.0:
            return False
        busy = {addr: keys for addr, keys in client.processing().items() if keys}
        if not busy:
            return False
        address = sorted(busy)[0]
        pid = client.run(os.getpid, workers=[address])[address]
        os.kill(pid, signal.SIGKILL)
        killed.update(address=address, pid=pid, tasks=list(busy[address]))
        return False

    try:
        result = build_library([sources], tmp_path / "lib", SETTINGS,
                               scheduler=cluster.scheduler_address,
                               callback=kill_a_busy_worker)
    finally:
        client.close()
    assert killed and killed["tasks"], "no worker was killed while it held a task"
    with pytest.raises(ProcessLookupError):
        os.kill(killed["pid"], 0)                        # it is dead
    assert len(result.written) == 10 and not result.failed
    lib = tmp_path / "lib"
    folders = sorted((lib / layout.MATERIALS).iterdir())
    assert len(folders) == 10 and not any(p.name.startswith(".") for p in folders)
    index = json.loads((lib / layout.INDEX_FILE).read_text())
    assert len(index["entries"]) == len({e["source"] for e in index["entries"]}) == 10


def test_an_unreachable_scheduler_is_named(sources, tmp_path):
    lib = tmp_path / "lib"
    with pytest.raises(SchedulerUnreachable, match="tcp://127.0.0.1:9"):
        build_library([sources], lib, SETTINGS, scheduler="tcp://127.0.0.1:9")
    index = json.loads((lib / layout.INDEX_FILE).read_text())
    assert index["entries"] == [] and index["format"] == layout.FORMAT
