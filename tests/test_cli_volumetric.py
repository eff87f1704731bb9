"""``guideway volumetric``: option errors are one line with exit code 2, never a traceback."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tui.cli import main

from .cli import guideway, one_line_error

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = str(ROOT / "docs" / "machine-example.toml")


@pytest.mark.parametrize(("args", "message"), [
    (["--at", "900", "0", "0", "0"], "--at X: 900 mm is outside the range of X (0 … 800 mm)"),
    (["--at", "1", "2", "3", "4", "5"], "--at: 5 values for 4 axes (X Y Z C)"),
    (["--at", "X=1", "2"], "either numbers in axis order or AXIS=VALUE pairs"),
    (["--at", "Q=1"], "no axis 'Q'; the axes are X Y Z C"),
    (["--at", "X=abc"], "'abc' is not a number (axis X)"),
    (["--at", "1", "--export", "csv", "--out", "d"], "--at and --export cannot be combined"),
    ([], "give --out DIR (grid or --export) or --at POSITIONS"),
    (["--out", "d", "--json"], "--json goes with --at"),
    (["--out", "d", "--set", "C"], "--set 'C': use AXIS=VALUE"),
    (["--out", "d", "--set", "C=400"], "--set C=400: 400 deg is outside the range of C"),
    (["--out", "d", "--grid", "1"], "--grid 1: need at least 2 points per axis"),
    (["--out", "d", "--grid", "2000"], "the limit is 2000000, use a smaller --grid"),
    (["--out", "d", "--set", "X=1", "--set", "Y=1", "--set", "Z=-1", "--set", "C=0"], "every axis is fixed"),
    (["--at", "X=1", "X=2"], "--at: axis X is given twice"),
    (["--at", "1", "--out", "d"], "--at prints one pose; --out goes with the grid or --export"),
    (["--at", "1", "--set", "X=1"], "--at prints one pose; --set goes with the grid or --export"),
    (["--at", "1", "--time-h", "nan"], "--time-h nan: give a finite number"),
    (["--out", "d", "--temperature-c", "inf"], "--temperature-c inf: give a finite number"),
])
def test_bad_options_are_one_line_errors(args: list[str], message: str, capsys: pytest.CaptureFixture[str],
                                         tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["volumetric", EXAMPLE, *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("guideway: error: ") and message in err and err.count("\n") == 1


def test_missing_machine_file_and_traceback_free_failure(tmp_path: Path) -> None:
    res = guideway("volumetric", tmp_path / "none.toml", "--at", "0")
    assert one_line_error(res) == f"guideway: error: {tmp_path / 'none.toml'}: no such machine file"


def test_grid_over_the_rotary_axis_when_every_prismatic_axis_is_held(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "c"
    assert main(["volumetric", EXAMPLE, "--out", str(out), "--grid", "5", "--set", "X=400", "--set", "Y=250",
                 "--set", "Z=-100"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["grid"]["gridded_axes"] == ["C"] and summary["grid"]["poses"] == 5
    assert summary["grid"]["fixed"] == {"X": 400.0, "Y": 250.0, "Z": -100.0}
    assert "along C" in (out / "report.html").read_text()  # one gridded axis: the components along it
    table = (out / "volumetric.csv").read_text().splitlines()
    assert table[0].startswith("X_mm,Y_mm,Z_mm,C_deg,") and [r.split(",")[3] for r in table[1:]] == [
        "0.000000", "90.000000", "180.000000", "270.000000", "360.000000"]


def test_at_accepts_named_axes_and_keeps_the_others_at_their_reference(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["volumetric", EXAMPLE, "--at", "C=90", "Y=100", "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["pose"] == {"X": 0.0, "Y": 100.0, "Z": 0.0, "C": 90.0}
    assert obj["units"] == {"X": "mm", "Y": "mm", "Z": "mm", "C": "deg"}
    assert main(["volumetric", EXAMPLE, "--at", "0", "100", "0", "90", "--json", "--exact"]) == 0
    exact = json.loads(capsys.readouterr().out)
    assert exact["method"] == "exact" and set(exact["first_order"]) == set(exact["error"])
    assert exact["error"]["d_um"] == pytest.approx(obj["error"]["d_um"], abs=1e-3)
