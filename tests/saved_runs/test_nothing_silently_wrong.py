"""Nothing silently wrong (docs/reliability.md): a run whose points the plan cannot have produced is
refused with one line naming the file, the line and the column (exit 2); a run with a gap is evaluated
with the gap stated and no PASS; a set-up value that would make every result wrong is refused; a
killed import leaves no run behind.  One test per case of issue 18; each damages a known-good run in
one place and derives the expected line and value from what it changed."""

from __future__ import annotations

import json
import math
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from saved_runs.catalog.folder import list_runs
from saved_runs.store.reader import load_run

from ..cli import ROOT, guideway, one_line_error

V1_RUN = ROOT / "tests" / "data" / "runs" / "v1-straightness"  # 8 stations, L = 100 mm, complete


def _copy_v1(tmp_path: Path) -> Path:
    run = tmp_path / "run"
    shutil.copytree(V1_RUN, run)
    shutil.rmtree(run / "results", ignore_errors=True)
    return run


def _rows(run: Path) -> list[list[str]]:
    return [line.split(",") for line in (run / "points.csv").read_text().splitlines()]


def _write_rows(run: Path, rows: list[list[str]]) -> None:
    (run / "points.csv").write_text("".join(",".join(r) + "\n" for r in rows))


def _set_meta(run: Path, **setup: object) -> None:
    meta = json.loads((run / "run.json").read_text())
    meta["setup"].update(setup)
    (run / "run.json").write_text(json.dumps(meta))


def test_x_far_from_its_station_is_refused(tmp_path: Path) -> None:
    run = _copy_v1(tmp_path)
    rows = _rows(run)
    header = rows[0]
    k = 3
    data_row = next(i for i, r in enumerate(rows) if i and r[header.index("station")] == str(k))
    rows[data_row][header.index("x_mm")] = repr(k * 100.0 + 12_000.0)  # 12 m off
    _write_rows(run, rows)
    # station 3 of a 100 mm block lies at 3 x 100 = 300 mm; the damaged value is on file line data_row + 1
    one_line_error(guideway("process", run, "--no-write"), f"points.csv:{data_row + 1}", "x_mm", "12300",
                   "300 mm")


def test_a_missing_station_is_stated_and_never_passes(tmp_path: Path) -> None:
    run = _copy_v1(tmp_path)
    _set_meta(run, tolerance={"straightness_um": 1000.0, "reference_line": "minimum_zone"})
    whole = guideway("process", run, "--json", "--no-write", "--mc-trials", "0")
    assert whole.returncode == 0 and json.loads(whole.stdout)["verdict"]["result"] == "pass"  # 1 mm: passes
    rows = _rows(run)
    missing = 4
    _write_rows(run, [r for r in rows if r[0] != str(missing)])
    res = guideway("process", run, "--json", "--no-write", "--mc-trials", "0")
    assert res.returncode == 0, res.stderr
    obj = json.loads(res.stdout)
    assert obj["verdict"]["result"] != "pass"
    assert f"station {missing} " in obj["verdict"]["incomplete"]
    assert obj["missing_steps"]["steps"] == [{"pass": 0, "station": missing}]
    text = guideway("process", run, "--no-write", "--mc-trials", "0")
    assert text.returncode == 0 and f"station {missing} not measured" in text.stdout
    assert "verdict: NOT EVALUATED" in text.stdout
    report = tmp_path / "report.html"
    assert guideway("report", run, "--out", report, "--mc-trials", "0").returncode == 0
    assert f"Run incomplete: station {missing} not measured" in report.read_text()


@pytest.mark.parametrize("station", [-3, 900])
def test_a_station_outside_the_plan_is_refused(tmp_path: Path, station: int) -> None:
    run = _copy_v1(tmp_path)
    rows = _rows(run)
    rows[3][0] = str(station)
    rows[3][1] = repr(station * 100.0)  # at its own nominal position: only the station number is wrong
    _write_rows(run, rows)
    one_line_error(guideway("process", run, "--no-write"), "points.csv:4", f"station = {station}",
                   "stations 0 to 7")


@pytest.fixture(scope="module")
def demo_v2(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A complete 6-station noise-free demo run (format version 2, resumable once marked in progress)."""
    out = tmp_path_factory.mktemp("demo") / "run"
    res = guideway("demo", "--out", out, "--stations", "6", "--samples", "1", "--no-noise", "--seed", "3")
    assert res.returncode == 0, res.stderr
    return out


def test_more_points_than_planned_are_not_resumed(tmp_path: Path, demo_v2: Path) -> None:
    run = tmp_path / "run"
    shutil.copytree(demo_v2, run)
    meta = json.loads((run / "run.json").read_text())
    meta["status"] = "in-progress"
    (run / "run.json").write_text(json.dumps(meta))
    rows = _rows(run)
    rows.append(list(rows[-1]))  # station 5 on disk a second time: 7 points for a 6-station plan
    _write_rows(run, rows)
    res = guideway("acquire", "--resume", run, "--simulate", "--auto", "--no-noise")
    one_line_error(res, f"points.csv:{len(rows)}", "station = 5", "twice", f"line {len(rows) - 1}")
    assert json.loads((run / "run.json").read_text())["status"] == "in-progress"  # not marked complete


@pytest.fixture()
def positioning_run(tmp_path: Path) -> Path:
    """An imported positioning run: 5 targets, one run up and down, compensated readings."""
    targets = [0.0, 100.0, 200.0, 300.0, 400.0]
    lines = ["run,direction,target_mm,reading_mm"]
    for d in (1, -1):
        for t in (targets if d == 1 else targets[::-1]):
            lines.append(f"1,{d},{t},{t + 0.001 * d}")
    data = tmp_path / "pos.csv"
    data.write_text("\n".join(lines) + "\n")
    out = tmp_path / "pos"
    res = guideway("import", "positioning", data, "--out", out, "--compensated")
    assert res.returncode == 0, res.stderr
    return out


def test_a_target_index_outside_the_setup_is_refused(positioning_run: Path) -> None:
    rows = _rows(positioning_run)
    header = rows[0]
    assert len(json.loads((positioning_run / "run.json").read_text())["setup"]["targets_mm"]) == 5
    rows[2][header.index("target_index")] = "6"  # a phantom sixth target
    rows[2][header.index("target_mm")] = "500.0"
    rows[2][header.index("reading_mm")] = "500.001"  # a plausible reading of it: only the index gives it away
    _write_rows(positioning_run, rows)
    one_line_error(guideway("process", positioning_run, "--no-write"), "points.csv:3", "target_index = 6",
                   "targets 1 to 5")


@pytest.mark.parametrize("length", [0, -100, "100mm", math.nan])
def test_a_bad_block_length_is_refused(tmp_path: Path, length: object) -> None:
    run = _copy_v1(tmp_path)
    _set_meta(run, block_length_mm=length)
    one_line_error(guideway("process", run, "--no-write"), "run.json", "setup.block_length_mm",
                   "must be a positive number")


def _positioning_setup(tmp_path: Path, old: str, new: str) -> Path:
    text = (ROOT / "docs" / "setup-positioning.toml").read_text()
    assert text.count(old) == 1
    setup = tmp_path / "pos.toml"
    setup.write_text(text.replace(old, new))
    return setup


def test_a_negative_wavelength_in_a_setup_is_refused(tmp_path: Path) -> None:
    setup = _positioning_setup(tmp_path, "wavelength_nm = 632.991", "wavelength_nm = -632.991")
    one_line_error(guideway("acquire", "positioning", "--setup", setup, "--out", tmp_path / "r", "--simulate"),
                   str(setup), "[environment] wavelength_nm", "-632.991")
    assert not (tmp_path / "r").exists()


def test_a_negative_wavelength_in_a_run_is_refused(positioning_run: Path) -> None:
    meta = json.loads((positioning_run / "run.json").read_text())
    meta["setup"]["environment"]["wavelength_nm"] = -632.991
    (positioning_run / "run.json").write_text(json.dumps(meta))
    one_line_error(guideway("process", positioning_run, "--no-write"), "run.json", "wavelength_nm", "-632.991")


def test_a_zero_max_deviation_is_refused_at_setup(tmp_path: Path) -> None:
    setup = _positioning_setup(tmp_path, "max_deviation_mm = 1.0 ", "max_deviation_mm = 0 ")
    one_line_error(guideway("acquire", "positioning", "--setup", setup, "--out", tmp_path / "r", "--simulate"),
                   str(setup), "max_deviation_mm", "positive")


KILLED_IMPORT = """
import os, signal, sys
from saved_runs.store import writer
from tui.cli import main

def killed(self, doc):  # the process dies as the run would be marked complete
    os.kill(os.getpid(), signal.SIGKILL)

writer.RunStore._stop = killed
main(sys.argv[1:])
"""


def test_a_killed_import_leaves_no_run(tmp_path: Path) -> None:
    data = tmp_path / "pos.csv"
    data.write_text("run,direction,target_mm,reading_mm\n" + "".join(
        f"1,{d},{t},{t}\n" for d in (1, -1) for t in (0.0, 100.0, 200.0, 300.0, 400.0)))
    out = tmp_path / "run"
    shutil.copytree(V1_RUN, tmp_path / "ref")  # a run next to it, which the runs browser lists
    killed = subprocess.run([sys.executable, "-c", KILLED_IMPORT, "import", "positioning", str(data), "--out",
                             str(out), "--compensated"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    assert not out.exists()  # nothing that process could take for a crashed measurement
    one_line_error(guideway("process", out, "--no-write"), "no such run directory")
    partial = list(tmp_path.glob(".run.*.partial"))
    assert len(partial) == 1
    assert [r.path for r in list_runs(tmp_path)] == [tmp_path / "ref"]  # the runs browser does not offer it
    res = guideway("import", "positioning", data, "--out", out, "--compensated")
    assert res.returncode == 0, res.stderr
    assert len(load_run(out).points) == 10 and load_run(out).meta["status"] == "complete"
    assert not list(tmp_path.glob(".run.*.partial"))  # the next import removed the dead one's leftovers
