"""Files the tool writes are never written through a planted link (issue 25, docs/reliability.md).

Anyone who may write into a shared runs folder could put a symbolic link where the next writer writes
(``RUN/.writer.lock``, ``RUN/points.csv``, ``RUN/results/report.html``, ``RUN/results -> /etc``) to have
it destroy another file - a read-only one too when the technician runs as root (as these tests do).  Each
writer entry point is run with a link planted at the file or folder it would write, pointing at a
"victim": it must stop with one line naming the link (exit 2) and leave the victim's bytes and mode and
the link itself as they were.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import stat
from pathlib import Path
from typing import NamedTuple

import pytest

from saved_runs.errors import UnsafeFileError
from saved_runs.store.files import write_text_atomic
from saved_runs.store.lock import LOCK_NAME, take_run_lock
from saved_runs.store.writer import open_points
from tests.cli import ROOT, CliResult, guideway, one_line_error

V1_RUN = ROOT / "tests" / "data" / "runs" / "v1-straightness"  # 8 stations, complete
SIMULATE = ("--simulate", "--auto", "--no-noise", "--seed", "5")
PRECIOUS = b"precious data: not the tool's\n"


class Victim(NamedTuple):
    """A file a planted link points at, and what it held before."""

    path: Path
    data: bytes
    mode: int

    def untouched(self) -> None:
        assert self.path.read_bytes() == self.data
        assert stat.S_IMODE(self.path.stat().st_mode) == self.mode


@pytest.fixture(params=["writable", "read-only"])
def victim(request: pytest.FixtureRequest, tmp_path: Path) -> Victim:
    """A file outside every run; read-only or not (root writes it all the same, through a link)."""
    path = tmp_path / "elsewhere" / "victim.txt"
    path.parent.mkdir()
    path.write_bytes(PRECIOUS)
    mode = 0o444 if request.param == "read-only" else 0o644
    path.chmod(mode)
    return Victim(path, PRECIOUS, mode)


@pytest.fixture()
def victim_dir(tmp_path: Path) -> Path:
    """A folder outside every run (as /etc would be) with one file in it."""
    d = tmp_path / "elsewhere-dir"
    d.mkdir()
    (d / "passwd").write_bytes(PRECIOUS)
    return d


def plant(link: Path, target: Path) -> Path:
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(target)
    return link


def refused(res: CliResult, link: Path, target: Path, found: str = "a symbolic link") -> None:
    """One line naming the link and what it is, exit 2; the link still there, pointing where it did."""
    line = one_line_error(res, f"{link} is {found}", "remove it")
    assert "Traceback" not in res.stderr and "Errno" not in line
    assert link.is_symlink() and os.readlink(link) == str(target)


def dir_untouched(d: Path) -> None:
    assert sorted(p.name for p in d.iterdir()) == ["passwd"]
    assert (d / "passwd").read_bytes() == PRECIOUS


def positioning_data(tmp_path: Path) -> Path:
    """Readings of a small ISO 230-2 test (2 runs each way, 5 targets) to import."""
    rows = ["run,direction,target_mm,reading_mm"]
    for run in (1, 2):
        for direction in (1, -1):
            for target in (0.0, 25.0, 50.0, 75.0, 100.0):
                rows.append(f"{run},{direction},{target},{target + 0.001 * run}")
    path = tmp_path / "data.csv"
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture(scope="module")
def interrupted_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated straightness run of 5 stations cut to its first 2 points, in progress: what a killed
    acquisition leaves (``acquire --resume ... --simulate`` continues it)."""
    run = tmp_path_factory.mktemp("interrupted") / "run"
    assert guideway("demo", "--out", run, "--stations", "5").returncode == 0
    shutil.rmtree(run / "results")
    lines = (run / "points.csv").read_text().splitlines(keepends=True)
    (run / "points.csv").write_text("".join(lines[:3]))
    meta = json.loads((run / "run.json").read_text())
    meta.update(status="in-progress", points=2)
    meta.pop("ended")
    (run / "run.json").write_text(json.dumps(meta))
    return run


def resumable_copy(run: Path, tmp_path: Path, name: str) -> Path:
    dest = tmp_path / name
    shutil.copytree(run, dest)
    return dest


def test_the_interrupted_run_resumes(tmp_path: Path, interrupted_run: Path) -> None:
    """(What the refusals below are measured against: without a planted link the run is continued.)"""
    run = resumable_copy(interrupted_run, tmp_path, "run")
    assert guideway("acquire", "--resume", run, *SIMULATE).returncode == 0
    assert len((run / "points.csv").read_text().splitlines()) == 1 + 5


# --- the writer lock: every writer of a run takes it --------------------------------------------------


def test_acquire_refuses_a_lock_file_that_is_a_link(tmp_path: Path, victim: Victim) -> None:
    out = tmp_path / "run"
    link = plant(out / LOCK_NAME, victim.path)
    res = guideway("acquire", "straightness", "--setup", ROOT / "docs" / "setup-straightness.toml", "--out", out,
                   *SIMULATE)
    refused(res, link, victim.path)
    victim.untouched()
    assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]  # no run started


def test_resume_refuses_a_lock_file_that_is_a_link(tmp_path: Path, interrupted_run: Path, victim: Victim) -> None:
    run = resumable_copy(interrupted_run, tmp_path, "run")
    points = (run / "points.csv").read_bytes()
    link = plant(run / LOCK_NAME, victim.path)
    refused(guideway("acquire", "--resume", run, *SIMULATE), link, victim.path)
    victim.untouched()
    assert (run / "points.csv").read_bytes() == points


def test_import_refuses_a_lock_file_that_is_a_link(tmp_path: Path, victim: Victim) -> None:
    out = tmp_path / "run"
    link = plant(out / LOCK_NAME, victim.path)
    res = guideway("import", "positioning", positioning_data(tmp_path), "--out", out, "--compensated")
    refused(res, link, victim.path)
    victim.untouched()
    assert not list(tmp_path.glob(".run.*"))  # no temporary run left next to it


def test_simulate_refuses_a_lock_file_that_is_a_link(tmp_path: Path, victim: Victim) -> None:
    out = tmp_path / "run"
    link = plant(out / LOCK_NAME, victim.path)
    refused(guideway("simulate", ROOT / "docs" / "scenario-positioning.toml", "--out", out), link, victim.path)
    victim.untouched()


def test_demo_refuses_a_lock_file_that_is_a_link(tmp_path: Path, victim: Victim) -> None:
    out = tmp_path / "run"
    link = plant(out / LOCK_NAME, victim.path)
    refused(guideway("demo", "--out", out, "--stations", "3"), link, victim.path)
    victim.untouched()


def test_a_leftover_partial_with_a_planted_lock_link_does_not_block_import(tmp_path: Path, victim: Victim) -> None:
    """A temporary run directory of a killed import (its pid gone) is cleaned by the next import to the
    same --out; one whose lock is a planted link is left alone (neither locked nor removed), not a reason
    to refuse the import."""
    import subprocess
    import sys

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    leftover = tmp_path / f".run.{dead.pid}-0123abcd.partial"
    link = plant(leftover / LOCK_NAME, victim.path)
    res = guideway("import", "positioning", positioning_data(tmp_path), "--out", tmp_path / "run", "--compensated")
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "run" / "run.json").is_file()
    assert link.is_symlink() and os.readlink(link) == str(victim.path)
    victim.untouched()


@pytest.mark.parametrize("kind", ["a dangling symbolic link", "a directory", "a named pipe (FIFO)",
                                  "a hard link of another file"])
def test_a_lock_path_that_is_not_a_plain_file_of_its_own_is_refused(tmp_path: Path, kind: str) -> None:
    """Whatever stands at the lock's name, the writer neither opens it for writing nor waits on it
    (a pipe opened for writing blocks until a reader comes), nor removes it."""
    run = tmp_path / "run"
    run.mkdir()
    path = run / LOCK_NAME
    other = tmp_path / "other.txt"
    other.write_bytes(PRECIOUS)
    if kind == "a dangling symbolic link":
        path.symlink_to(tmp_path / "nowhere" / "created-by-the-writer")
    elif kind == "a directory":
        path.mkdir()
        (path / "inside").write_bytes(PRECIOUS)
    elif kind == "a named pipe (FIFO)":
        os.mkfifo(path)
    else:
        os.link(other, path)
    before = os.stat(path, follow_symlinks=False)
    found = "a symbolic link" if kind == "a dangling symbolic link" else kind
    with pytest.raises(UnsafeFileError, match=f"^{re.escape(str(path))} is {re.escape(found)}, .*remove it"):
        take_run_lock(run)
    after = os.stat(path, follow_symlinks=False)
    assert (after.st_ino, after.st_mode) == (before.st_ino, before.st_mode)
    assert other.read_bytes() == PRECIOUS
    assert not (tmp_path / "nowhere").exists()
    if kind == "a directory":
        assert (path / "inside").read_bytes() == PRECIOUS
    # and from the command line: one line, exit 2
    res = guideway("import", "positioning", positioning_data(tmp_path), "--out", run, "--compensated")
    one_line_error(res, f"{path} is {found}")


# --- points.csv: created new, appended to on resume ----------------------------------------------------


def test_resume_refuses_points_that_are_a_link_to_another_runs_points(tmp_path: Path, interrupted_run: Path) -> None:
    """The cunning case: the link names a valid points file (another run's), so the run reads well -
    and resuming it would append this run's points to the other run."""
    other = resumable_copy(interrupted_run, tmp_path, "other")
    theirs = (other / "points.csv").read_bytes()
    run = resumable_copy(interrupted_run, tmp_path, "run")
    (run / "points.csv").unlink()
    link = plant(run / "points.csv", other / "points.csv")
    refused(guideway("acquire", "--resume", run, *SIMULATE), link, other / "points.csv")
    assert (other / "points.csv").read_bytes() == theirs


@pytest.mark.parametrize("new", [True, False])
def test_points_are_never_opened_through_a_link(tmp_path: Path, victim: Victim, new: bool) -> None:
    """The store's own opening of points.csv (a new run: O_EXCL; a resumed one: O_NOFOLLOW), whatever
    the directory looked like when it was checked."""
    link = plant(tmp_path / "run" / "points.csv", victim.path)
    with pytest.raises(UnsafeFileError, match=f"^{link} is a symbolic link"):
        open_points(link, new=new)
    victim.untouched()
    assert link.is_symlink()


def test_resume_refuses_points_with_another_hard_link(tmp_path: Path, interrupted_run: Path) -> None:
    """Appending to a file with a second name changes the other name's file as well."""
    other = resumable_copy(interrupted_run, tmp_path, "other")
    theirs = (other / "points.csv").read_bytes()
    run = resumable_copy(interrupted_run, tmp_path, "run")
    (run / "points.csv").unlink()
    os.link(other / "points.csv", run / "points.csv")
    one_line_error(guideway("acquire", "--resume", run, *SIMULATE), f"{run / 'points.csv'} is a file with other "
                   "hard links", "give the run its own copy")
    assert (other / "points.csv").read_bytes() == theirs
    # the advice given: a copy of its own, then the run resumes (and the other run stays as it was)
    shutil.copyfile(run / "points.csv", run / "points.csv.own")
    os.replace(run / "points.csv.own", run / "points.csv")
    assert guideway("acquire", "--resume", run, *SIMULATE).returncode == 0
    assert (other / "points.csv").read_bytes() == theirs


# --- files written into a run's results/ (and a volumetric --out folder) -------------------------------


@pytest.fixture(scope="module")
def positioning_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated positioning run (kept clean: each test works on a copy)."""
    out = tmp_path_factory.mktemp("pos") / "run"
    assert guideway("simulate", ROOT / "docs" / "scenario-positioning.toml", "--out", out).returncode == 0
    return out


def copy_of(run: Path, tmp_path: Path) -> Path:
    dest = tmp_path / "run"
    shutil.copytree(run, dest, symlinks=True)
    return dest


def test_report_refuses_a_link_at_its_file(tmp_path: Path, victim: Victim) -> None:
    run = copy_of(V1_RUN, tmp_path)
    link = plant(run / "results" / "report.html", victim.path)
    refused(guideway("report", run, "--mc-trials", "0"), link, victim.path)
    victim.untouched()


def test_report_refuses_a_results_folder_that_is_a_link(tmp_path: Path, victim_dir: Path) -> None:
    run = copy_of(V1_RUN, tmp_path)
    shutil.rmtree(run / "results", ignore_errors=True)
    link = plant(run / "results", victim_dir)
    refused(guideway("report", run, "--mc-trials", "0"), link, victim_dir)
    dir_untouched(victim_dir)


def test_report_refuses_a_dangling_results_link(tmp_path: Path) -> None:
    run = copy_of(V1_RUN, tmp_path)
    shutil.rmtree(run / "results", ignore_errors=True)
    link = plant(run / "results", tmp_path / "nowhere")
    refused(guideway("report", run, "--mc-trials", "0"), link, tmp_path / "nowhere")
    assert not (tmp_path / "nowhere").exists()


def test_process_refuses_a_results_folder_that_is_a_link(tmp_path: Path, victim_dir: Path) -> None:
    """(``process`` refused this before: results/ is exchanged as a whole, a link is no folder.)"""
    run = copy_of(V1_RUN, tmp_path)
    shutil.rmtree(run / "results", ignore_errors=True)
    link = plant(run / "results", victim_dir)
    res = guideway("process", run, "--mc-trials", "0")
    one_line_error(res, f"{link} is not a directory")
    assert link.is_symlink()
    dir_untouched(victim_dir)


def test_export_refuses_a_link_at_its_default_file(tmp_path: Path, positioning_run: Path, victim: Victim) -> None:
    run = copy_of(positioning_run, tmp_path)
    link = plant(run / "results" / "compensation-csv.csv", victim.path)
    refused(guideway("export", run, "--format", "csv"), link, victim.path)
    victim.untouched()


def test_export_refuses_a_results_folder_that_is_a_link(tmp_path: Path, positioning_run: Path,
                                                        victim_dir: Path) -> None:
    run = copy_of(positioning_run, tmp_path)
    shutil.rmtree(run / "results", ignore_errors=True)
    link = plant(run / "results", victim_dir)
    refused(guideway("export", run, "--format", "csv"), link, victim_dir)
    dir_untouched(victim_dir)


def test_diagnose_refuses_to_write_through_a_results_link(tmp_path: Path, positioning_run: Path,
                                                          victim_dir: Path) -> None:
    """``--out`` and ``--report`` named inside the run: its folders are the run's, links refused."""
    run = copy_of(positioning_run, tmp_path)
    shutil.rmtree(run / "results", ignore_errors=True)
    link = plant(run / "results", victim_dir)
    refused(guideway("diagnose", run, "--out", run / "results" / "model.toml"), link, victim_dir)
    refused(guideway("diagnose", run, "--report", run / "results" / "diagnosis.html"), link, victim_dir)
    dir_untouched(victim_dir)


def test_diagnose_out_inside_the_run_refuses_a_link_at_the_file(tmp_path: Path, positioning_run: Path,
                                                                victim: Victim) -> None:
    run = copy_of(positioning_run, tmp_path)
    link = plant(run / "model.toml", victim.path)
    refused(guideway("diagnose", run, "--out", link), link, victim.path)
    victim.untouched()


def test_diagnose_out_outside_a_run_replaces_a_link_never_writes_through_it(tmp_path: Path, positioning_run: Path,
                                                                           victim: Victim) -> None:
    """A file the user names outside any run: the rename replaces the link itself (as ``gcode --out``)."""
    link = plant(tmp_path / "mine" / "model.toml", victim.path)
    res = guideway("diagnose", positioning_run, "--out", link)
    assert res.returncode == 0, res.stderr
    victim.untouched()
    assert not link.is_symlink() and "[" in link.read_text()


def test_compare_report_inside_a_run_refuses_a_results_link(tmp_path: Path, positioning_run: Path,
                                                            victim_dir: Path) -> None:
    """A report named inside a run is written as the run's own files are (fleet's compare, here)."""
    run = copy_of(positioning_run, tmp_path)
    shutil.rmtree(run / "results", ignore_errors=True)
    link = plant(run / "results", victim_dir)
    res = guideway("compare", positioning_run, run, "--report", run / "results" / "compare.html")
    refused(res, link, victim_dir)
    dir_untouched(victim_dir)


def test_volumetric_refuses_a_link_in_its_out_folder(tmp_path: Path, victim: Victim) -> None:
    out = tmp_path / "vol"
    link = plant(out / "report.html", victim.path)
    res = guideway("volumetric", ROOT / "docs" / "machine-example.toml", "--out", out, "--grid", "3")
    refused(res, link, victim.path)
    victim.untouched()


def test_volumetric_export_refuses_a_link_in_its_out_folder(tmp_path: Path, victim: Victim) -> None:
    out = tmp_path / "vol"
    link = plant(out / "cross-terms.csv", victim.path)
    res = guideway("volumetric", ROOT / "docs" / "machine-example.toml", "--export", "csv", "--out", out)
    refused(res, link, victim.path)
    victim.untouched()


def test_the_atomic_writer_inside_a_run(tmp_path: Path, victim: Victim) -> None:
    """The one door every file goes through: below a run.json, a link at the file, a FIFO at the file or a
    link in place of a folder is refused; the run's own files are written as ever."""
    run = copy_of(V1_RUN, tmp_path)
    link = plant(run / "results" / "x.txt", victim.path)
    with pytest.raises(UnsafeFileError, match=f"^{link} is a symbolic link"):
        write_text_atomic(link, "new\n")
    os.mkfifo(run / "results" / "pipe")
    with pytest.raises(UnsafeFileError, match="is a named pipe"):
        write_text_atomic(run / "results" / "pipe", "new\n")
    plant(run / "sub", victim.path.parent)
    with pytest.raises(UnsafeFileError, match=f"^{run / 'sub'} is a symbolic link, not a directory"):
        write_text_atomic(run / "sub" / "victim.txt", "new\n")
    victim.untouched()
    write_text_atomic(run / "results" / "new" / "y.txt", "fine\n", make_parents=True)
    assert (run / "results" / "new" / "y.txt").read_text() == "fine\n"
    assert not list((run / "results").rglob(".*.tmp"))  # no temporary file left


def swap_results_for_a_link(run: Path, target: Path) -> None:
    """What an attacker racing ``process`` does: results/ moved away, a link to ``target`` in its place."""
    os.rename(run / "results", run.parent / "moved-away")
    (run / "results").symlink_to(target)


def test_process_never_lists_a_results_link_swapped_in_after_its_check(tmp_path: Path, victim_dir: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """results/ turns into a link between process's check and its listing of the files to carry over: the
    listing must not follow it (it would hard-link the target's files into the run)."""
    from saved_runs.results import result_set

    run = copy_of(V1_RUN, tmp_path)
    assert guideway("process", run, "--mc-trials", "0").returncode == 0
    real = result_set.remove_stale_temps

    def then_swap(directory: Path) -> list[str]:
        removed = real(directory)
        if directory == run / "results":  # called just after the check
            swap_results_for_a_link(run, victim_dir)
        return removed

    monkeypatch.setattr(result_set, "remove_stale_temps", then_swap)
    res = guideway("process", run, "--mc-trials", "0")
    one_line_error(res, f"{run / 'results'} is not a directory")
    dir_untouched(victim_dir)
    assert (victim_dir / "passwd").stat().st_nlink == 1  # not hard-linked into the run
    assert os.readlink(run / "results") == str(victim_dir)


def test_process_never_carries_files_from_a_results_link_swapped_in_before_the_exchange(
        tmp_path: Path, victim_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """results/ turns into a link just before the exchange: the exchange moves the link aside, and the
    files it points to must not be "carried over" into the new results/ (moved out of their folder)."""
    from saved_runs.results import result_set

    run = copy_of(V1_RUN, tmp_path)
    assert guideway("process", run, "--mc-trials", "0").returncode == 0
    real = result_set.fsync_dir

    def then_swap(path: Path) -> None:
        real(path)
        if path.name.startswith(".results.") and (run / "results").is_dir() and not (run / "results").is_symlink():
            swap_results_for_a_link(run, victim_dir)  # the new set is complete: next comes the exchange

    monkeypatch.setattr(result_set, "fsync_dir", then_swap)
    res = guideway("process", run, "--mc-trials", "0")
    assert "Traceback" not in res.stderr
    dir_untouched(victim_dir)
    assert not (run / "results" / "passwd").exists()
