"""Temporary directories of runs written at once (saved_runs/store/whole.py): the next writer to the same
``--out`` removes those of dead writers, never one a live writer has just made and not locked yet."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from saved_runs.store import whole
from saved_runs.store.lock import take_run_lock


def test_a_partial_just_made_by_a_live_writer_is_not_removed(tmp_path: Path) -> None:
    # writer A has made its temporary directory and not yet taken its lock (write_whole_run does both in turn)
    partial = whole._make_partial(tmp_path, "run")
    # writer B, to the same --out, cleans up meanwhile: A's directory is not a leftover
    whole._remove_stale_partials(tmp_path, "run")
    assert partial.is_dir()
    take_run_lock(partial).release()  # and A goes on


def test_a_partial_of_a_dead_writer_is_removed(tmp_path: Path) -> None:
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True,
                          check=True)
    pid = int(dead.stdout)
    left = tmp_path / f".run.{pid}-0123abcd{whole.PARTIAL_SUFFIX}"
    left.mkdir()
    (left / "points.csv").write_text("half")
    older = tmp_path / f".run.0123abcd{whole.PARTIAL_SUFFIX}"  # a name of the version before, its lock free
    older.mkdir()
    whole._remove_stale_partials(tmp_path, "run")
    assert not left.exists() and not older.exists()
