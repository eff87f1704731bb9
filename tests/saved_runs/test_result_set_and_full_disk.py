"""results/ is one evaluation's set, whatever kills ``process``; a full disk names the file, leaves no
temporary file and, during an acquisition, says how to resume."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ..cli import ROOT, guideway, one_line_error

SET = ("profile.csv", "profile.png", "summary.json")


def simulated_run(path: Path) -> Path:
    res = guideway("simulate", ROOT / "docs" / "scenario-straightness.toml", "--out", path)
    assert res.returncode == 0, res.stderr
    return path


def set_bytes(run: Path) -> dict[str, bytes]:
    return {name: (run / "results" / name).read_bytes() for name in SET}


def leftovers(run: Path) -> list[str]:
    return sorted(p.name for d in (run, run / "results") if d.is_dir() for p in d.iterdir()
                  if p.name.startswith("."))


@pytest.fixture(scope="module")
def reference_sets(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, dict[str, bytes]]]:
    """A run and the complete results set of each of two methods (each written by an undisturbed process)."""
    base = tmp_path_factory.mktemp("sets")
    run = simulated_run(base / "run")
    sets = {}
    for method in ("exact", "patent"):
        assert guideway("process", run, "--method", method, "--mc-trials", "50", "--plot").returncode == 0
        sets[method] = set_bytes(run)
    assert sets["exact"]["profile.csv"] != sets["patent"]["profile.csv"]
    assert sets["exact"]["profile.png"] != sets["patent"]["profile.png"]
    return run, sets


def test_a_crash_in_the_middle_of_the_set_leaves_the_old_set(reference_sets, tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    import shutil

    from saved_runs.results import straightness

    src, sets = reference_sets
    run = tmp_path / "run"
    shutil.copytree(src, run)
    assert guideway("process", run, "--method", "exact", "--mc-trials", "50", "--plot").returncode == 0
    (run / "results" / "report.html").write_text("<p>a report</p>")  # another command's file stays
    written = []

    def crash(result, path):  # noqa: ANN001, ANN202  (profile.csv and summary.json are written by now)
        written.extend(sorted(p.name for p in path.parent.iterdir()))
        raise RuntimeError("killed while drawing")

    monkeypatch.setattr(straightness, "plot_profile", crash)
    with pytest.raises(RuntimeError):
        guideway("process", run, "--method", "patent", "--mc-trials", "50", "--plot")
    assert "profile.csv" in written and "summary.json" in written  # the crash came mid-set
    assert set_bytes(run) == sets["exact"]
    assert (run / "results" / "report.html").read_text() == "<p>a report</p>"
    assert leftovers(run) == []
    monkeypatch.undo()
    assert guideway("process", run, "--method", "patent", "--mc-trials", "50", "--plot").returncode == 0
    assert set_bytes(run) == sets["patent"]
    assert (run / "results" / "report.html").read_text() == "<p>a report</p>"


def test_kill_9_during_process_never_leaves_a_mixed_set(reference_sets, tmp_path: Path) -> None:  # noqa: ANN001
    """A real SIGKILL the moment the process starts writing (anything in the run changes), and then
    later and later; each time results/ is all of one method's set, and the next process cleans up."""
    import shutil

    src, sets = reference_sets
    hit_while_writing = 0
    # at least five kills, each checked; then more, at delays spread over the write, until one has
    # landed while the set was being written (how long the write takes depends on the machine's load)
    delays_s = (0.0, 0.0, 0.05, 0.15, 0.3, 0.0, 0.01, 0.02, 0.03, 0.08, 0.1, 0.2)
    for trial, delay_s in enumerate(delays_s):
        if trial >= 5 and hit_while_writing:
            break
        run = tmp_path / f"run{trial}"
        shutil.copytree(src, run)
        old = "patent"
        assert guideway("process", run, "--method", old, "--mc-trials", "50", "--plot").returncode == 0
        before = {(p.name, p.stat().st_mtime_ns) for d in (run, run / "results") for p in d.iterdir()}
        proc = subprocess.Popen([sys.executable, "-m", "tui.cli", "process", str(run), "--method", "exact", "--plot",
                                 "--mc-trials", "50"], cwd=ROOT, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        try:
            deadline = time.monotonic() + 120
            while proc.poll() is None and time.monotonic() < deadline:
                try:
                    now = {(p.name, p.stat().st_mtime_ns) for d in (run, run / "results") for p in d.iterdir()}
                except FileNotFoundError:
                    now = set()
                if now != before:
                    break
                time.sleep(0.0005)
            time.sleep(delay_s)
            was_running = proc.poll() is None
            proc.send_signal(signal.SIGKILL)
        finally:
            proc.wait()
        hit_while_writing += was_running and bool(leftovers(run))
        got = set_bytes(run)
        assert got in (sets["exact"], sets[old]), f"trial {trial}: a mixed set"
        assert guideway("process", run, "--method", "exact", "--mc-trials", "50", "--plot").returncode == 0
        assert set_bytes(run) == sets["exact"]
        assert leftovers(run) == [], "stale temporary files not cleaned"
    assert hit_while_writing >= 1, "no kill landed while the set was being written"


def test_a_full_disk_while_writing_results_names_the_file(reference_sets, tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    import shutil

    from saved_runs.store import files

    src, sets = reference_sets
    run = tmp_path / "run"
    shutil.copytree(src, run)
    assert guideway("process", run, "--method", "patent", "--mc-trials", "50", "--plot").returncode == 0
    real_fsync = os.fsync

    def full(fd: int) -> None:
        if os.path.isfile(f"/proc/self/fd/{fd}"):  # a file being written, not a directory
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_fsync(fd)

    monkeypatch.setattr(files.os, "fsync", full)
    line = one_line_error(guideway("process", run, "--method", "exact", "--mc-trials", "50", "--plot"),
                          "No space left on device", "disk is full")
    assert str(run / "results" / "profile.csv") in line
    monkeypatch.undo()
    assert set_bytes(run) == sets["patent"] and leftovers(run) == []


def test_a_full_disk_during_an_acquisition_gives_the_resume_command(setup_file: Path, tmp_path: Path,
                                                                     monkeypatch) -> None:  # noqa: ANN001
    from saved_runs.store.writer import RunStore

    real = RunStore._write_row
    calls = []

    def full_at_the_fifth_point(self, data):  # noqa: ANN001, ANN202
        calls.append(1)
        if len(calls) == 5:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, data)

    monkeypatch.setattr(RunStore, "_write_row", full_at_the_fifth_point)
    run = tmp_path / "run"
    line = one_line_error(guideway("acquire", "straightness", "--setup", setup_file, "--out", run, "--simulate",
                                   "--auto"),
                          f"cannot write {run / 'points.csv'}: No space left on device",
                          f"continue with: guideway acquire --resume {run}")
    assert "Traceback" not in line
    monkeypatch.undo()
    res = guideway("acquire", "--resume", run, "--simulate", "--auto")
    assert res.returncode == 0, res.stderr
    from saved_runs.store.reader import load_run

    done = load_run(run)
    assert done.meta["status"] == "complete"
    keys = list(zip(done.points["station"], done.points["pass"], strict=True))
    assert len(keys) == len(set(keys)) == done.meta["setup"]["stations"] * (2 if done.meta["setup"].get(
        "return_pass") else 1)
    assert leftovers(run) == []


def test_a_real_full_tmpfs(reference_sets, tmp_path: Path) -> None:  # noqa: ANN001
    """A 96 KiB tmpfs: the run fits, its plot does not."""
    import shutil

    src, sets = reference_sets
    mnt = tmp_path / "small"
    mnt.mkdir()
    res = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=96k", "tmpfs", str(mnt)], capture_output=True)
    if res.returncode != 0:
        pytest.skip(f"mounting a tmpfs is not permitted here: {res.stderr.decode().strip()}")
    try:
        run = mnt / "run"
        run.mkdir()
        for name in ("run.json", "points.csv"):
            shutil.copy(src / name, run / name)
        line = one_line_error(guideway("process", run, "--mc-trials", "50", "--plot"), "No space left on device",
                              str(run / "results"))
        assert leftovers(run) == [] and not (run / "results").exists()
    finally:
        subprocess.run(["umount", str(mnt)], check=True)
    assert line
