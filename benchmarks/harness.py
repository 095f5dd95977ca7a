"""What every benchmark shares: the command line, the machine record, interleaved timing
of a baseline and a candidate, the log and the Markdown/JSON writers with their date.

Benchmarks run as ``python -m benchmarks.<name>`` from the repository root, or through
the thin ``scripts/bench_<name>.py``; both put the checkout on ``sys.path``. Nothing here
imports ``bpy`` at module level: ``benchmarks.eevee`` must set the GL driver's environment
before Blender starts its GPU.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def log(message: str) -> None:
    """One progress line, flushed at once (benchmarks run for minutes)."""
    print(message, flush=True)


# ------------------------------------------------------------------ command line


def parser(doc: str | None, *, quick_help: str | None = None,
           out_help: str | None = None, device_out: bool = False) -> argparse.ArgumentParser:
    """The parser every benchmark starts from: its description is the docstring's first
    line; ``--quick`` (when ``quick_help`` is given) and ``--out DIR`` (when ``out_help``
    is given; ``device_out`` also accepts ``--device-out``), defaulting to ``docs/``."""
    made = argparse.ArgumentParser(description=(doc or "").splitlines()[0])
    if quick_help is not None:
        made.add_argument("--quick", action="store_true", help=quick_help)
    if out_help is not None:
        names = ("--device-out", "--out") if device_out else ("--out",)
        made.add_argument(*names, dest="out", default=str(DOCS), help=out_help)
    return made


def command_line(name: str) -> str:
    """How this run was started, for the report: ``python scripts/bench_<name>.py …``
    through the thin script, ``python -m benchmarks.<name> …`` otherwise."""
    started = Path(sys.argv[0]).resolve()
    try:
        entry = started.relative_to(ROOT).as_posix()
    except ValueError:
        entry = f"scripts/bench_{name}.py"
    if entry.startswith("benchmarks/"):
        return " ".join(["python", "-m", f"benchmarks.{name}", *sys.argv[1:]])
    return " ".join(["python", entry, *sys.argv[1:]])


def date_stamp(day_only: bool = False) -> str:
    """The run's date: local time to the second with its offset, or the day alone."""
    if day_only:
        return datetime.date.today().isoformat()
    return datetime.datetime.now().astimezone().isoformat(timespec="seconds")


def output_stem(name: str, quick: bool) -> str:
    """``bench_<name>``, or ``bench_<name>_quick`` for a quick run."""
    return f"bench_{name}_quick" if quick else f"bench_{name}"


# ------------------------------------------------------------------- the machine


def gpu_machine() -> dict:
    """The GPU (renderer, vendor, version, backend), the load, CPUs and versions."""
    import bpy
    import gpu

    return {"renderer": gpu.platform.renderer_get(), "vendor": gpu.platform.vendor_get(),
            "version": gpu.platform.version_get(), "backend": gpu.platform.backend_type_get(),
            "load_start": os.getloadavg()[0],
            "cpu_count": os.cpu_count(), "blender": bpy.app.version_string,
            "python": platform.python_version(), "numpy": np.__version__}


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``), else what ``platform`` knows."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return model


def commit_of(tree: Path = ROOT) -> str:
    """The short commit hash of the checkout at ``tree`` ("unknown" outside git)."""
    try:
        done = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=False)
    except OSError:
        return "unknown"
    return done.stdout.strip() or "unknown"


def load_average() -> float:
    """The 1-minute load average: other jobs sharing the cores show here."""
    return os.getloadavg()[0]


# --------------------------------------------------------------------- timing


@dataclass
class Interleaved:
    """Timings of a candidate between timings of its baseline: B C B C … C B.

    Each candidate timing has a baseline timing on either side, so that both see the
    same share of the other jobs on the machine; ``ratios`` compares each candidate
    timing with the mean of the two baseline timings around it.
    """

    candidate: list[float] = field(default_factory=list)
    baseline: list[float] = field(default_factory=list)

    def ratios(self) -> list[float]:
        """Candidate over the mean of its neighbouring baseline timings."""
        return [c / (0.5 * (b0 + b1)) for c, b0, b1 in
                zip(self.candidate, self.baseline[:-1], self.baseline[1:])]

    def inverse_ratios(self) -> list[float]:
        """The mean of the neighbouring baseline timings over the candidate's."""
        return [0.5 * (b0 + b1) / c for c, b0, b1 in
                zip(self.candidate, self.baseline[:-1], self.baseline[1:])]


def interleave(candidate: Callable[[], float], baseline: Callable[[], float],
               reps: int) -> Interleaved:
    """Run ``baseline``, then ``reps`` times ``candidate`` and ``baseline`` again; each
    call returns the seconds (or any cost) it measured."""
    timings = Interleaved(baseline=[baseline()])
    for _ in range(reps):
        timings.candidate.append(candidate())
        timings.baseline.append(baseline())
    return timings


# ---------------------------------------------------------------------- writers


def write_json(path: Path, results: dict, *, indent: int = 1, default=None) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(results, indent=indent, default=default))


def write_markdown(path: Path, lines: list[str] | str) -> None:
    """The report; a list of lines is joined with newlines (no trailing newline added)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(lines if isinstance(lines, str) else "\n".join(lines))


def publish(out: Path | str, name: str, quick: bool, results: dict, lines: list[str], *,
            indent: int = 1) -> None:
    """``bench_<name>[_quick].json`` (the results) and ``.md`` (``lines``) in ``out``, and
    the Markdown printed: the end of every benchmark that renders its report as lines."""
    out, stem = Path(out), output_stem(name, quick)
    write_json(out / f"{stem}.json", results, indent=indent, default=float)
    write_markdown(out / f"{stem}.md", lines)
    print("\n".join(lines))


def write_outputs(out: Path, stem: str, results: dict, markdown: Callable[[dict, Path], None],
                  *, indent: int = 1, default=None) -> None:
    """``<stem>.json`` (the results) and ``<stem>.md`` (``markdown(results, path)``)."""
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / f"{stem}.json", results, indent=indent, default=default)
    markdown(results, out / f"{stem}.md")
