#!/usr/bin/env python3
"""Peak memory of every file reader on crafted bombs: the table of the readers' memory bound.

Each bomb of ``tests/helpers/bombs_archives.py`` and ``tests/helpers/bombs_binary.py`` (the same
files the default suite's memory tests use) is crafted in a temporary folder and read in a
fresh interpreter; the figure is the peak resident memory the read added (``VmHWM`` after
the read minus after the imports, ``tests/helpers/peak_memory.py``), against the bound
``2 × decoded + 100 MB``, where *decoded* is the size of the data the file can really hold.

``--tree PATH`` reads with the package of another checkout (for example a ``git worktree``
of an older commit) while crafting the same files, so that before and after come from one
script. Writes Markdown and JSON (``--out``, default ``docs/bench_reader_memory``).

Run as ``python -m benchmarks.reader_memory`` or ``scripts/bench_reader_memory.py``.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from . import harness

# The bombs and the peak-memory runner are the default suite's (tests/helpers/).
sys.path.insert(0, str(harness.ROOT / "tests" / "helpers"))

import bombs_archives  # noqa: E402
import bombs_binary  # noqa: E402
from peak_memory import MB, bound_bytes, peak_run  # noqa: E402

REPO = harness.ROOT


def measure(tree: Path | None) -> list[dict]:
    rows = []
    bombs = {**bombs_archives.BOMBS, **bombs_binary.BOMBS}
    prefix = "" if tree is None else f"import sys; sys.path.insert(0, {str(tree)!r})\n"
    with tempfile.TemporaryDirectory() as folder:
        for name, bomb in bombs.items():
            path = bomb.make(Path(folder))
            result = peak_run(prefix + bomb.setup, bomb.call, path)
            bound = bound_bytes(bomb.decoded_bytes)
            outcome = result["outcome"].replace(str(path), "<file>")
            rows.append({"bomb": name, "file_bytes": path.stat().st_size,
                         "decoded_bytes": bomb.decoded_bytes, "extra_bytes": result["extra"],
                         "bound_bytes": bound, "within": result["extra"] <= bound,
                         "outcome": outcome.split(":", 1)[0] if outcome != "ok" else "ok",
                         "message": outcome})
            print(f"{name}: +{result['extra'] / MB:.1f} MB (bound {bound / MB:.0f} MB), "
                  f"{outcome[:120]}", file=sys.stderr)
    return rows


def markdown(rows: list[dict], label: str) -> list[str]:
    lines = [f"### {label}", "",
             "| bomb | file | peak added | bound | within | outcome |",
             "|---|---:|---:|---:|---|---|"]
    for r in rows:
        lines.append(f"| {r['bomb']} | {r['file_bytes'] / 1024:.1f} KiB | "
                     f"{r['extra_bytes'] / MB:.1f} MB | {r['bound_bytes'] / MB:.0f} MB | "
                     f"{'yes' if r['within'] else '**no**'} | {r['outcome']} |")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = harness.parser(__doc__)
    parser.add_argument("--tree", type=Path, action="append", default=[],
                        help="also measure the package of this checkout (repeatable), "
                        "labelled by its commit")
    parser.add_argument("--out", type=Path, default=harness.DOCS / "bench_reader_memory")
    args = parser.parse_args(argv)
    runs = {f"commit {harness.commit_of(tree)}": measure(tree.resolve()) for tree in args.tree}
    runs[f"this checkout (commit {harness.commit_of(REPO)} and its working tree)"] = measure(None)
    lines = ["# Reader memory on crafted bombs", "",
             "Written by `scripts/bench_reader_memory.py`. Peak resident memory a read added in "
             "a fresh process (VmHWM after minus after the imports), against the bound "
             "2 × decoded + 100 MB (decoded: the data the file can really hold). Outcome: "
             "`ok` (read) or the error class (each message names the file).", ""]
    for label, rows in runs.items():
        lines += markdown(rows, label) + [""]
    harness.write_markdown(args.out.with_suffix(".md"), lines)
    harness.write_json(args.out.with_suffix(".json"), runs, indent=2)
    print("\n".join(lines))
    return 0 if all(r["within"] for r in list(runs.values())[-1]) else 1


if __name__ == "__main__":
    sys.exit(main())
