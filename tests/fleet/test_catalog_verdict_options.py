"""A catalogue entry carries the verdict the evaluation gives, however the run was evaluated (processed,
processed by an older guideway whose summary.json had no verdict, or not at all), and the evaluation options
of its values, with a line in ``catalog list`` when they are not ``guideway process``'s defaults."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli import ROOT, guideway
from tests.setups import replace_once, straightness_setup_text


@pytest.fixture(scope="module")
def failing_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated straightness run of 6 stations against a tolerance of 0.01 um: no real profile is that
    straight, so the run fails it."""
    tmp = tmp_path_factory.mktemp("failing")
    setup = tmp / "s.toml"
    setup.write_text(replace_once(straightness_setup_text(stations=6, samples=1), "straightness_um = 10.0",
                                  "straightness_um = 0.01"))
    res = guideway("acquire", "straightness", "--setup", setup, "--out", tmp / "run", "--simulate", "--auto")
    assert res.returncode == 0, res.stderr
    return tmp / "run"


def copy_of(run: Path, to: Path) -> Path:
    import shutil

    return Path(shutil.copytree(run, to))


def entry(url: str) -> dict:
    (only,) = json.loads(guideway("catalog", "list", "--json", "--catalog", url).stdout)["runs"]
    return only


def test_a_processed_failing_run_is_catalogued_fail(failing_run: Path, tmp_path: Path) -> None:
    run = copy_of(failing_run, tmp_path / "run")
    res = guideway("process", run, "--json")
    assert res.returncode == 0, res.stderr
    # the tolerance is 0.01 um: the minimum-zone straightness of the run is larger, the run fails
    evaluated = json.loads(res.stdout)
    assert evaluated["straightness_um"]["minimum_zone"] > 0.01 and evaluated["verdict"]["result"] == "fail"
    summary = json.loads((run / "results" / "summary.json").read_text())
    assert summary["verdict"]["result"] == "fail"  # summary.json holds the verdict as process --json does
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    assert guideway("catalog", "add", run, "--catalog", url).returncode == 0
    e = entry(url)
    assert e["verdict"] == "fail"
    assert e["options"] == {"method": "exact", "mc_trials": 10_000, "accept_out_of_range": False}
    assert e["non_default_options"] == {}
    listed = guideway("catalog", "list", "--catalog", url).stdout
    assert "evaluated with" not in listed


def test_a_summary_without_verdict_is_not_taken(failing_run: Path, tmp_path: Path) -> None:
    """summary.json as an older guideway wrote it (no verdict key): the run is evaluated, and fails."""
    run = copy_of(failing_run, tmp_path / "run")
    assert guideway("process", run).returncode == 0
    path = run / "results" / "summary.json"
    old = json.loads(path.read_text())
    del old["verdict"]
    stat = path.stat()
    path.write_text(json.dumps(old))
    import os

    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))  # still fresh: written after the run's files
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    assert guideway("catalog", "add", run, "--catalog", url).returncode == 0
    assert entry(url)["verdict"] == "fail"


def test_other_options_are_recorded_and_listed(failing_run: Path, tmp_path: Path) -> None:
    run = copy_of(failing_run, tmp_path / "run")
    assert guideway("process", run, "--method", "first-order", "--mc-trials", "20").returncode == 0
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    assert guideway("catalog", "add", run, "--catalog", url).returncode == 0
    e = entry(url)
    assert e["verdict"] == "fail"
    assert e["options"] == {"method": "first-order", "mc_trials": 20, "accept_out_of_range": False}
    # 6 stations: 10 000 trials by default (fewer only above 200 stations)
    assert e["option_defaults"] == {"method": "exact", "mc_trials": 10_000, "accept_out_of_range": False}
    assert e["non_default_options"] == {"method": "first-order", "mc_trials": 20}
    lines = guideway("catalog", "list", "--catalog", url).stdout.splitlines()
    assert lines[1] == ("    evaluated with method first-order, mc_trials 20, not the defaults of guideway process "
                        "(method exact, mc_trials 10000)"), lines


def test_an_unprocessed_run_is_evaluated_with_the_defaults(failing_run: Path, tmp_path: Path) -> None:
    run = copy_of(failing_run, tmp_path / "run")
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    assert guideway("catalog", "add", run, "--catalog", url).returncode == 0
    e = entry(url)
    assert e["verdict"] == "fail" and e["non_default_options"] == {}


def test_positioning_options(tmp_path: Path) -> None:
    from .runs import positioning_summary, write_run

    summary = positioning_summary({"E": 4.0}, verdict="pass") | {"k": 3.0, "edition": "ISO 230-2:1997"}
    write_run(tmp_path / "runs", "p", kind="positioning", summary=summary)
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0
    e = entry(url)
    assert e["non_default_options"] == {"k": 3.0, "edition": "ISO 230-2:1997"}
    assert e["option_defaults"] == {"k": 2.0, "edition": "ISO 230-2:2014", "accept_out_of_range": False}


def test_a_positioning_value_is_catalogued_with_its_standard_uncertainty(tmp_path: Path) -> None:
    """u of a positioning value = U / k of its ISO 230-2 Annex A budget as the run's evaluation states it
    (the budget's own figures are tested in tests/processing/test_positioning_budget.py); the trend then
    weighs the runs with it.  Before, every positioning value was catalogued with u null."""
    run = tmp_path / "runs" / "p"
    assert guideway("simulate", ROOT / "docs" / "scenario-positioning.toml", "--out", run).returncode == 0
    assert guideway("process", run).returncode == 0
    summary = json.loads(guideway("process", run, "--json", "--no-write").stdout)
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    assert guideway("catalog", "add", run, "--catalog", url).returncode == 0
    values = entry(url)["values"]
    for q in ("E", "M", "A", "B", "R"):
        budget = summary["uncertainty"][q]
        assert values[q]["u_um"] == pytest.approx(budget["U"] / budget["k"], rel=1e-9), q
