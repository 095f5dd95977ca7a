"""The benchmarks: one module per capability, and the harness they share.

Run one as ``python -m benchmarks.<name>`` from the repository root (or through
``scripts/bench_<name>.py``); each writes ``docs/bench_<name>.md`` and ``.json``.
Modules: factor, draw, eevee, prt, prt_rotation, btf, measured, raycast, reader_memory.
"""
