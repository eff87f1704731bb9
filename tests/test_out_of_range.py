"""Values outside the set-up's validation limits: ``process`` refuses the run with one line
naming the point and the column; ``--accept-out-of-range`` evaluates it, lists the values in
the results and marks them in the report.  Files are umask-mode like any file the user writes."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from tests.cli import guideway, one_line_error
from tests.test_export_end_to_end import write_run

V1_RUN = Path(__file__).resolve().parent / "data" / "runs" / "v1-straightness"


def straightness_run(tmp_path: Path, station: int, column: str, value: str) -> Path:
    run = tmp_path / "run"
    shutil.copytree(V1_RUN, run)
    set_cell(run, station + 1, column, value)  # row 1 is station 0
    return run


def test_a_sensor_value_of_1e9_is_refused_naming_station_and_column(tmp_path: Path) -> None:
    run = straightness_run(tmp_path, 5, "sensor_mm", "1e9")
    one_line_error(guideway("process", run, "--mc-trials", "0"),
                   "station 5: sensor_mm = 1e+09 outside [-50, 50] mm", "--accept-out-of-range")
    assert not (run / "results").exists()
    one_line_error(guideway("report", run, "--mc-trials", "0"))


def test_angles_and_straightness_use_the_setup_limits(tmp_path: Path) -> None:
    run = straightness_run(tmp_path, 3, "pitch_urad", "-6000")  # default max_angle_urad = 5000
    one_line_error(guideway("process", run), "station 3: pitch_urad = -6000 outside [-5000, 5000] urad")
    meta = json.loads((run / "run.json").read_text(encoding="utf-8"))
    meta["setup"]["validation"] = {"max_angle_urad": 8000.0, "max_straightness_um": 0.5}
    (run / "run.json").write_text(json.dumps(meta), encoding="utf-8")
    # the pitch is fine now; stry of station 1 (0.898) is not
    one_line_error(guideway("process", run), "station 1: stry_um = 0.897715 outside [-0.5, 0.5] um",
                   "values out of range")


def test_accepted_values_are_listed_and_marked(tmp_path: Path) -> None:
    run = straightness_run(tmp_path, 5, "sensor_mm", "1e9")
    old = os.umask(0o027)
    try:
        res = guideway("process", run, "--json", "--mc-trials", "0", "--accept-out-of-range", "--plot")
        assert res.returncode == 0, res.stderr
        assert json.loads(res.stdout)["out_of_range_accepted"] == [
            {"where": "station 5", "column": "sensor_mm", "value": 1e9, "limit": "[-50, 50] mm"}]
        assert guideway("report", run, "--mc-trials", "0", "--accept-out-of-range").returncode == 0
    finally:
        os.umask(old)
    html = (run / "results" / "report.html").read_text(encoding="utf-8")
    assert "outside the set-up&#x27;s validation limits were evaluated anyway" in html
    assert "--accept-out-of-range" in html.split("Produced by")[1]  # the command that reproduces it
    for name in ("report.html", "summary.json", "profile.csv", "profile.png"):
        assert (run / "results" / name).stat().st_mode & 0o777 == 0o640, name


def set_cell(run: Path, row: int, column: str, value: str) -> None:
    """points.csv data row ``row`` (1 = the first after the header): ``column`` = ``value``."""
    pts = run / "points.csv"
    lines = pts.read_text(encoding="utf-8").splitlines()
    cells = lines[row].split(",")
    cells[lines[0].split(",").index(column)] = value
    lines[row] = ",".join(cells)
    pts.write_text("\n".join(lines) + "\n", encoding="utf-8")


def test_a_positioning_reading_far_from_its_target_is_refused(tmp_path: Path) -> None:
    write_run(tmp_path / "run")
    set_cell(tmp_path / "run", 3, "reading_mm", "203.5")  # run 1, up, target 3 (198 mm): 5.5 mm off, limit 1 mm
    one_line_error(guideway("process", tmp_path / "run"),
                   "target 3 (198 mm), run 1 up (+): reading_mm = 203.5 outside +/-1 mm of its target")
    one_line_error(guideway("export", tmp_path / "run", "--format", "csv"))
    assert guideway("export", tmp_path / "run", "--format", "csv", "--accept-out-of-range").returncode == 0


def compensated_run(tmp_path: Path) -> Path:
    """The positioning run of write_run with raw readings (the air index and the material
    temperature are applied when it is evaluated)."""
    run = tmp_path / "run"
    write_run(run)
    meta = json.loads((run / "run.json").read_text(encoding="utf-8"))
    meta["setup"]["environment"]["readings_compensated"] = False
    (run / "run.json").write_text(json.dumps(meta), encoding="utf-8")
    return run


@pytest.mark.parametrize(("column", "value", "limit"), [
    # the ranges the air-index equations are stated for (NIST, Ciddor 1996: -40 to 100 C, 10 to 140 kPa,
    # 0 to 100 %RH), which `guideway air-index` enforces too; the material temperature within the same range
    ("humidity_pct", "1e9", "[0, 100] %RH"),
    ("air_temp_c", "150", "[-40, 100] C"),
    ("air_pressure_hpa", "10132.5", "[100, 1400] hPa"),  # Pa written as hPa x 10
    ("material_temp_c", "2000", "[-40, 100] C"),
])
def test_environment_values_the_compensation_cannot_use_are_refused(tmp_path: Path, column: str, value: str,
                                                                     limit: str) -> None:
    # a humidity of 1e9 %RH was evaluated: A came out at metres, exit 0
    run = compensated_run(tmp_path)
    assert guideway("process", run, "--json").returncode == 0  # the same run with its recorded values is fine
    set_cell(run, 4, column, value)  # run 1, up, target 4 (302.5 mm)
    one_line_error(guideway("process", run), f"target 4 (302.5 mm), run 1 up (+): {column} = {float(value):g} "
                   f"outside {limit}", "--accept-out-of-range")
    res = guideway("process", run, "--json", "--accept-out-of-range")
    assert res.returncode == 0, res.stderr
    assert [(a["column"], a["value"]) for a in json.loads(res.stdout)["out_of_range_accepted"]] == [
        (column, float(value))]


def test_diagnose_refuses_what_process_refuses(tmp_path: Path) -> None:
    # diagnose took the deviations without the limits: a humidity of 1e9 %RH became a "physical effect"
    run = compensated_run(tmp_path)
    set_cell(run, 4, "humidity_pct", "1e9")
    one_line_error(guideway("diagnose", run), "target 4 (302.5 mm), run 1 up (+): humidity_pct = 1e+09 outside "
                   "[0, 100] %RH", "--accept-out-of-range")
    res = guideway("diagnose", run, "--json", "--accept-out-of-range")
    assert res.returncode == 0, res.stderr
    assert any("humidity_pct = 1e+09" in n for n in json.loads(res.stdout)["notes"])


def test_environment_values_are_not_checked_where_they_are_not_used(tmp_path: Path) -> None:
    run = tmp_path / "run"
    write_run(run)  # readings_compensated = true: the air values are only recorded
    set_cell(run, 4, "humidity_pct", "1e9")
    assert guideway("process", run).returncode == 0
