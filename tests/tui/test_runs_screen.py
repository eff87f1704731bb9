"""The runs browser: points on disk, damaged runs, statuses in full at 80 columns, Home / End."""

from __future__ import annotations

import asyncio
import json
import shutil
from pathlib import Path
from typing import Any

from saved_runs.catalog.folder import list_runs
from tests.tui.sessions import screen_lines
from tui.app import GuidewayApp

ROOT = Path(__file__).resolve().parents[2]
RUNS = ROOT / "tests/data/tui-runs"


def copy_run(name: str, to: Path, **meta: Any) -> Path:
    """A copy of a saved test run with run.json keys replaced (None: removed)."""
    run = to / name
    shutil.copytree(RUNS / name, run)
    data = json.loads((run / "run.json").read_text())
    for k, v in meta.items():
        if v is None:
            data.pop(k, None)
        else:
            data[k] = v
    (run / "run.json").write_text(json.dumps(data))
    return run


def data_lines(run: Path) -> int:
    return len((run / "points.csv").read_text().splitlines()) - 1  # less the header


def test_an_in_progress_run_shows_the_points_on_disk(tmp_path: Path) -> None:
    # a run that crashed: run.json counts its points only when a run ends
    run = copy_run("straightness-aborted", tmp_path, status="in-progress", points=None)
    (s,) = list_runs(tmp_path)
    setup = json.loads((run / "run.json").read_text())["setup"]
    assert s.points == data_lines(run) == 8
    assert s.planned == setup["stations"] * 2  # forward and return pass
    assert s.points_text == "8/24" and s.resumable


def test_a_damaged_points_file_marks_the_run_damaged(tmp_path: Path) -> None:
    run = copy_run("straightness-bed", tmp_path)
    lines = (run / "points.csv").read_text().splitlines(keepends=True)
    lines[5] = lines[5].replace(",", ";", 1)  # a torn row: one field fewer
    (run / "points.csv").write_text("".join(lines))
    (s,) = list_runs(tmp_path)
    assert s.status == "damaged" and "line 6" in s.problem and not s.resumable


def test_a_number_that_is_not_one_and_a_count_that_disagrees_are_damage(tmp_path: Path) -> None:
    a = copy_run("positioning-x", tmp_path)
    text = (a / "points.csv").read_text().splitlines(keepends=True)
    (a / "points.csv").write_text("".join(text[:-1]))  # complete, but one point fewer than run.json says
    b = copy_run("straightness-bed", tmp_path)
    (b / "points.csv").write_text((b / "points.csv").read_text().replace("\n1,", "\nx1,", 1))
    found = {r.path.name: r for r in list_runs(tmp_path)}
    assert found["positioning-x"].status == "damaged" and "29 points" in found["positioning-x"].problem
    assert found["straightness-bed"].status == "damaged" and "not a number" in found["straightness-bed"].problem


def test_a_partial_last_line_is_no_damage(tmp_path: Path) -> None:
    run = copy_run("straightness-aborted", tmp_path)
    with (run / "points.csv").open("a") as f:
        f.write("9,900.0,12.")  # killed in the middle of a write
    (s,) = list_runs(tmp_path)
    assert s.status == "aborted" and s.points == 8 and not s.problem


def browse(runs_dir: Path, keys: tuple[str, ...] = (), size: tuple[int, int] = (80, 24)) -> tuple[list[str], int]:
    out: list[Any] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=runs_dir, start="runs")
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            for k in keys:
                await pilot.press(k)
                await pilot.pause()
            out.append((screen_lines(app), app.screen.query_one("#runs-table").cursor_row))

    asyncio.run(main())
    return out[0]


def test_statuses_are_whole_at_80_columns_and_home_end_move_the_cursor(tmp_path: Path) -> None:
    copy_run("straightness-aborted", tmp_path, status="in-progress", points=None)
    bad = copy_run("straightness-bed", tmp_path)
    (bad / "points.csv").write_text((bad / "points.csv").read_text().replace(",", ";", 20))
    copy_run("positioning-x", tmp_path)
    lines, row = browse(tmp_path, ("end",))
    text = "\n".join(lines)
    assert "in-progress" in text and "damaged" in text and "8/24" in text
    assert row == 2 and "positioning-x" in lines[-3] + lines[-2]  # the oldest run, told in full below the table
    _, row = browse(tmp_path, ("end", "home"))
    assert row == 0


def test_wide_terminal_lists_one_run_per_line(tmp_path: Path) -> None:
    for name in ("straightness-aborted", "straightness-bed", "positioning-x"):
        copy_run(name, tmp_path)
    lines, _ = browse(tmp_path, size=(160, 48))
    rows = [ln for ln in lines if "Machine 7" in ln]
    assert len(rows) == 3 and all("2026-" in ln for ln in rows)  # name and creation time on the same line
