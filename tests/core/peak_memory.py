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

import json
import subprocess
import sys
import textwrap
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
