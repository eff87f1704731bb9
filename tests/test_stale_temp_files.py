"""A killed ``export`` or ``volumetric`` leaves the temporary files of its atomic writes
(``.NAME.PID-HEX.tmp``, saved_runs/store/files.py); a successful rerun removes those of its own
outputs, and nothing else: not another output's, not a live process's, not a symlink or a directory
of that name (issue 25).  The leftovers are planted as a SIGKILL leaves them: a regular file named
for the output, holding part of it, with the pid of a process that has ended."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from tests.cli import guideway
from tests.test_export_end_to_end import write_run

from .test_cli_volumetric import EXAMPLE

GRID_FILES = ("volumetric.csv", "contributions.csv", "summary.json", "report.html")


def dead_pid() -> int:
    """The pid of a process that has ended (and been reaped)."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def plant(directory: Path, name: str, pid: int, hexpart: str = "0badf00d") -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f".{name}.{pid}-{hexpart}.tmp"
    path.write_text("half a table\n")
    return path


def others(directory: Path, name: str) -> list[Path]:
    """Entries of the temporary-name pattern of ``name`` a rerun must keep: a live writer's file, a
    symlink (whose target must stay too) and a directory of a dead pid's name."""
    target = directory.parent / f"target-of-{name}"
    target.write_text("not the tool's\n")
    live = plant(directory, name, os.getpid(), "11111111")
    link = directory / f".{name}.{dead_pid()}-22222222.tmp"
    link.symlink_to(target)
    subdir = directory / f".{name}.{dead_pid()}-33333333.tmp"
    subdir.mkdir()
    return [live, link, subdir, target]


def test_export_rerun_removes_its_own_stale_temp_file(tmp_path: Path) -> None:
    run = tmp_path / "run"
    write_run(run)
    results = run / "results"
    stale = [plant(results, "compensation-linuxcnc.comp", dead_pid()),
             plant(results, "compensation-linuxcnc.comp", dead_pid(), "deadbeef")]
    foreign = plant(results, "compensation-fanuc.txt", dead_pid())  # another format's: not this command's kind
    keep = others(results, "compensation-linuxcnc.comp")
    res = guideway("export", run, "--format", "linuxcnc")
    assert res.returncode == 0, res.stderr
    assert (results / "compensation-linuxcnc.comp").is_file()
    assert not any(p.exists() for p in stale)
    assert foreign.exists() and all(p.exists() or p.is_symlink() for p in keep)
    assert keep[3].read_text() == "not the tool's\n"


def test_export_to_a_named_file_removes_its_stale_temp_file(tmp_path: Path) -> None:
    run = tmp_path / "run"
    write_run(run)
    out = tmp_path / "tables" / "x.comp"
    stale = plant(out.parent, "x.comp", dead_pid())
    assert guideway("export", run, "--format", "linuxcnc", "--out", out).returncode == 0
    assert out.is_file() and not stale.exists()


def test_volumetric_grid_rerun_removes_its_stale_temp_files(tmp_path: Path) -> None:
    out = tmp_path / "grid"
    stale = [plant(out, name, dead_pid()) for name in GRID_FILES]
    foreign = plant(out, "X.comp", dead_pid())  # an --export's table: not the grid's
    keep = others(out, "volumetric.csv")
    res = guideway("volumetric", EXAMPLE, "--out", out, "--grid", "3")
    assert res.returncode == 0, res.stderr
    assert all((out / name).is_file() for name in GRID_FILES)
    assert not any(p.exists() for p in stale)
    assert foreign.exists() and all(p.exists() or p.is_symlink() for p in keep)


def test_volumetric_export_rerun_removes_its_stale_temp_files(tmp_path: Path) -> None:
    out = tmp_path / "tables"
    first = guideway("volumetric", EXAMPLE, "--export", "linuxcnc", "--out", out, "--grid", "3")
    assert first.returncode == 0, first.stderr
    written = sorted(p.name for p in out.iterdir())
    assert "cross-terms.csv" in written and any(n.endswith(".comp") for n in written)
    stale = [plant(out, name, dead_pid()) for name in written]
    foreign = plant(out, "volumetric.csv", dead_pid())  # the grid's: not the export's
    keep = others(out, written[0])
    assert guideway("volumetric", EXAMPLE, "--export", "linuxcnc", "--out", out, "--grid", "3").returncode == 0
    assert not any(p.exists() for p in stale)
    assert foreign.exists() and all(p.exists() or p.is_symlink() for p in keep)


def test_volumetric_killed_mid_write_then_rerun_leaves_no_temp_file(tmp_path: Path) -> None:
    """The real thing: SIGKILL while a grid file is being written (its temporary file exists), then a rerun."""
    from tests.cli import kill_when

    out = tmp_path / "grid"

    def writing() -> bool:
        return out.is_dir() and any(p.name.endswith(".tmp") for p in out.iterdir())

    # 50 per axis: 125,000 poses, volumetric.csv and contributions.csv take a while to write
    kill_when(writing, "volumetric", EXAMPLE, "--out", out, "--grid", "50", tmp_dir=tmp_path / "tmp",
              what="a grid file being written")
    assert any(p.name.endswith(".tmp") for p in out.iterdir())  # what the kill left
    res = guideway("volumetric", EXAMPLE, "--out", out, "--grid", "3")
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in out.iterdir()) == sorted(GRID_FILES)


def test_export_into_a_linked_results_folder_sweeps_nothing_there(tmp_path: Path) -> None:
    """RUN/results a link to another folder: the export is refused (the writer follows no link inside a run)
    and the sweep does not reach through the link either: a file of the temporary-name pattern of a dead
    pid in the link's target stays."""
    run = tmp_path / "run"
    write_run(run)
    elsewhere = tmp_path / "elsewhere"
    victim = plant(elsewhere, "compensation-linuxcnc.comp", dead_pid())
    (run / "results").symlink_to(elsewhere, target_is_directory=True)
    res = guideway("export", run, "--format", "linuxcnc")
    assert res.returncode == 2
    assert victim.exists() and victim.read_text() == "half a table\n"
