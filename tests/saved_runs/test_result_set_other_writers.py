"""results/ swapped in one step (saved_runs/results/result_set.py) while another command (``report``,
``export``) writes its own file into results/: that file is neither lost nor replaced by its older copy."""

from __future__ import annotations

from pathlib import Path

import pytest

from saved_runs.results import result_set
from saved_runs.store.files import write_text_atomic


def _evaluation(directory: Path) -> None:
    (directory / "summary.json").write_text('{"new": true}\n')


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two-renames"])
def test_a_report_written_while_the_set_is_swapped_in_is_kept(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                              exchange: bool) -> None:
    results = tmp_path / "run" / "results"
    results.mkdir(parents=True)
    (results / "summary.json").write_text('{"new": false}\n')
    (results / "report.html").write_text("old report")
    (results / "compensation-csv.csv").write_text("old table")
    real_fsync_dir = result_set.fsync_dir
    wrote = []

    def other_command_writes(path: Path) -> None:
        # the moment after the other files of results/ were carried over and before the swap: ``report``
        # replaces report.html and ``export`` writes a new table (as they do: write_text_atomic into results/)
        if not wrote:
            write_text_atomic(results / "report.html", "new report")
            write_text_atomic(results / "compensation-fanuc.txt", "new table")
            wrote.append(path)
        real_fsync_dir(path)

    monkeypatch.setattr(result_set, "fsync_dir", other_command_writes)
    if not exchange:
        monkeypatch.setattr(result_set, "_exchange", lambda a, b: False)
    result_set.write_result_set(results, _evaluation)
    assert wrote
    assert (results / "summary.json").read_text() == '{"new": true}\n'
    assert (results / "report.html").read_text() == "new report"
    assert (results / "compensation-fanuc.txt").read_text() == "new table"
    assert (results / "compensation-csv.csv").read_text() == "old table"
    assert [p.name for p in results.parent.iterdir()] == ["results"]  # nothing temporary left
