"""What ``factor`` reports: the colour error of each fitted model and of the table itself at
the protocol's random direction pairs, printed as a fixed-width table, with notes on how the
fit ended, and written as JSON."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.brdf.factored import json_default

#: Direction pairs per chunk when measuring XYZ of a factored model.
_XYZ_CHUNK = 8192


@dataclass
class FactorResult:
    """A ``factor`` run's outcome, for the table, the notes and the JSON report."""

    #: What was factored: the model's or the file's ``describe()``.
    source: dict
    #: The tabulation that was factored (``core.brdf.tabulate.Table``).
    table: object
    wavelengths: np.ndarray
    #: The fitted models, fewest packs first.
    series: list
    #: The requested pack counts (None: the default).
    counts: list[int] | None
    illuminants: list[str]
    rows: list[dict] = field(default_factory=list)

    @property
    def final(self):
        return self.series[-1]

    @property
    def missing(self) -> list[int]:
        return missing_packs(self.rows, self.counts)


def _model_xyz(model, wi: np.ndarray, wo: np.ndarray, illuminant: str) -> np.ndarray:
    out = np.empty((wi.shape[0], 3))
    for begin in range(0, wi.shape[0], _XYZ_CHUNK):
        sl = slice(begin, begin + _XYZ_CHUNK)
        out[sl] = model.xyz(wi[sl], wo[sl], illuminant)
    return out


def _stats(reference: dict, xyz_fn, wi, wo, illuminants) -> dict:
    from ..core.brdf import metrics

    return {illum: {k: v for k, v in metrics.delta_e94_stats(
        reference[illum], xyz_fn(wi, wo, illum), illum).items() if k != "count"}
        for illum in illuminants}


def _factored_row(model, reference: dict, wi, wo, illuminants) -> dict:
    report = model.report
    requested = int(report.get("requested_packs", report["packs"]))
    return {
        "kind": "factored",
        "packs": requested,
        "packs_fitted": int(report["packs"]),
        "terms": int(model.terms),
        "relative_rms": float(report["relative_rms"]),
        "de94": _stats(reference, lambda a, b, i, m=model: _model_xyz(m, a, b, i),
                       wi, wo, illuminants),
        "factor_seconds": float(report["factor_seconds"]),
        "bytes": int(model.nbytes),
    }


def _table_floor_row(table, final, reference: dict, wi, wo, illuminants) -> dict:
    basis_bytes = 0 if table.basis is None else table.basis.vectors.size * 4
    return {
        "kind": "table_floor",
        "packs": None,
        "packs_fitted": None,
        "terms": None,
        "relative_rms": float(final.report.get("basis_relative_error", 0.0)),
        "de94": _stats(reference, table.xyz, wi, wo, illuminants),
        "factor_seconds": None,
        "tabulate_seconds": float(table.seconds),
        "bytes": int(table.values.size * 4 + basis_bytes),
    }


def measure_rows(brdf, result: FactorResult, pairs: int, progress) -> None:
    """Fill ``result.rows``: one row per fitted model and a last ``table_floor`` row, each with
    relative RMS, ΔE94 mean/p95/max per illuminant at ``pairs`` random direction pairs
    against ``brdf`` itself, seconds and bytes."""
    from ..core.brdf import metrics

    illuminants = result.illuminants
    wi, wo = metrics.random_direction_pairs(pairs)
    reference = {illum: metrics.reference_xyz(brdf, wi, wo, illum) for illum in illuminants}
    progress.check()
    for model in result.series:
        result.rows.append(_factored_row(model, reference, wi, wo, illuminants))
        progress.check()
    result.rows.append(_table_floor_row(result.table, result.final, reference, wi, wo,
                                        illuminants))


def format_table(rows: list[dict], illuminants) -> str:
    """The fixed-width error table (ASCII)."""
    head1 = f"{'':>5} {'':>6} {'':>9}"
    head2 = f"{'packs':>5} {'terms':>6} {'rel_rms':>9}"
    for illum in illuminants:
        head1 += f"  {('dE94 ' + illum):^26}"
        head2 += f"  {'mean':>8} {'p95':>8} {'max':>8}"
    head1 += f"  {'':>9} {'':>11}"
    head2 += f"  {'seconds':>9} {'bytes':>11}"
    lines = [head1.rstrip(), head2, "-" * len(head2)]
    for row in rows:
        if row["kind"] == "table_floor":
            packs, terms, seconds = "table", "-", row["tabulate_seconds"]
        else:
            packs = str(row["packs"]) + ("*" if row["packs_fitted"] < row["packs"] else "")
            terms, seconds = str(row["terms"]), row["factor_seconds"]
        line = f"{packs:>5} {terms:>6} {row['relative_rms']:9.2e}"
        for illum in illuminants:
            s = row["de94"][illum]
            line += f"  {s['mean']:8.4f} {s['p95']:8.4f} {s['max']:8.4f}"
        line += f"  {seconds:9.3f} {row['bytes']:11,d}"
        lines.append(line)
    return "\n".join(lines)


def missing_packs(rows: list[dict], counts: list[int] | None) -> list[int]:
    """Requested pack counts (of several) that no model was fitted for: the fit stopped
    before them."""
    fitted = {r["packs"] for r in rows if r["kind"] == "factored"}
    return [c for c in (counts or []) if c not in fitted] if len(counts or []) > 1 else []


def result_notes(result: FactorResult, target_de94: float | None) -> list[str]:
    """The lines printed under the table: how the fit ended and what the table row is."""
    final, missing = result.final, result.missing
    stopped = final.report.get("stopped")
    short = [r for r in result.rows
             if r["kind"] == "factored" and r["packs_fitted"] < r["packs"]]
    notes = []
    if short or missing:
        fitted_packs = int(final.report["packs"])
        notes.append(f"* the fit stopped after {fitted_packs} pack{'s' * (fitted_packs != 1)} "
                     f"({stopped}); more packs would not lower the error")
    if missing:
        notes.append(f"no models for pack counts {', '.join(map(str, missing))}")
    if target_de94 is not None:
        notes.append(f"--target-de94 {target_de94:g}: stopped at {final.packs} "
                     f"pack{'s' * (final.packs != 1)} ({stopped})")
    notes.append("table: the tabulated grid looked up without factorising (the error floor); "
                 "its seconds are the tabulation's, its rel_rms the spectral basis loss")
    return notes


def json_document(args, result: FactorResult, out_path: Path | None) -> dict:
    """The ``--json`` report: the run's settings, the rows, and the final model's report."""
    table, wavelengths, final = result.table, result.wavelengths, result.final
    return {
        "command": "factor",
        "argv": list(args.argv),
        "input": result.source,
        "grid": table.grid.describe(),
        "wavelengths": {"start": float(wavelengths[0]), "stop": float(wavelengths[-1]),
                        "count": int(wavelengths.size)},
        "spectral_basis": None if table.basis is None else int(table.basis.size),
        "method": args.method,
        "pack_size": args.pack_size,
        "seed": args.seed,
        "target_de94": args.target_de94,
        "pairs": args.pairs,
        "illuminants": result.illuminants,
        "requested_packs": result.counts,
        "missing_packs": result.missing,
        "stopped": final.report.get("stopped"),
        "rows": result.rows,
        "out": None if out_path is None else str(out_path),
        "report": final.report,
    }


def json_text(document: dict) -> str:
    """``document`` as indented JSON (paths as strings, numpy values as numbers)."""
    import json

    def default(value):
        if isinstance(value, Path):
            return str(value)
        return json_default(value)

    return json.dumps(document, indent=2, default=default) + "\n"
