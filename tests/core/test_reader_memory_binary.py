"""Peak memory of the RGL, MERL and spectrum CSV readers on hostile files (bombs_binary).

Each bomb is read in a fresh interpreter (peak_memory.peak_run); the peak resident memory
the read added must stay within ``2 × decoded_bytes + 100 MB``, where ``decoded_bytes`` is
what the file can really hold, and the read must either succeed or raise a project error
(a ValueError subclass defined in spectral_materials) whose message names the file.
"""

from __future__ import annotations

import importlib
import time

import pytest
from bombs_binary import BOMBS
from peak_memory import MB, peak_run


def _project_error(outcome: str) -> type | None:
    """The exception class of a ``"module.Class: message"`` outcome if it is a
    spectral_materials ValueError subclass, else None."""
    qualified = outcome.split(":", 1)[0]
    module, _, name = qualified.rpartition(".")
    if not module.startswith("spectral_materials"):
        return None
    cls = getattr(importlib.import_module(module), name, None)
    return cls if isinstance(cls, type) and issubclass(cls, ValueError) else None


@pytest.mark.parametrize("name", sorted(BOMBS))
def test_reader_memory_stays_in_proportion(tmp_path, name):
    bomb = BOMBS[name]
    path = bomb.make(tmp_path)
    start = time.perf_counter()
    result = peak_run(bomb.setup, bomb.call, path)
    seconds = time.perf_counter() - start
    bound = 2 * bomb.decoded_bytes + 100 * MB
    outcome = result["outcome"]
    assert result["extra"] <= bound, (
        f"{name}: +{result['extra'] / MB:.1f} MB, bound {bound / MB:.1f} MB ({outcome[:200]})")
    if outcome != "ok":
        assert _project_error(outcome) is not None, outcome
        assert str(path) in outcome, outcome
    assert seconds < 30, f"{name}: {seconds:.1f} s"
