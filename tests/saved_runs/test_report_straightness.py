"""The HTML report of a straightness run: self-contained, and the numbers it prints are
the ones the standard's definitions give for the profile (recomputed here)."""

from __future__ import annotations

import itertools
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from saved_runs.errors import RunFormatError
from saved_runs.evaluation.evaluate import process_run_dir
from saved_runs.report.build import build_report

from .html_report import assert_self_contained, number, rows_by_first_cell, table_with_header

V1_RUN = Path(__file__).resolve().parents[1] / "data" / "runs" / "v1-straightness"
MC_TRIALS = 200  # enough for a U column; keeps the test fast


@pytest.fixture()
def run_copy(tmp_path: Path) -> Path:
    return Path(shutil.copytree(V1_RUN, tmp_path / "run"))


def straightness_by_definition(x: np.ndarray, h: np.ndarray) -> dict[str, float]:
    """ISO 230-1: largest positive + |largest negative| deviation from the reference line.
    Minimum zone by brute force: the zone's direction is that of a line through two points."""
    def zone(slope: float) -> float:
        d = h - slope * x
        return float(d.max() - d.min())

    endpoint = zone((h[-1] - h[0]) / (x[-1] - x[0]))
    xm, hm = x.mean(), h.mean()
    least_squares = zone(float(np.sum((x - xm) * (h - hm)) / np.sum((x - xm) ** 2)))
    minimum_zone = min(zone((h[j] - h[i]) / (x[j] - x[i])) for i, j in itertools.combinations(range(len(x)), 2))
    return {"end-point line": endpoint, "least-squares line": least_squares, "minimum-zone line": minimum_zone}


def test_report_prints_straightness_per_named_reference_line(run_copy: Path) -> None:
    path = build_report(run_copy, mc_trials=MC_TRIALS)
    assert path == run_copy / "results" / "report.html"
    assert [p.name for p in path.parent.iterdir()] == ["report.html"]  # no temporary file left
    doc = path.read_text(encoding="utf-8")
    assert assert_self_contained(doc) == 1  # the profile plot

    _, evaluation = process_run_dir(run_copy, mc_trials=0)
    prof = evaluation.result.profile
    x, h = prof["x_mm"].to_numpy(), prof["height_um"].to_numpy()
    expected = straightness_by_definition(x, h)
    lines = rows_by_first_cell(table_with_header(doc, "reference line"))
    assert set(lines) == set(expected)  # every value names its reference line
    for name, value in expected.items():
        assert number(lines[name]["straightness (µm)"]) == pytest.approx(value, abs=5e-4), name
        assert number(lines[name]["U, k = 2 (µm)"]) > 0
    assert expected["minimum-zone line"] <= min(expected.values()) + 1e-12

    stations = table_with_header(doc, "station", "height (µm)")
    header, rows = stations[0], stations[1:]
    col = {name: header.index(name) for name in header}
    assert [int(r[0]) for r in rows] == list(range(8))
    endpoint_dev = h - (h[0] + (h[-1] - h[0]) / (x[-1] - x[0]) * (x - x[0]))
    for i, r in enumerate(rows):
        assert number(r[col["x (mm)"]]) == pytest.approx(x[i], abs=5e-4)
        assert number(r[col["height (µm)"]]) == pytest.approx(h[i], abs=5e-4)
        assert number(r[col["dev. end-point line (µm)"]]) == pytest.approx(endpoint_dev[i], abs=5e-4)
        u, big_u = number(r[col["u, k = 1 (µm)"]]), number(r[col["U, k = 2 (µm)"]])
        assert big_u == pytest.approx(2 * u, abs=1.5e-3)

    summary = rows_by_first_cell(table_with_header(doc, "item", None))
    assert summary["kind"]["value"] == "straightness" and summary["status"]["value"].startswith("complete")
    assert summary["points recorded / planned"]["value"] == "8 / 8"
    assert "decoupling method" in doc and "exact" in doc
    assert f"Monte Carlo (GUM-S1), {MC_TRIALS} trials" in doc
    assert 'class="alert"' not in doc  # a complete run has no status notice
    assert "guideway report" in doc and "Produced by guideway" in doc
    env = rows_by_first_cell(table_with_header(doc, "quantity", "mean"))
    temps = evaluation.run.points["air_temp_c"]
    assert number(env["air temperature (°C)"]["min"]) == pytest.approx(temps.min(), abs=5e-4)
    assert number(env["air temperature (°C)"]["mean"]) == pytest.approx(temps.sum() / len(temps), abs=5e-4)


def test_method_option_is_used_and_named(run_copy: Path, tmp_path: Path) -> None:
    out = build_report(run_copy, out=tmp_path / "r.html", method="first-order", mc_trials=0)
    doc = out.read_text(encoding="utf-8")
    assert "first-order (small-angle) formula" in doc
    assert "U of the straightness values not evaluated" in doc
    assert "--method first-order" in doc  # the command line that reproduces it


def _abort(run: Path, keep: int, status: str = "aborted") -> None:
    meta = json.loads((run / "run.json").read_text())
    meta.update(status=status, end_reason="operator abort")
    (run / "run.json").write_text(json.dumps(meta))
    lines = (run / "points.csv").read_text().splitlines()
    (run / "points.csv").write_text("\n".join(lines[: keep + 1]) + "\n")


def test_aborted_run_says_so_and_still_renders(run_copy: Path) -> None:
    _abort(run_copy, keep=4)
    doc = build_report(run_copy, mc_trials=0).read_text(encoding="utf-8")
    assert "Run status: aborted (operator abort). 4 of 8 planned points recorded" in doc
    assert doc.index('class="alert"') < doc.index("<h2>Run</h2>")  # at the top
    stations = table_with_header(doc, "station", "height (µm)")
    assert len(stations) - 1 == 4


def test_aborted_run_too_short_to_evaluate_still_renders(run_copy: Path) -> None:
    _abort(run_copy, keep=1)
    doc = build_report(run_copy).read_text(encoding="utf-8")
    assert "1 of 8 planned points recorded" in doc
    assert "Not evaluated:" in doc and "need at least 2" in doc
    assert assert_self_contained(doc) == 0


def test_complete_run_that_cannot_be_evaluated_is_an_error(run_copy: Path) -> None:
    _abort(run_copy, keep=1, status="complete")
    with pytest.raises(RunFormatError, match="need at least 2"):
        build_report(run_copy)
    assert not (run_copy / "results" / "report.html").exists()


def test_return_pass_closure_and_drift(run_copy: Path) -> None:
    """A v2 run whose return pass repeats the forward readings, the sensor reading 0.3 um
    higher: the return profile is 0.3 um higher everywhere (sensor_sign "height"), so the
    closure at the datum is 0.3 um and the drift the LS slope of 0.3 um against the time gap."""
    meta = json.loads((run_copy / "run.json").read_text())
    meta["version"] = 2
    meta["setup"]["return_pass"] = True
    (run_copy / "run.json").write_text(json.dumps(meta))
    lines = (run_copy / "points.csv").read_text().splitlines()
    header = lines[0].split(",")
    t_col, s_col = header.index("time_s"), header.index("sensor_mm")
    fwd = [ln.split(",") for ln in lines[1:]]
    t_end = max(float(r[t_col]) for r in fwd)
    back, gaps_h = [], []
    for k, r in enumerate(reversed(fwd), start=1):
        r = list(r)
        t_back = t_end + 60.0 * k
        gaps_h.append((t_back - float(r[t_col])) / 3600.0)
        r[t_col], r[s_col] = f"{t_back}", f"{float(r[s_col]) + 0.0003:.6f}"
        back.append(r)
    rows = [",".join([*r, "0"]) for r in fwd] + [",".join([*r, "1"]) for r in back]
    (run_copy / "points.csv").write_text(",".join([*header, "pass"]) + "\n" + "\n".join(rows) + "\n")

    doc = build_report(run_copy, mc_trials=0).read_text(encoding="utf-8")
    run_table = rows_by_first_cell(table_with_header(doc, "item", None))
    assert run_table["points recorded / planned"]["value"] == "16 / 16"
    section = doc[doc.index("<h3>Return pass</h3>"):]
    table = rows_by_first_cell(table_with_header(section, "item", None))
    assert number(table["closure error (µm)"]["value"]) == pytest.approx(0.3, abs=2e-3)
    expected_drift = 0.3 * sum(gaps_h) / sum(g * g for g in gaps_h)
    assert number(table["drift (µm/h)"]["value"]) == pytest.approx(expected_drift, rel=1e-2)


def test_skipped_stations_and_overridden_warmup_are_shown(run_copy: Path) -> None:
    meta = json.loads((run_copy / "run.json").read_text())
    meta["skipped"] = [{"station": 3, "pass": 0, "reason": "chip <on> the rail"}]
    meta["warmup"] = {"stable": False, "overridden": True, "duration_s": 600.0}
    (run_copy / "run.json").write_text(json.dumps(meta))
    doc = build_report(run_copy, mc_trials=0).read_text(encoding="utf-8")
    skipped = table_with_header(doc, "station", "reason")
    assert skipped[1:] == [["3", "forward", "chip <on> the rail"]]
    assert "chip &lt;on&gt; the rail" in doc
    assert '<p class="alert">Warm-up: not stable, overridden by the operator after 600 s.</p>' in doc
