"""One writer per run (docs/reliability.md): real ``guideway`` processes started on the same run
directory.  The second writer is refused at once with one line naming the holder, exit 2, and the
points the first one writes stay intact; ``process`` reads the run meanwhile.  And the lock itself: a
lock left by a process killed with SIGKILL is no obstacle."""

from __future__ import annotations

import errno
import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from saved_runs.store import lock as lock_module
from saved_runs.store.lock import LOCK_NAME, RunInUseError, take_run_lock

from .cli import ROOT, guideway, one_line_error, spawn
from .reliability import (
    COMMON,
    MANUAL,
    Counts,
    Refusal,
    partial_run,
    points_on_disk,
    prefix_counts,
    two_writers_trial,
)
from .waiting import wait_for


@pytest.fixture()
def long_ref(reliability_references: dict[str, tuple[Path, Path]]) -> tuple[Path, Path]:
    """The straightness trial set-up and its uninterrupted run."""
    return reliability_references["straightness"]


@pytest.fixture(scope="module")
def killed_run(tmp_path_factory: pytest.TempPathFactory, reliability_references: dict[str, tuple[Path, Path]]) -> Path:
    """A straightness run killed after 2 points, for the tests that only try to write it (and must leave
    it as it is)."""
    setup, _ = reliability_references["straightness"]
    return partial_run("straightness", setup, tmp_path_factory.mktemp("killed"), points=2)


def refused_naming_the_holder(r: Refusal) -> str:
    """The refused writer printed one line naming the other writer: its pid, this host, since when."""
    res = subprocess.CompletedProcess([], 2, "", r.stderr)
    return one_line_error(res, "is in use", f"pid {r.holder_pid} on host {socket.gethostname()}, since ")


def test_two_resumes_of_the_same_run_one_is_refused(tmp_path: Path, long_ref: tuple[Path, Path]) -> None:
    setup, ref = long_ref
    run_dir = partial_run("straightness", setup, tmp_path, points=2)
    resume = ["acquire", "--resume", run_dir, *MANUAL]
    refusal = two_writers_trial(resume, resume, tmp_path, run_dir=run_dir)
    refused_naming_the_holder(refusal)
    assert prefix_counts("straightness", run_dir, ref) == Counts(0, 0, 0)


def test_resume_while_the_run_is_written_is_refused(tmp_path: Path, long_ref: tuple[Path, Path]) -> None:
    setup, ref = long_ref
    run_dir = tmp_path / "run"
    refusal = two_writers_trial(["acquire", "straightness", "--setup", setup, "--out", run_dir, *MANUAL],
                                ["acquire", "--resume", run_dir, *MANUAL], tmp_path, run_dir=run_dir, first_points=3)
    assert refusal.loser == 1
    refused_naming_the_holder(refusal)
    assert prefix_counts("straightness", run_dir, ref) == Counts(0, 0, 0)  # no torn or repeated rows


def test_race_for_the_same_new_out_the_loser_is_told_it_is_in_use(tmp_path: Path,
                                                                   long_ref: tuple[Path, Path]) -> None:
    setup, ref = long_ref
    out = tmp_path / "new"
    args = ["acquire", "straightness", "--setup", setup, "--out", out, *MANUAL]
    refusal = two_writers_trial(args, args, tmp_path, run_dir=out)
    line = refused_naming_the_holder(refusal)
    assert "resume" not in line  # the winner's live run is not the loser's to resume
    assert prefix_counts("straightness", out, ref) == Counts(0, 0, 0)


def test_process_reads_the_run_while_it_is_written(tmp_path: Path, long_ref: tuple[Path, Path]) -> None:
    setup, _ = long_ref
    run_dir = tmp_path / "run"
    with spawn("acquire", "straightness", "--setup", setup, "--out", run_dir, *MANUAL, tmp_dir=tmp_path / "tmp",
               stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE) as proc:
        try:
            assert proc.stdin is not None
            seen: list[int] = []
            sent = 0
            for n in (3, 5, 8):  # the run goes on between the reads (each Enter captures a station)
                proc.stdin.write("\n" * (n - sent))
                proc.stdin.flush()
                sent = n
                wait_for(lambda n=n: points_on_disk(run_dir) >= n or proc.poll() is not None, timeout_s=60,
                         what=f"{n} points")
                res = guideway("process", run_dir, "--json", "--no-write", "--mc-trials", "0")
                assert res.returncode == 0, res.stderr
                seen.append(len(json.loads(res.stdout)["profile"]))
            assert proc.poll() is None, "the run ended while process read it; the test proves nothing"
            assert seen == [3, 5, 8]
        finally:
            proc.kill()
            proc.communicate()


def test_a_lock_left_by_a_killed_process_is_no_obstacle(tmp_path: Path) -> None:
    code = ("import os, signal, sys; from saved_runs.store.lock import take_run_lock; "
            "take_run_lock(sys.argv[1]); print('locked', flush=True); os.kill(os.getpid(), signal.SIGKILL)")
    with subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], cwd=ROOT, stdout=subprocess.PIPE,
                          text=True) as proc:
        out, _ = proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL and out == "locked\n"
    holder = json.loads((tmp_path / LOCK_NAME).read_text())  # the dead process's lock file stays ...
    assert holder["pid"] == proc.pid and holder["host"] == socket.gethostname()
    lock = take_run_lock(tmp_path)  # ... but the kernel released its lock
    try:
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
        with pytest.raises(RunInUseError, match=f"pid {os.getpid()} on host"):
            take_run_lock(tmp_path)  # a second descriptor, even in the same process, is a second writer
    finally:
        lock.release()
    assert not (tmp_path / LOCK_NAME).exists()


def test_import_into_a_run_being_written_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "run"
    out.mkdir()
    lock = take_run_lock(out)
    try:
        data = tmp_path / "data.csv"
        data.write_text("run,direction,target_mm,reading_mm\n1,1,0,0\n1,1,100,100.001\n")
        res = guideway("import", "positioning", data, "--out", out, "--compensated")
        one_line_error(res, f"{out} is in use", f"pid {os.getpid()}")
    finally:
        lock.release()
    assert not any(out.iterdir())
    assert not list(tmp_path.glob(".run.*"))  # nor a temporary directory next to it


def test_a_read_only_run_is_one_clear_line(killed_run: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """What a user without write permission meets (root, who runs these tests, is never refused: the
    refusal is put in place of the system call)."""
    run_dir = killed_run
    before = (run_dir / "points.csv").read_text()
    real_open = os.open

    def read_only(path: str | os.PathLike[str], flags: int, *args: int) -> int:
        if Path(path).parent == run_dir and flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return real_open(path, flags, *args)

    monkeypatch.setattr(lock_module.os, "open", read_only)
    res = guideway("acquire", "--resume", run_dir, *COMMON)
    monkeypatch.undo()
    line = one_line_error(res, str(run_dir), "permission denied")
    assert "Errno" not in line
    assert (run_dir / "points.csv").read_text() == before


def test_the_tui_entry_point_holds_the_lock_too(killed_run: Path) -> None:
    """The TUI (and its runs browser) start and resume runs through ``acquisition.acquire.acquire`` with an
    operator of their own: a run another process writes is refused there before any device is opened."""
    import io

    from acquisition.acquire import SimOptions, acquire
    from acquisition.operators import AutoOperator

    run_dir = killed_run
    before = (run_dir / "points.csv").read_text()
    lock = take_run_lock(run_dir)  # another writer (here: this process, through another descriptor)
    try:
        with pytest.raises(RunInUseError, match=f"is in use: .*pid {os.getpid()} on host"):
            acquire("straightness", None, "", run_dir, simulate=SimOptions(seed=5, noise=False), resume=True,
                    operator=AutoOperator({}), stream=io.StringIO())
    finally:
        lock.release()
    assert (run_dir / "points.csv").read_text() == before


def test_the_refusal_names_the_new_holder_not_the_killed_writer_before_it(tmp_path: Path) -> None:
    """A killed writer leaves its record in the lock file; the next holder rewrites it just after taking
    the lock.  A writer refused in between must wait for the new record, not name the dead process
    (seen in the soak trials: two resumes of a killed run)."""
    import fcntl
    import threading
    import time

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # a pid that no longer runs
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    path = run_dir / LOCK_NAME
    path.write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname(), "since": "2026-01-01T00:00:00Z"}))
    fd = os.open(path, os.O_RDWR)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # the new holder has the lock, its record not yet written
    mine = json.dumps({"pid": os.getpid(), "host": socket.gethostname(), "since": "2026-11-26T12:00:00Z"})

    def record_later() -> None:
        time.sleep(0.2)
        os.ftruncate(fd, 0)
        os.pwrite(fd, mine.encode(), 0)

    writer = threading.Thread(target=record_later)
    writer.start()
    try:
        with pytest.raises(RunInUseError) as refused:
            take_run_lock(run_dir)
    finally:
        writer.join()
        os.close(fd)
    assert f"pid {os.getpid()} on host" in str(refused.value)
    assert f"pid {dead.pid} " not in str(refused.value)
