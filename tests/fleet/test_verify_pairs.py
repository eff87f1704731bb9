"""As-found / as-left pairs among saved runs (fleet/verify/pairs.py): an export record of the run's own uid
makes the pair, a table written elsewhere (``export --out``) is still found from the runs folder."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

from fleet.verify.pairs import found_left_pairs, found_run_of
from tests.cli import guideway

RUN = Path(__file__).resolve().parents[1] / "data" / "tui-runs" / "positioning-x"


def measured_with(run: Path, table: Path, uid: str) -> None:
    meta = json.loads((run / "run.json").read_text())
    meta.update(uid=uid, compensation={"active": True, "file": table.name, "path": str(table), "format": "linuxcnc",
                                       "sha256": hashlib.sha256(table.read_bytes()).hexdigest()})
    (run / "run.json").write_text(json.dumps(meta))


def test_a_table_written_elsewhere_is_found_from_the_folder(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    found, left = runs / "found", runs / "left"
    shutil.copytree(RUN, found)
    shutil.copytree(RUN, left)
    table = tmp_path / "elsewhere.comp"  # not under FOUND/results: only exports.json links it
    assert guideway("export", found, "--format", "linuxcnc", "--out", table).returncode == 0
    measured_with(left, table, "uid-left")
    assert found_run_of(left, []) is None  # not where the table lies, and no folder to look in
    assert found_run_of(left, [runs]) == found
    pairs = found_left_pairs([left, found])
    assert pairs.found_of == {left: found} and pairs.lefts_of == {found: [left]}
    # a run measured with no table has no as-found run; a run is never its own
    assert found_run_of(found, [runs]) is None
    measured_with(found, table, json.loads((found / "run.json").read_text())["uid"])
    assert found_left_pairs([found]).found_of == {}


def test_a_table_in_the_found_runs_results_is_found_by_its_bytes_without_the_record(tmp_path: Path) -> None:
    found, left = tmp_path / "a" / "found", tmp_path / "b" / "left"  # different folders: no folder search
    shutil.copytree(RUN, found)
    shutil.copytree(RUN, left)
    assert guideway("export", found, "--format", "fanuc").returncode == 0
    table = found / "results" / "compensation-fanuc.txt"
    (found / "results" / "exports.json").unlink()
    measured_with(left, table, "uid-left")
    assert found_run_of(left, []) == found
    table.write_text(table.read_text() + "\n")  # other bytes than the run was measured with: not that table
    assert found_run_of(left, []) is None
