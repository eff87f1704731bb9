"""A live compensator that stops mid-run (docs/compensation.md, "When the compensator stops"): the simulated
controller closes the compensator's connection at its N-th request (``--faults live:close@N``, real Modbus TCP
over loopback as in tests/test_seed003_live.py); the run stops before its next point with one line and exit 2,
keeps the points measured while the compensator ran, and process / compare warn, verify refuses it."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "seed003"


def guideway(*args: object) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "tui.cli", *map(str, args)], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)


def planned_points(setup: Path) -> list[tuple[int, int, int]]:
    """(run, direction, target_index) of every point of a linear-cycle run, in the order measured (ISO 230-2
    linear cycle: each run up through the targets, then down)."""
    axis = tomllib.loads(setup.read_text())["axis"]
    n = len(axis["targets_deg"])
    out = []
    for r in range(1, axis["runs"] + 1):
        out += [(r, 1, i) for i in range(1, n + 1)] + [(r, -1, i) for i in range(n, 0, -1)]
    return out


def read_rows(run: Path) -> list[dict[str, str]]:
    with (run / "points.csv").open(newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict:
    tmp = tmp_path_factory.mktemp("live-death")
    found, dead = tmp / "found", tmp / "dead"
    res = guideway("acquire", "positioning", "--setup", DATA / "rotary-found.toml", "--out", found, "--simulate",
                   "--auto")
    assert res.returncode == 0, res.stderr
    # ~2 requests per 8 ms cycle, a few cycles per point: the link goes well inside the 180 points
    dead_res = guideway("acquire", "positioning", "--setup", DATA / "rotary-left.toml", "--out", dead, "--simulate",
                        "--auto", "--seed", 1, "--live-compensation", found, "--faults", "live:close@500")
    return {"found": found, "dead": dead, "res": dead_res}


def test_the_run_stops_with_one_line_and_exit_2(runs: dict) -> None:
    res, dead = runs["res"], runs["dead"]
    assert res.returncode == 2, (res.stdout[-2000:], res.stderr)
    line = res.stderr.strip()
    assert "\n" not in line and "Traceback" not in line
    rows = read_rows(dead)
    n = len(rows)
    assert line.startswith(f"guideway: error: live compensation stopped after point {n} (connection to the "
                           "live-compensation controller"), line
    assert "lost" in line and "the run is stopped" in line and "check the live-compensation controller link" in line
    assert "--resume" not in line  # resuming would measure the rest uncompensated


def test_points_before_the_death_are_kept_and_none_after(runs: dict) -> None:
    dead = runs["dead"]
    meta = json.loads((dead / "run.json").read_text())
    rows = read_rows(dead)
    n = len(rows)
    plan = planned_points(DATA / "rotary-left.toml")
    assert 0 < n < len(plan)  # stopped mid-run
    # the points measured are the plan's first n, in order, flushed to points.csv
    assert [(int(r["run"]), int(r["direction"]), int(r["target_index"])) for r in rows] == plan[:n]
    assert meta["status"] == "aborted" and meta["points"] == n
    assert meta["end_reason"].startswith(f"live compensation stopped after point {n} (")
    live = meta["live_compensation"]
    assert "lost" in live["error"] and live["ended"] == "stopped during the run"
    assert live["last_compensated_point"] == n
    assert live["last_compensated_time_s"] == pytest.approx(float(rows[-1]["time_s"]), abs=1e-9)
    # no capture started after the compensator stopped: the last reading is at most the capture's own time after
    # it (a Modbus round trip; bound: the controller's heartbeat timeout, 500 ms, within which it still applies
    # the last offset), and the fault fired exactly at the 500th request
    assert float(rows[-1]["time_s"]) <= live["stopped_time_s"] + 0.5
    assert meta["fault_plan"]["requests"]["live"] == 500 and meta["fault_plan"]["not_fired"] == []
    assert meta["compensation"]["active"] is True  # it was measured compensated, as far as it went


def test_process_and_compare_warn_verify_refuses(runs: dict) -> None:
    found, dead = runs["found"], runs["dead"]
    n = json.loads((dead / "run.json").read_text())["points"]
    res = guideway("process", dead, "--no-write")
    assert res.returncode == 0, res.stderr
    warning = f"guideway: warning: {dead}: live compensation stopped after point {n} ("
    assert warning in res.stderr and "no complete as-left measurement" in res.stderr
    assert f"; live compensation stopped after point {n} (" in res.stdout  # in the compensation line as well
    res = guideway("compare", dead, dead)
    assert warning in res.stderr
    res = guideway("verify", found, dead)
    assert res.returncode == 2
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith(f"guideway: error: AS_LEFT {dead}: live compensation stopped after point {n} ("), last


def test_a_live_fault_without_live_compensation_is_refused(tmp_path: Path) -> None:
    res = guideway("acquire", "positioning", "--setup", DATA / "rotary-found.toml", "--out", tmp_path / "r",
                   "--simulate", "--auto", "--faults", "live:close@5")
    assert res.returncode == 2
    assert res.stderr.strip() == ("guideway: error: --faults live:close@5 cannot fire: this run has no live "
                                  "compensation; add --live-compensation AS_FOUND_RUN (a positioning run) or inject "
                                  "controller faults")
