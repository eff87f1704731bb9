"""The HTML report of a positioning run: ISO 230-2 values equal those computed here with
plain loops from the deviations; edition, GB/T names, compensation and residuals shown."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from processing.iso230_2 import QUANTITY_NAMES
from saved_runs.report.build import build_report
from tui.cli import main

from .html_report import assert_self_contained, number, rows_by_first_cell, table_with_header

TARGETS_MM = (0.0, 50.0, 100.0, 150.0)
RUNS = 3
K = 2.0


def deviation_um(run: int, direction: int, i: int) -> float:
    """A systematic curve, a reversal of about 1.2 um and run-to-run scatter."""
    return 2.0 * i - 0.4 * i * i + (1.2 if direction < 0 else 0.0) + 0.15 * ((run * 7 + i * 3 + direction) % 5 - 2)


@pytest.fixture(scope="module")
def positioning_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("pos")
    lines = ["run,direction,target_mm,reading_mm"]
    for run in range(1, RUNS + 1):
        for d in (1, -1):
            order = range(len(TARGETS_MM)) if d > 0 else reversed(range(len(TARGETS_MM)))
            for i in order:
                t = TARGETS_MM[i]
                lines.append(f"{run},{d:+d},{t},{t + deviation_um(run, d, i) / 1000:.7f}")
    csv = tmp / "pos.csv"
    csv.write_text("\n".join(lines) + "\n")
    out = tmp / "run"
    assert main(["import", "positioning", str(csv), "--out", str(out), "--compensated", "--axis", "X"]) == 0
    return out


def iso230_2_by_loops() -> dict[str, list[float] | float]:
    means: dict[int, list[float]] = {1: [], -1: []}
    stds: dict[int, list[float]] = {1: [], -1: []}
    for d in (1, -1):
        for i in range(len(TARGETS_MM)):
            xs = [deviation_um(run, d, i) for run in range(1, RUNS + 1)]
            m = sum(xs) / len(xs)
            means[d].append(m)
            stds[d].append(math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1)))
    reversal = [means[1][i] - means[-1][i] for i in range(len(TARGETS_MM))]
    mean_bi = [(means[1][i] + means[-1][i]) / 2 for i in range(len(TARGETS_MM))]
    all_means = means[1] + means[-1]
    upper = [means[d][i] + K * stds[d][i] for d in (1, -1) for i in range(len(TARGETS_MM))]
    lower = [means[d][i] - K * stds[d][i] for d in (1, -1) for i in range(len(TARGETS_MM))]
    r_i = [max(K * stds[1][i] + K * stds[-1][i] + abs(reversal[i]), 2 * K * stds[1][i], 2 * K * stds[-1][i])
           for i in range(len(TARGETS_MM))]
    return {"B_i": reversal, "B": max(abs(b) for b in reversal), "E": max(all_means) - min(all_means),
            "M": max(mean_bi) - min(mean_bi), "A": max(upper) - min(lower), "R": max(r_i), "R_i": r_i,
            "max_abs_mean": max(abs(m) for m in all_means)}


def test_positioning_report_values_edition_and_names(positioning_run: Path, tmp_path: Path) -> None:
    path = build_report(positioning_run, out=tmp_path / "sub" / "report.html")
    doc = path.read_text(encoding="utf-8")
    assert assert_self_contained(doc) == 1  # runs, means with ±2 s bands, reversal per target
    exp = iso230_2_by_loops()

    iso = rows_by_first_cell(table_with_header(doc, "symbol", "GB/T 17421.2 name"))
    for q in ("B", "E", "M", "A", "R"):
        assert number(iso[q]["value"]) == pytest.approx(exp[q], abs=5e-4), q
        assert iso[q]["unit"] == "µm"
        assert iso[q]["ISO 230-2 name"] == QUANTITY_NAMES[q][0]
        assert iso[q]["GB/T 17421.2 name"] == QUANTITY_NAMES[q][1]
    assert "ISO 230-2:2014 results (k = 2)" in doc

    per_target = table_with_header(doc, "i", "B_i")
    col = {h: n for n, h in enumerate(per_target[0])}
    for i, row in enumerate(per_target[1:]):
        assert number(row[col["target (mm)"]]) == TARGETS_MM[i]
        assert int(row[col["n ↑"]]) == RUNS and int(row[col["n ↓"]]) == RUNS
        assert number(row[col["B_i"]]) == pytest.approx(exp["B_i"][i], abs=5e-4)
        assert number(row[col["R"]]) == pytest.approx(exp["R_i"][i], abs=5e-4)

    vdi = rows_by_first_cell(table_with_header(doc, "symbol", "name"))
    assert number(vdi["U_max"]["value"]) == pytest.approx(exp["B"], abs=5e-4)  # max |B_i|
    assert number(vdi["Pa"]["value"]) == pytest.approx(exp["M"], abs=5e-4)

    residual = rows_by_first_cell(table_with_header(doc, "model", "RMS (µm)"))
    assert set(residual) == {"none", "linear", "spline", "segments", "polynomial"}
    assert "Residual at every measured point" in doc
    # uncompensated: the residual is every measured deviation itself; E of it is the ISO E
    raw = [deviation_um(run, d, i) for run in range(1, RUNS + 1) for d in (1, -1) for i in range(len(TARGETS_MM))]
    assert number(residual["none"]["range (µm)"]) == pytest.approx(max(raw) - min(raw), abs=5e-4)
    assert number(residual["none"]["max |r| (µm)"]) == pytest.approx(max(abs(x) for x in raw), abs=5e-4)
    assert number(residual["none"]["E (µm)"]) == pytest.approx(exp["E"], abs=5e-4)
    # linear through the means: each point keeps its deviation from its target/direction mean
    scatter = []
    for d in (1, -1):
        for i in range(len(TARGETS_MM)):
            xs = [deviation_um(run, d, i) for run in range(1, RUNS + 1)]
            scatter += [x - sum(xs) / len(xs) for x in xs]
    lin = residual["linear"]
    assert number(lin["max |r| (µm)"]) == pytest.approx(max(abs(x) for x in scatter), abs=5e-4)
    assert number(lin["range (µm)"]) == pytest.approx(max(scatter) - min(scatter), abs=5e-4)
    assert number(lin["RMS (µm)"]) == pytest.approx(math.sqrt(sum(x * x for x in scatter) / len(scatter)), abs=5e-4)
    assert number(lin["E (µm)"]) == pytest.approx(0.0, abs=5e-4)
    # 4 targets: the polynomial is fitted with degree min(6, 4 − 2) = 2 and says so
    assert residual["polynomial"]["note"].startswith("degree 2 (of 6 requested")

    comp = rows_by_first_cell(table_with_header(doc, "item", None))  # the run table
    assert comp["kind"]["value"] == "positioning"
    assert comp["points recorded / planned"]["value"].startswith(f"{len(TARGETS_MM) * RUNS * 2} /")
    assert "readings_compensated is true" in doc  # why no environmental compensation
    assert "Positioning deviations x_ij = actual − target" in doc


def test_single_run_note_is_shown(tmp_path: Path) -> None:
    csv = tmp_path / "one.csv"
    csv.write_text("run,direction,target_mm,reading_mm\n1,+1,0,0.001\n1,+1,100,100.002\n"
                   "1,-1,100,100.003\n1,-1,0,0.0015\n")
    run = tmp_path / "run"
    assert main(["import", "positioning", str(csv), "--out", str(run), "--compensated"]) == 0
    doc = build_report(run).read_text(encoding="utf-8")
    assert "<h3>Notes</h3>" in doc and "single run" in doc and "no repeatability figures" in doc
    iso = rows_by_first_cell(table_with_header(doc, "symbol", "GB/T 17421.2 name"))
    # B_i = up − down: 1 − 1.5 = −0.5 um at 0 mm, 2 − 3 = −1 um at 100 mm
    assert iso["R"]["value"] == "—" and number(iso["B"]["value"]) == pytest.approx(1.0, abs=5e-4)


def test_rotary_axis_in_arcsec(tmp_path: Path) -> None:
    # deviations (arcsec): up 0°: 1, 2; 90°: 3, 4; down 0°: -1 (read as 359.99972°), 0; 90°: 5, 6
    devs = {(1, 1, 0): 1, (2, 1, 0): 2, (1, 1, 90): 3, (2, 1, 90): 4,
            (1, -1, 0): -1, (2, -1, 0): 0, (1, -1, 90): 5, (2, -1, 90): 6}
    lines = ["run,direction,target_deg,reading_deg"]
    for (run, d, t), dev in devs.items():
        lines.append(f"{run},{d:+d},{t},{(t + dev / 3600.0) % 360.0:.10f}")
    csv = tmp_path / "rot.csv"
    csv.write_text("\n".join(lines) + "\n")
    run = tmp_path / "run"
    assert main(["import", "positioning", str(csv), "--out", str(run), "--axis-type", "rotary", "--axis", "C"]) == 0
    doc = build_report(run).read_text(encoding="utf-8")
    iso = rows_by_first_cell(table_with_header(doc, "symbol", "GB/T 17421.2 name"))
    # means up 1.5, 3.5; down -0.5, 5.5: B_i = 2, -2; E = 5.5 - (-0.5); M = mean_bi 0.5 … 4.5
    expected = {"B": 2.0, "B_mean": 0.0, "E": 6.0, "M": 4.0}
    for q, v in expected.items():
        assert iso[q]["unit"] == "arcsec" and number(iso[q]["value"]) == pytest.approx(v, abs=5e-4), q
    assert "target (°)" in doc and "rotary axis: angular readings are not air-compensated" in doc
