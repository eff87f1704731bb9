"""Positioning runs: CSV import into a run directory, evaluation via the EVALUATORS
registry, rotary axes in arcsec, and the per-target table other modules read."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from saved_runs.errors import UserError
from saved_runs.evaluation.evaluate import EVALUATORS, process_run_dir
from saved_runs.importing.positioning import ImportProblems, PositioningImport, import_positioning
from saved_runs.store.reader import load_run

# Hand data: 2 targets x 2 runs x 2 directions, readings already compensated.
# deviations (um): target 0: up +1, +3 / down -1, -1; target 250: up +2, +2 / down 0, +4
GOOD = """run,direction,target_mm,reading_mm,time_s
1,+1,0,0.001,0
1,+1,250,250.002,1
1,-1,250,250.000,2
1,-1,0,-0.001,3
2,1,0,0.003,4
2,1,250,250.002,5
2,-1,250,250.004,6
2,-1,0,-0.001,7
"""


def write(tmp_path: Path, text: str, name: str = "data.csv") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_import_and_evaluate_compensated(tmp_path: Path) -> None:
    out, n = import_positioning(write(tmp_path, GOOD), tmp_path / "run", PositioningImport(compensated=True))
    assert n == 8
    run = load_run(out)
    assert run.kind == "positioning" and run.meta["axis_type"] == "linear" and run.meta["version"] == 2
    assert run.meta["setup"]["environment"] == {"readings_compensated": True}
    assert run.meta["setup"]["targets_mm"] == [0.0, 250.0] and run.meta["status"] == "complete"
    assert run.points["target_index"].tolist() == [1, 2, 2, 1, 1, 2, 2, 1]
    assert "positioning" in EVALUATORS
    _, ev = process_run_dir(out)
    pt = ev.result.per_target
    assert ev.result.axis_type == "linear" and ev.result.unit == "um"
    assert pt["target"].tolist() == [0.0, 250.0] and pt["target_index"].tolist() == [1, 2]
    assert pt["mean_up"].tolist() == pytest.approx([2.0, 2.0], abs=1e-9)
    assert pt["mean_down"].tolist() == pytest.approx([-1.0, 2.0], abs=1e-9)
    a = ev.result.axis
    # B_i = 3, 0; s_up = sqrt(2), 0; s_down = 0, sqrt(8); R_i = max(2 s_up + 2 s_down + |B_i|, 4 s_up, 4 s_down)
    assert a["B"] == pytest.approx(3) and a["B_mean"] == pytest.approx(1.5)
    assert a["R"] == pytest.approx(max(2 * math.sqrt(2) + 3, 4 * math.sqrt(2), 2 * math.sqrt(8), 4 * math.sqrt(8)))
    assert a["E"] == pytest.approx(3) and a["M"] == pytest.approx(1.5)
    d = ev.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["kind"] == "positioning" and set(d["iso230_2"]) == set(a)
    assert not d["environment"]["applied"]
    res = ev.write(out / "results")
    assert (res / "positioning.csv").read_text().splitlines()[0].startswith("target_index,target_mm,n_up,n_down,")
    assert json.loads((res / "summary.json").read_text())["kind"] == "positioning"
    assert (res / "positioning.png").stat().st_size > 1000


def test_import_with_air_values_is_compensated(tmp_path: Path) -> None:
    text = ("run,direction,target_mm,reading_mm,air_temp_c,air_pressure_hpa,humidity_pct\n"
            "1,1,0,0,20,1013.25,50\n1,1,1000,1000,20,1013.25,50\n"
            "2,1,0,0,20,1013.25,50\n2,1,1000,1000,20,1013.25,50\n")
    out, _ = import_positioning(write(tmp_path, text), tmp_path / "run",
                                PositioningImport(refractive_index_assumed=1.0, wavelength_nm=633.0))
    _, ev = process_run_dir(out)
    # vacuum counts: 1000 mm read means 1000/n mm in air (n = 1.000271373, NIST, 633 nm)
    assert ev.result.per_target["mean_up"].iloc[1] == pytest.approx(1e6 * (1 / 1.000271373 - 1), abs=0.002)
    assert ev.environment.applied and ev.environment.equation == "ciddor"
    assert ev.result.directions == "up"


def test_rotary_in_arcsec_with_wrap_around(tmp_path: Path) -> None:
    # target 0 read as 359.9995 deg = -1.8 arcsec; target 90 read 90.0005 = +1.8 arcsec
    text = ("run,direction,target_deg,reading_deg\n"
            "1,1,0,359.9995\n1,1,90,90.0005\n1,-1,90,90.0\n1,-1,0,0.0\n"
            "2,1,0,359.9995\n2,1,90,90.0005\n2,-1,90,90.0\n2,-1,0,0.0\n")
    out, _ = import_positioning(write(tmp_path, text), tmp_path / "run", PositioningImport(axis_type="rotary"))
    _, ev = process_run_dir(out)
    assert ev.result.unit == "arcsec" and ev.result.axis_type == "rotary"
    assert ev.result.per_target["mean_up"].tolist() == pytest.approx([-1.8, 1.8], abs=1e-6)
    assert ev.result.axis["E"] == pytest.approx(3.6, abs=1e-6)
    assert ev.to_dict()["unit"] == "arcsec"


def problems_of(tmp_path: Path, text: str, opts: PositioningImport | None = None) -> list[str]:
    with pytest.raises(ImportProblems) as info:
        import_positioning(write(tmp_path, text), tmp_path / "run", opts or PositioningImport(compensated=True))
    assert not (tmp_path / "run").exists()
    return info.value.problems


def test_bad_rows_are_reported_with_line_numbers(tmp_path: Path) -> None:
    text = ("run,direction,target_mm,reading_mm\n"
            "1,1,0,0.001\n"
            "1,2,100,100.0\n"        # line 3: direction
            "0,1,200,200.0\n"        # line 4: run
            "1,1,300,abc\n"          # line 5: reading
            "1,1,0,0.002\n"          # line 6: duplicate of line 2
            "1,1,400\n")             # line 7: field count
    probs = problems_of(tmp_path, text)
    assert len(probs) == 5
    assert probs[0].endswith(":3: direction must be +1 or -1, found '2'")
    assert ":4: run must be a positive integer" in probs[1]
    assert ":5: reading_mm must be a finite number" in probs[2]
    assert ":6: duplicate point" in probs[3] and "line 2" in probs[3]
    assert ":7: expected 4 fields, found 3" in probs[4]


def test_header_problems(tmp_path: Path) -> None:
    probs = problems_of(tmp_path, "run,direction,target_deg,reading_deg\n1,1,0,0\n")
    assert probs == [f"{tmp_path / 'data.csv'}:1: missing column(s) target_mm, reading_mm "
                     "(the file has target_deg: use --axis-type rotary)",
                     f"{tmp_path / 'data.csv'}:1: unknown column(s) target_deg, reading_deg; allowed: "
                     "run, direction, target_mm, reading_mm, time_s, stry_um, strz_um, pitch_urad, yaw_urad, "
                     "roll_urad, air_temp_c, air_pressure_hpa, humidity_pct, material_temp_c"]
    probs = problems_of(tmp_path, "run,direction,target_mm,reading_mm\n1,1,0,0\n", PositioningImport())
    assert "air_temp_c, air_pressure_hpa, humidity_pct needed to compensate" in probs[0]
    probs = problems_of(tmp_path, "run,direction,target_mm,reading_mm,air_temp_c,air_pressure_hpa,humidity_pct\n"
                                  "1,1,0,0,20,1013,50\n1,1,10,10,20,,50\n", PositioningImport())
    assert probs == [f"{tmp_path / 'data.csv'}:3: air_pressure_hpa is empty; needed to compensate the readings "
                     "(or pass --compensated)"]


def test_refuses_non_empty_out(tmp_path: Path) -> None:
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "keep").write_text("x")
    with pytest.raises(UserError, match="not empty"):
        import_positioning(write(tmp_path, GOOD), tmp_path / "run", PositioningImport(compensated=True))


def test_summary_prints_the_iso_table(tmp_path: Path) -> None:
    import io

    out, _ = import_positioning(write(tmp_path, GOOD), tmp_path / "run", PositioningImport(compensated=True))
    _, ev = process_run_dir(out)
    buf = io.StringIO()
    ev.print_summary(buf)
    text = buf.getvalue()
    assert "ISO 230-2:2014, k = 2" in text
    row = next(ln.split() for ln in text.splitlines() if ln.split()[:2] == ["2", "250.0000"])
    assert row[2:5] == ["2.000", "2.000", "0.000"]  # mean up, mean down, B_i at 250 mm
    assert any(ln.split()[:3] == ["B", "3.000", "um"] for ln in text.splitlines())
