"""run.json's own plan, hand-edited or damaged (saved_runs/store/plan.py): one line naming run.json and the
key, exit 2; never a traceback, never a process that allocates the plan of an absurd station count."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from acquisition.setup.maxima import STATIONS_MAX
from saved_runs.errors import RunFormatError
from saved_runs.store.plan import straightness_plan
from saved_runs.store.reader import load_run

from ..cli import ROOT, guideway, one_line_error

V1_RUN = ROOT / "tests" / "data" / "runs" / "v1-straightness"  # 8 stations, L = 100 mm, complete


def _copy_v1(tmp_path: Path, **changes: object) -> Path:
    run = tmp_path / "run"
    shutil.copytree(V1_RUN, run)
    shutil.rmtree(run / "results", ignore_errors=True)
    meta = json.loads((run / "run.json").read_text())
    for key, value in changes.items():
        if key in ("stations", "block_length_mm"):
            meta["setup"][key] = value
        else:
            meta[key] = value
    (run / "run.json").write_text(json.dumps(meta))
    return run


@pytest.mark.parametrize("skipped", [[{"station": 3, "pass": None}], [{"station": 3, "pass": "x"}],
                                     [{"station": 3, "pass": 2}], [{"station": "3", "pass": 0}], ["3"]])
def test_a_damaged_skip_record_is_one_line(tmp_path: Path, skipped: list[object]) -> None:
    run = _copy_v1(tmp_path, skipped=skipped)
    one_line_error(guideway("process", run, "--no-write"), "run.json", "skipped[0]")


def test_a_skip_record_of_version_1_without_a_pass_is_read(tmp_path: Path) -> None:
    # version 1 wrote {"station": k, "reason": ...}: the forward pass (docs/run-format.md)
    run = _copy_v1(tmp_path, skipped=[{"station": 3, "reason": "skipped by the operator"}])
    assert guideway("process", run, "--no-write").returncode == 0


def test_a_station_count_beyond_the_maximum_is_refused_before_the_plan_is_made(tmp_path: Path) -> None:
    # 10^30 planned steps cannot be listed: the count is refused as the set-up loader refuses it
    run = _copy_v1(tmp_path, stations=10**30)
    with pytest.raises(RunFormatError, match="setup.stations"):
        straightness_plan(load_run(run))
    one_line_error(guideway("process", run, "--no-write"), "run.json", "setup.stations", str(STATIONS_MAX))


def test_the_largest_station_count_is_a_plan(tmp_path: Path) -> None:
    run = _copy_v1(tmp_path, stations=STATIONS_MAX)
    assert straightness_plan(load_run(run)).stations == STATIONS_MAX
