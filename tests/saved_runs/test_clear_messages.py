"""Messages that were unclear (issue 18, "Also"): each is one line naming the file and what is wrong."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest

from processing.iso230_2 import evaluate_iso230_2

from ..cli import ROOT, guideway, one_line_error

V1_RUN = ROOT / "tests" / "data" / "runs" / "v1-straightness"


def _run_with(tmp_path: Path, change) -> Path:  # noqa: ANN001
    run = tmp_path / "run"
    shutil.copytree(V1_RUN, run)
    meta = json.loads((run / "run.json").read_text())
    change(meta)
    (run / "run.json").write_text(json.dumps(meta))
    return run


def test_a_run_without_setup_says_the_geometry_is_missing(tmp_path: Path) -> None:
    run = _run_with(tmp_path, lambda m: m.pop("setup"))
    line = one_line_error(guideway("process", run, "--no-write"), f"{run}/run.json", "no setup.geometry")
    assert "('setup')" not in line


def test_a_bogus_axis_type_names_the_file(tmp_path: Path) -> None:
    def positioning(meta: dict) -> None:
        meta.update(kind="positioning", axis_type="diagonal")

    run = _run_with(tmp_path, positioning)
    one_line_error(guideway("process", run, "--no-write"), f"{run}/run.json", "'diagonal'", "linear or rotary")


def test_a_point_on_disk_twice_names_run_direction_target_and_lines(tmp_path: Path) -> None:
    data = tmp_path / "pos.csv"
    data.write_text("run,direction,target_mm,reading_mm\n" + "".join(
        f"1,{d},{t},{t}\n" for d in (1, -1) for t in (0.0, 100.0, 200.0, 300.0, 400.0)))
    out = tmp_path / "pos"
    assert guideway("import", "positioning", data, "--out", out, "--compensated").returncode == 0
    lines = (out / "points.csv").read_text().splitlines()
    lines.append(lines[2])  # the second point (run 1, direction +1, target 2) again, as the last line
    (out / "points.csv").write_text("\n".join(lines) + "\n")
    one_line_error(guideway("process", out, "--no-write"), f"points.csv:{len(lines)}", "run 1", "direction +1",
                   "target 2", "first on line 3")


def test_the_iso230_2_duplicate_message_names_the_point() -> None:
    rows = [(i, float(t), d, 1, 0.0) for d in (1, -1) for i, t in enumerate((0, 100, 200, 300, 400), start=1)]
    rows.append((3, 200.0, -1, 1, 0.5))  # target 3, direction -1, run 1 twice
    dev = pd.DataFrame(rows, columns=["target_index", "target", "direction", "run", "deviation"])
    with pytest.raises(ValueError, match="target 3, direction -1, run 1"):
        evaluate_iso230_2(dev, axis_type="linear")


def test_a_read_only_run_directory_is_one_clear_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``process`` of a run the user may not write to (root, who runs these tests, may write anywhere:
    the refusal is put in place of the system call that creates the results' temporary files)."""
    import errno
    import os

    from saved_runs.store import files

    run = tmp_path / "run"
    shutil.copytree(V1_RUN, run)
    shutil.rmtree(run / "results", ignore_errors=True)
    real_open = os.open

    def read_only(path: str, flags: int, *args: int, dir_fd: int | None = None) -> int:
        # files are created relative to their opened directory (saved_runs/store/files.py): where is that?
        where = str(path) if dir_fd is None else os.path.join(os.readlink(f"/proc/self/fd/{dir_fd}"), path)
        if where.startswith(str(run)) and flags & os.O_CREAT:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), where)
        return real_open(path, flags, *args, dir_fd=dir_fd)

    monkeypatch.setattr(files.os, "open", read_only)
    line = one_line_error(guideway("process", run, "--mc-trials", "0"), str(run), "Permission denied",
                          "copy the run elsewhere")
    assert "Errno" not in line
