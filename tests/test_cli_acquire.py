"""`guideway acquire straightness`: the plain-terminal operator end to end,
abort then resume, a recovered device fault, and one-line errors (in this
process: ``tests.cli.guideway``; ``setup_file`` is in conftest.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from saved_runs.store.reader import load_run

from .cli import ROOT, guideway, one_line_error


def test_terminal_operator_skip_abort_then_resume(tmp_path: Path, setup_file: Path) -> None:
    out = tmp_path / "run"
    # datum: Enter; station 1: Enter (capture); station 2: "s" (skip); station 3: "a" (abort)
    res = guideway("acquire", "straightness", "--setup", str(setup_file), "--out", str(out), "--simulate",
                   stdin="\n\ns\na\n")
    assert res.returncode == 1 and f"guideway acquire --resume {out}" in res.stderr
    assert "Move the block to station 2 (x = 200 mm), against the side face" in res.stdout
    assert "[capture/redo/skip/pause/abort]" in res.stdout
    run = load_run(out)
    assert run.meta["status"] == "aborted" and run.points["station"].tolist() == [0, 1]
    assert [s["station"] for s in run.meta["skipped"]] == [2]
    res = guideway("acquire", "--resume", str(out), "--simulate", "--auto")  # the kind is read from the run
    assert res.returncode == 0, res.stderr
    run = load_run(out)
    assert run.meta["status"] == "complete" and run.points["station"].tolist() == [0, 1, 3, 4, 5]
    assert [s["station"] for s in run.meta["skipped"]] == [2]


def test_a_dropped_sensor_reply_pauses_and_the_run_recovers(tmp_path: Path, setup_file: Path) -> None:
    out = tmp_path / "run"
    res = guideway("acquire", "straightness", "--setup", str(setup_file), "--out", str(out), "--simulate",
                   "--auto", "--faults", "sensor:drop@6x1")
    assert res.returncode == 0, res.stderr
    assert "device fault: displacement sensor" in res.stdout and "devices reconnected" in res.stdout
    run = load_run(out)
    assert run.meta["status"] == "complete" and run.points["station"].tolist() == list(range(6))
    assert len(run.meta["faults"]) == 1 and "displacement sensor" in run.meta["faults"][0]


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (("--out", "{tmp}/r"), ("needs --setup",)),
        (("--setup", "{setup}", "--out", "{tmp}/r", "--faults", "sensor:drop@1"), ("--faults needs --simulate",)),
        (("--setup", "{setup}", "--out", "{tmp}/r"), ("/dev/ttyUSB0", "check the port name")),
        (("--out", "{tmp}/none", "--resume"), ("no such run directory",)),
        (("--resume",), ("give the run directory",)),
        (("--setup", "{tmp}/missing.toml", "--out", "{tmp}/r"), ("no such setup file",)),
    ],
)
def test_acquire_errors_are_one_line(tmp_path: Path, setup_file: Path, args, fragments) -> None:
    argv = [a.format(tmp=tmp_path, setup=setup_file) for a in args]
    one_line_error(guideway("acquire", "straightness", *argv), *fragments)
    assert not (tmp_path / "r").exists()  # a run that never started leaves no empty directory


def test_positioning_gcode_and_simulated_run(tmp_path: Path) -> None:
    text = (ROOT / "docs" / "setup-positioning.toml").read_text()
    text = text.replace("end_mm = 1000.0", "end_mm = 400.0").replace("runs = 5 ", "runs = 2 ")
    setup = tmp_path / "pos.toml"
    setup.write_text(text)
    prog = tmp_path / "cycle.ngc"
    res = guideway("gcode", "--setup", str(setup), "--out", str(prog), "--dialect", "linuxcnc")
    assert res.returncode == 0, res.stderr
    program = prog.read_text()
    assert program.rstrip().endswith("M2") and program.count("M66 P0 L3") == 2 * 2 * 5
    res = guideway("acquire", "positioning", "--setup", str(setup), "--out", str(tmp_path / "run"), "--simulate",
                   "--auto")
    assert res.returncode == 0, res.stderr
    run = load_run(tmp_path / "run")
    assert run.meta["kind"] == "positioning" and len(run.points) == 20 and run.meta["status"] == "complete"


def test_wrong_setup_kind_is_a_one_line_error(tmp_path: Path) -> None:
    one_line_error(guideway("acquire", "positioning", "--setup", str(ROOT / "docs" / "setup-straightness.toml"),
                            "--out", str(tmp_path / "r"), "--simulate"), "needs a positioning setup")
    one_line_error(guideway("gcode", "--setup", str(ROOT / "docs" / "setup-straightness.toml")),
                   "needs a positioning setup")
