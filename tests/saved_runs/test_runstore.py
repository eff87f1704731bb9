"""Run directories: every point on disk before the engine continues, atomic
run.json, and one-line errors for bad directories."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from processing.columns import STRAIGHTNESS_POINTS_V2
from saved_runs.errors import RunFormatError
from saved_runs.store.reader import load_run
from saved_runs.store.writer import RunStore


def point(k: int) -> dict:
    row = dict.fromkeys(STRAIGHTNESS_POINTS_V2, 0.5 * k)
    row["station"] = k
    row["x_mm"] = 100.0 * k
    row["pass"] = 0
    row["not_still"] = k % 2  # a flag: 0 or 1
    row["sensor_mm"] = 0.1 + k / 3  # needs more than 15 digits to round-trip
    return row


def start(store: RunStore) -> None:
    store("start", {"uid": "u1", "kind": "straightness"})


def test_each_point_is_on_disk_when_the_subscriber_returns(tmp_path: Path) -> None:
    run = tmp_path / "run"
    store = RunStore(run, {"machine": "M", "setup": {"stations": 3}})
    start(store)
    meta = json.loads((run / "run.json").read_text())
    assert meta["status"] == "in-progress" and meta["format"] == "guideway-run" and meta["version"] == 2
    assert meta["created"].endswith("Z") and meta["machine"] == "M"
    for k in range(3):
        store("event", {"data": point(k)})
        lines = (run / "points.csv").read_text().splitlines()  # a separate reader sees it
        assert len(lines) == k + 2
    store("stop", {"exit_status": "success", "reason": "done"})
    meta = json.loads((run / "run.json").read_text())
    assert meta["status"] == "complete" and meta["points"] == 3
    loaded = load_run(run)
    assert list(loaded.points.columns) == list(STRAIGHTNESS_POINTS_V2)
    assert loaded.points["sensor_mm"].tolist() == [0.1 + k / 3 for k in range(3)]  # exact round trip
    assert not list(run.glob(".*tmp"))  # no temp files left


@pytest.mark.parametrize(("exit_status", "status"), [("abort", "aborted"), ("fail", "aborted")])
def test_early_end_is_recorded(tmp_path: Path, exit_status: str, status: str) -> None:
    store = RunStore(tmp_path / "r", {})
    start(store)
    store("event", {"data": point(0)})
    store("stop", {"exit_status": exit_status, "reason": "why"})
    meta = json.loads((tmp_path / "r" / "run.json").read_text())
    assert meta["status"] == status and meta["end_reason"] == "why"


def test_refuses_a_non_empty_directory(tmp_path: Path) -> None:
    (tmp_path / "keep.txt").write_text("precious")
    with pytest.raises(RunFormatError, match="not empty"):
        RunStore(tmp_path, {}).prepare()
    assert (tmp_path / "keep.txt").read_text() == "precious"


def make_run(tmp_path: Path, n: int = 3) -> Path:
    store = RunStore(tmp_path / "r", {})
    start(store)
    for k in range(n):
        store("event", {"data": point(k)})
    store("stop", {"exit_status": "success"})
    return tmp_path / "r"


def test_partial_last_line_is_dropped_with_a_warning(tmp_path: Path) -> None:
    run = make_run(tmp_path)
    with open(run / "points.csv", "a") as f:
        f.write("3,300.0,1.5,1.5")  # a kill in the middle of a write
    loaded = load_run(run)
    assert len(loaded.points) == 3 and "incomplete last line" in loaded.warnings[0]


def edit_meta(run: Path, **changes: object) -> None:
    meta = json.loads((run / "run.json").read_text())
    meta.update(changes)
    (run / "run.json").write_text(json.dumps(meta))


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda r: (r / "run.json").unlink(), "no run.json"),
        (lambda r: (r / "run.json").write_text("{not json"), "not valid JSON"),
        (lambda r: (r / "run.json").write_text('{"format": "other"}'), "not a guideway run"),
        (lambda r: (r / "run.json").write_text('{"format": "guideway-run", "version": 99, "kind": "straightness"}'),
         "version 99 is not supported"),
        (lambda r: (r / "run.json").write_text('{"format": "guideway-run", "version": 1, "kind": "weird"}'),
         "unknown run kind"),
        (lambda r: (r / "points.csv").unlink(), "no points.csv"),
        (lambda r: (r / "points.csv").write_text("station,x_mm\n0,0\n"), "missing column"),
        (lambda r: (r / "points.csv").write_text(
            (r / "points.csv").read_text().replace("100.0", "abc", 1)), r"points.csv:3: column x_mm is not a number"),
        (lambda r: (r / "points.csv").write_bytes(b"\xff\xfe\x00"), "not UTF-8"),
        (lambda r: edit_meta(r, instruments=5), "'instruments' must be dict, got int 5"),
        (lambda r: edit_meta(r, instruments={"sensor": "keyence"}), "instruments.sensor must be an object"),
        (lambda r: edit_meta(r, setup=[1, 2]), "'setup' must be dict, got list"),
        (lambda r: edit_meta(r, machine=7), "'machine' must be str, got int"),
    ],
)
def test_bad_run_directories_give_one_line_errors(tmp_path: Path, mutate, message: str) -> None:
    run = make_run(tmp_path)
    mutate(run)
    with pytest.raises(RunFormatError, match=message) as info:
        load_run(run)
    assert "\n" not in str(info.value)


def test_missing_directory(tmp_path: Path) -> None:
    with pytest.raises(RunFormatError, match="no such run directory"):
        load_run(tmp_path / "nope")


def test_annotate_replaces_run_json_keys(tmp_path: Path) -> None:
    store = RunStore(tmp_path / "r", {})
    start(store)
    store("annotate", {"key": "progress", "value": {"pass": 0, "station": 4}})
    store("annotate", {"key": "skipped", "value": [{"station": 2, "pass": 0, "reason": "r"}]})
    store.close()
    meta = json.loads((tmp_path / "r" / "run.json").read_text())
    assert meta["progress"] == {"pass": 0, "station": 4} and meta["skipped"][0]["station"] == 2


def test_retract_withdraws_the_last_matching_point(tmp_path: Path) -> None:
    store = RunStore(tmp_path / "r", {})
    start(store)
    for k in range(3):
        store("event", {"data": point(k)})
    store("retract", {"match": {"station": 2, "pass": 0}})
    store("event", {"data": {**point(2), "stry_um": 9.0}})  # the redone capture
    store("stop", {"exit_status": "success"})
    loaded = load_run(tmp_path / "r")
    assert loaded.points["station"].tolist() == [0, 1, 2]
    assert loaded.points["stry_um"].tolist() == [0.0, 0.5, 9.0]
    assert loaded.meta["points"] == 3


def test_resume_cuts_a_partial_line_and_appends(tmp_path: Path) -> None:
    run = tmp_path / "r"
    store = RunStore(run, {"machine": "M"})
    start(store)
    for k in range(2):
        store("event", {"data": point(k)})
    store.close()
    with open(run / "points.csv", "a") as f:
        f.write("2,200.0,1.0")  # killed in the middle of writing station 2
    resumed = RunStore.for_resume(run)
    assert resumed.points_written == 2 and [int(p["station"]) for p in resumed.loaded_points] == [0, 1]
    resumed("start", {"uid": "u1", "kind": "straightness", "resume": True})
    resumed("event", {"data": point(2)})
    resumed("stop", {"exit_status": "success", "reason": "done"})
    loaded = load_run(run)
    assert loaded.warnings == () and loaded.points["station"].tolist() == [0, 1, 2]
    assert loaded.meta["status"] == "complete" and loaded.meta["points"] == 3 and loaded.meta["uid"] == "u1"
    assert loaded.meta["machine"] == "M" and loaded.meta["resumed"][0]["points"] == 2


def test_a_complete_run_is_not_resumed(tmp_path: Path) -> None:
    run = make_run(tmp_path)
    with pytest.raises(RunFormatError, match="already complete"):
        RunStore.for_resume(run)


def test_run_files_take_the_users_umask(tmp_path: Path) -> None:
    import os

    old = os.umask(0o002)
    try:
        store = RunStore(tmp_path / "run", {"machine": "M"})
        start(store)
        store("event", {"data": point(0)})
        store("retract", {"match": {"station": 0}})  # points.csv rewritten atomically
        store("stop", {"exit_status": "success", "reason": "done"})
    finally:
        os.umask(old)
    for name in ("run.json", "points.csv"):
        assert (tmp_path / "run" / name).stat().st_mode & 0o777 == 0o664, name
