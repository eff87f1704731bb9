"""The runs browser (issue 25): machine and axis names whole at 80 and 160 columns, however long the run's
name; an empty aborted run (F5, then q before the first point) marked as empty."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from tests.tui.sessions import screen_lines
from tests.tui.test_runs_screen import copy_run
from tui.app import GuidewayApp

MACHINE = "Machine 7, bed"
AXIS = "Y straightness of the long bed"
LONG_NAME = "straightness-bed-2026-11-25-long"  # 32 characters: the widest name column, the least left over


def browse(runs: Path, size: tuple[int, int]) -> tuple[Any, list[str]]:
    out: list[Any] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=runs, start="runs")
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            await pilot.pause()
            out.append((app.screen.runs, screen_lines(app)))

    asyncio.run(main())
    return out[0]


def column(lines: list[str], label: str, until: str | None) -> str:
    """The text of a table column from its header's place to the next header's, all rows, spaces squeezed."""
    head = next(i for i, ln in enumerate(lines) if " status " in ln and " points " in ln)
    start = lines[head].index(label)
    end = lines[head].index(until) if until else None
    return " ".join(" ".join(ln[start:end] for ln in lines[head + 1:]).split())


@pytest.mark.parametrize("size", [(80, 24), (160, 48)])
def test_machine_and_axis_are_whole(tmp_path: Path, size: tuple[int, int]) -> None:
    run = copy_run("straightness-bed", tmp_path, machine=MACHINE, axis=AXIS)
    run.rename(tmp_path / LONG_NAME)
    _, lines = browse(tmp_path, size)
    assert MACHINE in column(lines, "machine", None)
    wide = size[0] >= 120
    axis = column(lines, "axis" if wide else "kind · axis", "status")
    assert AXIS in axis, axis


def test_an_empty_aborted_run_is_marked(tmp_path: Path) -> None:
    copy_run("straightness-bed", tmp_path)
    empty = copy_run("straightness-aborted", tmp_path / "x", points=0)
    header = (empty / "points.csv").read_text().splitlines(keepends=True)[0]
    (empty / "points.csv").write_text(header)  # F5, then q: the run opened, no point taken
    empty = empty.rename(tmp_path / "straightness-empty")
    assert json.loads((empty / "run.json").read_text())["status"] == "aborted"
    runs, lines = browse(tmp_path, (80, 24))
    row = next(i for i, ln in enumerate(lines) if ln.startswith(" straightness-empty"))
    assert " empty " in lines[row]
    other = next(i for i, ln in enumerate(lines) if ln.startswith(" straightness-bed"))
    assert " complete " in lines[other] and " empty " not in lines[other]
