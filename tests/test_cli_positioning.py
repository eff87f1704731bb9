"""CLI of the positioning features: guideway import positioning, process --json on a
positioning run, air-index --json; bad input gives line-numbered errors and exit 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tui.cli import main

from .cli import ROOT, guideway, one_line_error

CSV = """run,direction,target_mm,reading_mm,air_temp_c,air_pressure_hpa,humidity_pct,material_temp_c
1,+1,0,0.0,20,1013.25,50,20.5
1,+1,100,100.0012,20,1013.25,50,20.5
1,-1,100,100.0022,20,1013.25,50,20.5
1,-1,0,0.0011,20,1013.25,50,20.5
2,+1,0,0.0002,20,1013.25,50,20.5
2,+1,100,100.0013,20,1013.25,50,20.5
2,-1,100,100.0021,20,1013.25,50,20.5
2,-1,0,0.0010,20,1013.25,50,20.5
"""


def test_import_then_process_json(tmp_path: Path) -> None:
    data = tmp_path / "pos.csv"
    data.write_text(CSV)
    out = tmp_path / "run"
    res = guideway("import", "positioning", str(data), "--out", str(out), "--index-assumed", "1.000271373",
                   "--expansion-ppm-per-k", "11.5", "--wavelength-nm", "633")
    assert res.returncode == 0, res.stderr
    assert "imported 8 point(s)" in res.stdout
    res = guideway("process", str(out), "--json", "--plot")
    assert res.returncode == 0, res.stderr
    obj = json.loads(res.stdout)
    assert obj["kind"] == "positioning" and obj["axis_type"] == "linear" and obj["unit"] == "um"
    assert set(obj["iso230_2"]) == {"B", "B_mean", "R_up", "R_down", "R", "E_up", "E_down", "E", "M",
                                    "A_up", "A_down", "A"}
    assert [t["target_index"] for t in obj["targets"]] == [1, 2]
    assert set(obj["vdi3441"]) >= {"P", "Pa", "Ps_max", "U_max"}
    env = obj["environment"]
    assert env["applied"] and env["equation"] == "ciddor" and env["expansion_ppm_per_k"] == 11.5
    # index ~ assumed one, material 0.5 K warm: 100 mm normalised = reading / (1 + 11.5e-6 * 0.5)
    t2 = obj["targets"][1]
    expected_up = ((100.00125 / (1 + 11.5e-6 * 0.5)) - 100) * 1000
    assert t2["mean_up"] == pytest.approx(expected_up, abs=0.002)
    # B_i: (0.1 - 1.05) = -0.95 at 0 mm, (1.25 - 2.15) = -0.9 at 100 mm
    assert obj["iso230_2"]["B"] == pytest.approx(0.95, abs=0.002)
    assert (out / "results" / "positioning.png").is_file()
    assert (out / "results" / "positioning.csv").is_file()


def test_bad_csv_lists_each_problem_with_its_line(tmp_path: Path) -> None:
    data = tmp_path / "bad.csv"
    data.write_text("run,direction,target_mm,reading_mm\n1,1,0,0\n1,0,5,5\n1,1,x,10\n")
    res = guideway("import", "positioning", str(data), "--out", str(tmp_path / "run"), "--compensated")
    assert res.returncode == 2 and "Traceback" not in res.stderr
    lines = res.stderr.splitlines()
    assert lines == [f"guideway: error: {data}:3: direction must be +1 or -1, found '0'",
                     f"guideway: error: {data}:4: target_mm must be a finite number, found 'x'"]
    assert not (tmp_path / "run").exists()


def test_air_index_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["air-index", "--t-c", "20", "--p-pa", "101325", "--rh", "50", "--wavelength-nm", "633",
                 "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert abs(obj["n"] - 1.000271373) < 1e-9 and obj["equation"] == "ciddor"
    assert main(["air-index", "--t-c", "20", "--p-pa", "101325", "--rh", "50", "--wavelength-nm", "633",
                 "--equation", "edlen", "--json"]) == 0
    assert abs(json.loads(capsys.readouterr().out)["n"] - 1.000271374) < 1e-9


def test_air_index_subprocess_prints_one_object() -> None:
    # The installed console script (pyproject [project.scripts]) as a separate process: the one smoke
    # test of the entry point and of the exit code reaching the shell; every other test runs main().
    script = Path(sys.executable).with_name("guideway")
    assert script.is_file(), f"no console script {script}: install the tool (pip install -e .)"
    res = subprocess.run([script, "air-index", "--t-c", "20", "--p-pa", "101325", "--rh", "50", "--json"],
                         cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert isinstance(json.loads(res.stdout)["n"], float)
    res = subprocess.run([script, "air-index", "--t-c", "20", "--p-pa", "1013.25", "--rh", "50"],
                         cwd=ROOT, capture_output=True, text=True, timeout=60)
    one_line_error(res, "--p-pa", "outside the range")


def test_air_index_out_of_range() -> None:
    one_line_error(guideway("air-index", "--t-c", "20", "--p-pa", "1013.25", "--rh", "50"),
                   "--p-pa", "outside the range")


def test_process_positioning_without_assumed_index(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "pos.csv"
    data.write_text(CSV)
    out = tmp_path / "run"
    assert main(["import", "positioning", str(data), "--out", str(out)]) == 0
    meta = json.loads((out / "run.json").read_text())
    del meta["setup"]["environment"]["refractive_index_assumed"]
    (out / "run.json").write_text(json.dumps(meta))
    capsys.readouterr()
    assert main(["process", str(out), "--no-write"]) == 2
    err = capsys.readouterr().err
    assert "refractive_index_assumed is missing" in err and len(err.strip().splitlines()) == 1


def test_process_positioning_coverage_factor_edition_and_wrong_option(tmp_path: Path) -> None:
    data = tmp_path / "pos.csv"
    data.write_text(CSV)
    out = tmp_path / "run"
    assert guideway("import", "positioning", str(data), "--out", str(out), "--compensated").returncode == 0
    k2 = json.loads(guideway("process", str(out), "--json", "--no-write").stdout)
    res = guideway("process", str(out), "--json", "--no-write", "--k", "3", "--edition", "ISO 230-2:2006")
    assert res.returncode == 0, res.stderr
    k3 = json.loads(res.stdout)
    # R_up = max_i 2 k s_i(up): proportional to k; the means do not depend on k.
    assert k3["iso230_2"]["R_up"] == pytest.approx(1.5 * k2["iso230_2"]["R_up"], rel=1e-12)
    assert k3["iso230_2"]["E"] == pytest.approx(k2["iso230_2"]["E"], rel=1e-12)
    assert "ISO 230-2:2006" in json.dumps(k3)
    one_line_error(guideway("process", str(out), "--method", "exact"), "--method", "not an option for positioning")
    one_line_error(guideway("process", str(out), "--k", "0"), "--k must be a positive")
