"""docs/bench_gpu.md's script against the committed H200 replay: every case of the issue's
table, the precisions' per-pack costs and the PRT ratio come from the replay's numbers."""

import json
from pathlib import Path

from benchmarks.gpu_replay import report

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "gpu" / "h200_gpu_results.json"


def test_the_report_states_the_replay_numbers():
    results = json.loads(RESULTS.read_text())
    cases = {c["name"]: c for c in results["cases"]}
    text = "\n".join(report.markdown(results, str(RESULTS)))
    assert "NVIDIA H200" in text
    for name in report.ISSUE_H100:
        assert f"| `{name}` | {report._ms(cases[name]):.3f} |" in text, name
    spectral, rgb = cases["prt_spectral_m8"], cases["prt_rgb"]
    assert f"| {report._ms(spectral):.3f} | {report._ms(spectral) / report._ms(rgb):.2f} |" \
        in text
    exact = (report._ms(cases["draw_io_iso_precontract_p22_l1"]) -
             report._ms(cases["draw_baseline_l1"])) / 22
    assert f"| 22 | 1 | exact | {report._ms(cases['draw_io_iso_precontract_p22_l1']):.3f} | " \
           f"{exact:.4f} | 1.00 |" in text
    assert text.count("\n| ") >= len(results["cases"])


def test_the_committed_page_is_the_scripts_output(monkeypatch):
    # The page names its inputs relative to the repository root.
    monkeypatch.chdir(RESULTS.parents[2])
    assert len(list(RESULTS.parent.glob("*_explored_*.json"))) == 2
    page = (RESULTS.parents[1] / "bench_gpu.md").read_text()
    assert page == report.page("docs/gpu/h200_gpu_results.json")
    assert "### Albedo precisions" in page and "h200_prt_paths" not in page
