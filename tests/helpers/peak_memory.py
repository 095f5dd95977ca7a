"""Peak resident memory of one reader call, measured in a fresh subprocess.

The readers' memory bound (issue "What independent checks found", part 3) is about what the
operating system really gives the process, so it is measured as the kernel sees it: the
peak resident set (``VmHWM``) after the call minus the peak after the imports. A fresh
process per call keeps one test's allocations out of another's figure.

Usage::

    extra = peak_extra_bytes("from spectral_materials.core.formats import exr",
                             "exr.read_exr(PATH)", path)
    assert extra <= 2 * decoded_bytes + 100 * MB
"""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
import textwrap
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

MB = 1 << 20
REPO = Path(__file__).resolve().parents[2]

_PROBE = textwrap.dedent("""
    import json, sys
    sys.path.insert(0, {repo!r})
    PATH = {path!r}

    def peak():
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
        raise RuntimeError("no VmHWM in /proc/self/status")

    {setup}
    before = peak()
    outcome = "ok"
    try:
        {call}
    except Exception as exc:        # the test checks the kind; the figure is what matters
        outcome = type(exc).__module__ + "." + type(exc).__qualname__ + ": " + str(exc)[:500]
    print(json.dumps({{"extra": peak() - before, "outcome": outcome}}))
""")


@dataclass(frozen=True)
class Bomb:
    """A crafted file (``make(directory) -> path``, deterministic and quick) and the reader
    call aimed at it: ``setup`` and ``call`` are code for :func:`peak_run`, and
    ``decoded_bytes`` is the decoded size of the data the file can really hold (for a
    claim its bytes cannot back, the file's own size)."""

    make: Callable[[Path], Path]
    setup: str
    call: str
    decoded_bytes: int
    note: str = ""


def bound_bytes(decoded_bytes: int) -> int:
    """The readers' memory bound: twice the data the file really holds, plus 100 MB."""
    return 2 * decoded_bytes + 100 * MB


def project_error(outcome: str) -> type | None:
    """The exception class of a ``"module.Class: message"`` outcome if it is one of the
    project's ValueError subclasses, else None."""
    qualified = outcome.split(":", 1)[0]
    module, _, name = qualified.rpartition(".")
    if not module.startswith("spectral_materials"):
        return None
    cls = getattr(importlib.import_module(module), name, None)
    return cls if isinstance(cls, type) and issubclass(cls, ValueError) else None


def check_read(name: str, path: Path, setup: str, call: str, decoded_bytes: int) -> str:
    """Read ``path`` in a fresh process and assert the bound, and that a failure is a project
    error naming the file; returns the outcome. A read that runs past 60 s fails too (a
    hostile file can cost time instead of memory)."""
    result = peak_run(setup, call, path, timeout=60.0)
    outcome = result["outcome"]
    bound = bound_bytes(decoded_bytes)
    assert result["extra"] <= bound, (
        f"{name}: +{result['extra'] / MB:.1f} MB, bound {bound / MB:.1f} MB ({outcome[:200]})")
    if outcome != "ok":
        assert project_error(outcome) is not None, outcome
        assert str(path) in outcome, outcome
    return outcome


def peak_run(setup: str, call: str, path: str | Path, timeout: float = 120.0) -> dict:
    """``{"extra": bytes, "outcome": "ok" | "module.Error: message"}`` of ``call`` after
    ``setup`` in a fresh interpreter, ``PATH`` bound to ``str(path)``."""
    code = _PROBE.format(repo=str(REPO), path=str(path), setup=setup,
                         call=call.replace("\n", "\n    "))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=timeout, check=False)
    if done.returncode != 0 or not done.stdout.strip():
        raise RuntimeError(f"memory probe failed ({done.returncode}): {done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def peak_extra_bytes(setup: str, call: str, path: str | Path) -> int:
    """The peak resident bytes ``call`` added (see :func:`peak_run`)."""
    return int(peak_run(setup, call, path)["extra"])
