"""Values outside the set-up's validation limits: ``process`` refuses the run with one line
naming the point and the column; ``--accept-out-of-range`` evaluates it, lists the values in
the results and marks them in the report.  Files are umask-mode like any file the user writes."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from tests.test_export_end_to_end import write_run
from tui.cli import main

V1_RUN = Path(__file__).resolve().parent / "data" / "runs" / "v1-straightness"


def straightness_run(tmp_path: Path, station: int, column: str, value: str) -> Path:
    run = tmp_path / "run"
    shutil.copytree(V1_RUN, run)
    lines = (run / "points.csv").read_text(encoding="utf-8").splitlines()
    header = lines[0].split(",")
    cells = lines[station + 1].split(",")
    cells[header.index(column)] = value
    lines[station + 1] = ",".join(cells)
    (run / "points.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return run


def one_line_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("guideway: error: ")
    return err


def test_a_sensor_value_of_1e9_is_refused_naming_station_and_column(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    run = straightness_run(tmp_path, 5, "sensor_mm", "1e9")
    err = one_line_error(capsys, ["process", str(run), "--mc-trials", "0"])
    assert "station 5: sensor_mm = 1e+09 outside [-50, 50] mm" in err and "--accept-out-of-range" in err
    assert not (run / "results").exists()
    one_line_error(capsys, ["report", str(run), "--mc-trials", "0"])


def test_angles_and_straightness_use_the_setup_limits(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = straightness_run(tmp_path, 3, "pitch_urad", "-6000")  # default max_angle_urad = 5000
    assert "station 3: pitch_urad = -6000 outside [-5000, 5000] urad" in one_line_error(capsys, ["process", str(run)])
    meta = json.loads((run / "run.json").read_text(encoding="utf-8"))
    meta["setup"]["validation"] = {"max_angle_urad": 8000.0, "max_straightness_um": 0.5}
    (run / "run.json").write_text(json.dumps(meta), encoding="utf-8")
    err = one_line_error(capsys, ["process", str(run)])  # the pitch is fine now; stry of station 1 (0.898) is not
    assert "station 1: stry_um = 0.897715 outside [-0.5, 0.5] um" in err and "values out of range" in err


def test_accepted_values_are_listed_and_marked(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = straightness_run(tmp_path, 5, "sensor_mm", "1e9")
    old = os.umask(0o027)
    try:
        assert main(["process", str(run), "--json", "--mc-trials", "0", "--accept-out-of-range"]) == 0
        out = json.loads(capsys.readouterr().out)
        assert out["out_of_range_accepted"] == [{"where": "station 5", "column": "sensor_mm", "value": 1e9,
                                                 "limit": "[-50, 50] mm"}]
        assert main(["report", str(run), "--mc-trials", "0", "--accept-out-of-range"]) == 0
    finally:
        os.umask(old)
    html = (run / "results" / "report.html").read_text(encoding="utf-8")
    assert "outside the set-up&#x27;s validation limits were evaluated anyway" in html
    assert "--accept-out-of-range" in html.split("Produced by")[1]  # the command that reproduces it
    for name in ("report.html", "summary.json", "profile.csv", "profile.png"):
        assert (run / "results" / name).stat().st_mode & 0o777 == 0o640, name


def test_a_positioning_reading_far_from_its_target_is_refused(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    write_run(tmp_path / "run")
    pts = tmp_path / "run" / "points.csv"
    lines = pts.read_text(encoding="utf-8").splitlines()
    cells = lines[3].split(",")  # run 1, up, target 3 (198 mm)
    cells[4] = "203.5"  # 5.5 mm from its target; default max_deviation_mm = 1
    lines[3] = ",".join(cells)
    pts.write_text("\n".join(lines) + "\n", encoding="utf-8")
    err = one_line_error(capsys, ["process", str(tmp_path / "run")])
    assert "target 3 (198 mm), run 1 up (+): reading_mm = 203.5 outside +/-1 mm of its target" in err
    one_line_error(capsys, ["export", str(tmp_path / "run"), "--format", "csv"])
    assert main(["export", str(tmp_path / "run"), "--format", "csv", "--accept-out-of-range"]) == 0
