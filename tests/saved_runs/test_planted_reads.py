"""A named pipe (FIFO) or a device planted at run.json, points.csv or results/summary.json is never read (issue 25):
``process``, ``report`` and ``catalog add`` say so in one line naming the file and exit 2 (a summary.json that is
no regular file is ignored and the run evaluated), instead of waiting forever for a writer; the runs browser
marks the run damaged.  A symbolic link to a regular file is read (reading is harmless)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from saved_runs.catalog.folder import list_runs
from saved_runs.store.reader import load_run
from tests.cli import ROOT, one_line_error

RUN = ROOT / "tests/data/tui-runs/positioning-x"
TIMEOUT_S = 60  # a hang fails the test here instead of holding the suite


def cli(*args: object, tmp: Path) -> subprocess.CompletedProcess[str]:
    """``guideway ARGS`` in a separate process under a timeout (in this process a hang would hang the suite)."""
    env = {**os.environ, "TMPDIR": str(tmp)}
    return subprocess.run([sys.executable, "-m", "tui.cli", *map(str, args)], cwd=ROOT, env=env, text=True,
                          capture_output=True, timeout=TIMEOUT_S)


def planted(tmp_path: Path, name: str) -> Path:
    run = tmp_path / "run"
    shutil.copytree(RUN, run)
    target = run / name
    target.parent.mkdir(exist_ok=True)
    target.unlink(missing_ok=True)
    os.mkfifo(target)
    return run


@pytest.mark.parametrize("name", ["run.json", "points.csv"])
@pytest.mark.parametrize("command", [("process",), ("report",), ("catalog", "add")])
def test_a_fifo_in_a_run_is_refused_in_one_line_not_waited_on(tmp_path: Path, name: str, command: tuple) -> None:
    run = planted(tmp_path, name)
    extra = ("--catalog", f"sqlite:///{tmp_path / 'c.sqlite'}") if command[0] == "catalog" else ()
    started = time.monotonic()
    res = cli(*command, run, *extra, tmp=tmp_path / "tmp")
    assert time.monotonic() - started < TIMEOUT_S
    line = res.stderr if command[0] == "catalog" else one_line_error(res, str(run / name))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert f"{run / name} is a named pipe (FIFO), not a regular file" in line, res.stderr


def test_a_fifo_at_summary_json_is_not_read_by_catalog_add(tmp_path: Path) -> None:
    run = planted(tmp_path, "results/summary.json")
    res = cli("catalog", "add", run, "--catalog", f"sqlite:///{tmp_path / 'c.sqlite'}", tmp=tmp_path / "tmp")
    assert res.returncode == 0 and "added" in res.stdout, res.stderr


def test_the_runs_browser_marks_a_run_with_a_fifo_damaged(tmp_path: Path) -> None:
    import threading

    run = planted(tmp_path, "points.csv")
    found: list = []
    t = threading.Thread(target=lambda: found.append(list_runs(tmp_path)), daemon=True)
    t.start()
    t.join(TIMEOUT_S)
    assert found, "list_runs hung on a FIFO"
    (r,) = found[0]
    assert r.path == run and r.problem == "points.csv is not a regular file"


def test_a_device_is_refused_and_a_link_to_a_regular_file_is_read(tmp_path: Path) -> None:
    from saved_runs.store.files import read_run_file

    run = tmp_path / "run"
    shutil.copytree(RUN, run)
    real = tmp_path / "elsewhere.json"
    real.write_bytes((run / "run.json").read_bytes())
    (run / "run.json").unlink()
    (run / "run.json").symlink_to(real)
    assert load_run(run).meta == json.loads(real.read_text())  # followed: reading through a link is harmless
    with pytest.raises(Exception, match="is a device, not a regular file"):
        read_run_file("/dev/zero")  # would be read without end


def _within_timeout(work):  # noqa: ANN001, ANN202
    """``work()`` in a daemon thread, failing the test (instead of hanging the suite) if it does not return."""
    import threading

    found: list = []
    t = threading.Thread(target=lambda: found.append(work()), daemon=True)
    t.start()
    t.join(TIMEOUT_S)
    assert found, "hung on a FIFO"
    return found[0]


@pytest.mark.parametrize("name", ["run.json", "results/exports.json"])
def test_the_found_left_pairs_of_the_runs_browser_do_not_wait_on_a_fifo(tmp_path: Path, name: str) -> None:
    """The runs browser pairs as-found and as-left runs from run.json and results/exports.json: a FIFO at either
    is not read (that run simply pairs with nothing)."""
    from fleet.verify.pairs import found_left_pairs

    run = planted(tmp_path, name)
    pairs = _within_timeout(lambda: found_left_pairs([run]))
    assert pairs.found_of == {} and pairs.lefts_of == {}


def test_export_does_not_wait_on_a_fifo_at_exports_json(tmp_path: Path) -> None:
    """``export`` adds its record to results/exports.json: a FIFO there is not read; the table is written, the
    record is refused with a note (the atomic writer never writes through it) and the FIFO stays."""
    run = planted(tmp_path, "results/exports.json")
    res = cli("export", run, "--format", "linuxcnc", tmp=tmp_path / "tmp")
    assert "Traceback" not in res.stderr
    assert (run / "results" / "compensation-linuxcnc.comp").is_file(), res.stderr
    assert (run / "results" / "exports.json").is_fifo()
