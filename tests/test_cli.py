"""The command line: one JSON object with --json, one-line errors with exit
code 2, and a run killed with SIGKILL mid-capture stays processable.

Commands run in this process (``tests.cli.guideway``); only the killed run is a
separate process (being killed is the point)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from saved_runs.store.reader import load_run
from tui.cli import main

from .cli import guideway, kill_when, one_line_error
from .waiting import line_count


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cli") / "run"
    res = guideway("demo", "--out", str(out), "--stations", "6", "--seed", "3")
    assert res.returncode == 0, res.stderr
    assert "straightness (least squares reference line)" in res.stdout
    return out


def test_process_json_prints_exactly_one_object(demo_run: Path) -> None:
    res = guideway("process", str(demo_run), "--json", "--no-write")
    assert res.returncode == 0, res.stderr
    obj = json.loads(res.stdout)  # fails if anything else is printed
    assert obj["kind"] == "straightness"
    assert [p["station"] for p in obj["profile"]] == list(range(6))
    assert obj["profile"][0] == {"station": 0, "x_mm": 0.0, "height_um": 0.0}
    assert set(obj["straightness_um"]) >= {"endpoint", "least_squares"}
    assert obj["straightness_um"]["endpoint"] > 0


def test_missing_run_directory(tmp_path: Path) -> None:
    one_line_error(guideway("process", str(tmp_path / "nope")), "no such run directory")


def test_malformed_run_directory(tmp_path: Path) -> None:
    (tmp_path / "run.json").write_text("{")
    one_line_error(guideway("process", str(tmp_path)), "run.json", "not valid JSON")


def test_results_that_cannot_be_written_are_a_one_line_error(demo_run: Path, tmp_path: Path) -> None:
    # RUN/results is a file (as good as a full disk or a read-only share): one line naming it, no traceback
    import shutil

    straightness = tmp_path / "straightness"
    shutil.copytree(demo_run, straightness, ignore=shutil.ignore_patterns("results"))
    positioning = tmp_path / "positioning"
    shutil.copytree(Path(__file__).parent / "data" / "tui-runs" / "positioning-x", positioning)
    for run in (straightness, positioning):
        (run / "results").write_text("not a folder\n")
    one_line_error(guideway("process", straightness), str(straightness / "results"))
    one_line_error(guideway("export", positioning, "--format", "csv"), str(positioning / "results"))


def test_usage_errors_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["demo", "--stations", "many"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("guideway: error: argument --stations: a whole number is needed")
    assert "guideway demo --help" in err


def test_demo_refuses_non_empty_out(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "x").write_text("keep")
    assert main(["demo", "--out", str(tmp_path), "--stations", "3"]) == 2
    assert "not empty" in capsys.readouterr().err
    assert (tmp_path / "x").read_text() == "keep"


def test_killed_run_keeps_every_written_point(tmp_path: Path) -> None:
    out = tmp_path / "run"
    # a separate process, killed; its temporary files (the sensor link) go to a TMPDIR this test owns
    kill_when(lambda: line_count(out / "points.csv") > 8, "demo", "--out", out, "--stations", "500", "--samples", "1",
              tmp_dir=tmp_path / "tmp", what="the demo to write points")
    run = load_run(out)
    assert run.meta["status"] == "in-progress"
    n = len(run.points)
    assert n >= 8 and run.points["station"].tolist() == list(range(n))
    res = guideway("process", str(out), "--json", "--no-write")
    assert res.returncode == 0 and "in-progress" in res.stderr
    assert len(json.loads(res.stdout)["profile"]) == n


@pytest.mark.parametrize(
    ("faults", "fragments"),
    [
        ("sensor:garbage@6", ("displacement sensor", "non-ASCII bytes")),
        ("sensor:error@6=22", ("displacement sensor", "Invalid parameter error")),
        ("controller:freeze-seq@12", ("trigger not completed", "sequence")),
    ],
)
def test_misbehaving_device_one_line_error_and_points_kept(tmp_path: Path, faults: str, fragments) -> None:
    out = tmp_path / "run"
    res = guideway("demo", "--out", str(out), "--stations", "8", "--samples", "2", "--faults", faults)
    one_line_error(res, *fragments)
    run = load_run(out)
    assert run.meta["status"] == "aborted" and run.meta["end_reason"]
    assert len(run.points) >= 1 and run.points["station"].tolist() == list(range(len(run.points)))


def test_process_json_straightness_keys(demo_run: Path) -> None:
    res = guideway("process", str(demo_run), "--json", "--no-write", "--method", "patent", "--mc-trials", "300")
    assert res.returncode == 0, res.stderr
    obj = json.loads(res.stdout)
    assert obj["method"] == "patent"
    assert set(obj["straightness_um"]) == {"endpoint", "least_squares", "minimum_zone"}
    assert obj["straightness_um"]["minimum_zone"] <= obj["straightness_um"]["least_squares"]
    unc = obj["uncertainty_um"]
    assert unc["k"] == 2 and len(unc["per_station"]) == 6
    assert unc["per_station"][0] > 0  # patent: the datum's interferometer channels are used as recorded
    assert set(unc["straightness"]) == {"endpoint", "least_squares", "minimum_zone"}
    assert "300 trials" in unc["straightness_method"]
    assert obj["wavelength_mm"] is None or obj["wavelength_mm"]["dominant"] > 0
    assert "return_pass" not in obj


def test_process_writes_deviation_and_uncertainty_columns(demo_run: Path) -> None:
    res = guideway("process", str(demo_run), "--mc-trials", "0")
    assert res.returncode == 0, res.stderr
    assert "decoupling: exact" in res.stdout and "minimum zone reference line" in res.stdout
    header = (demo_run / "results" / "profile.csv").read_text().splitlines()[0].split(",")
    assert header == ["station", "x_mm", "height_um", "dev_endpoint_um", "dev_least_squares_um",
                      "dev_minimum_zone_um", "u_um"]


def test_bad_mc_trials_is_a_one_line_error(demo_run: Path) -> None:
    one_line_error(guideway("process", str(demo_run), "--mc-trials", "1"), "--mc-trials")
