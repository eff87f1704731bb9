"""The TUI's fleet overview: opened from the runs browser with one key (``o``), the rows most urgent first;
Enter opens the selected row's trend."""

from __future__ import annotations

import asyncio
from pathlib import Path

from textual.widgets import DataTable

from tests.cli import guideway
from tui.app import GuidewayApp
from tui.screens.fleet import FleetScreen
from tui.screens.runs import RunsScreen
from tui.screens.trend import TrendScreen

from .runs import straightness_summary, write_run


def test_the_runs_browser_opens_the_fleet_overview(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    runs = tmp_path / "runs"
    for i in range(3):  # X: 5.0, 5.5, 6.0 one year apart, limit 5.8: beyond since x2; Y: one run, limit far
        write_run(runs, f"x{i}", created=f"{2023 + i}-01-01T00:00:00Z",
                  summary=straightness_summary(5.0 + 0.5 * i, 0.1),
                  tolerance={"straightness_um": 5.8, "reference_line": "minimum_zone"})
    write_run(runs, "y0", axis="Y", created="2020-06-01T00:00:00Z", summary=straightness_summary(1.0, 0.1),
              tolerance={"straightness_um": 9.0, "reference_line": "minimum_zone"})
    assert guideway("catalog", "add", "--scan", runs, "--catalog", url).returncode == 0
    seen = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=runs, start="runs", catalog_url=url)
        async with app.run_test(size=(140, 30)) as pilot:
            for k in ("", "o", "enter", "escape", "escape"):
                if k:
                    await pilot.press(k)
                await pilot.pause()
                await app.workers.wait_for_complete()
                await pilot.pause()
                screen = app.screen
                rows = []
                if isinstance(screen, FleetScreen):
                    table = screen.query_one(DataTable)
                    rows = [[str(c) for c in table.get_row_at(i)] for i in range(table.row_count)]
                seen.append((type(screen), rows, {k for k, b in app.active_bindings.items() if b.enabled}))

    asyncio.run(main())
    (start, _, keys), (fleet, rows, _), (trend, _, _), (back, rows_again, _), (end, _, _) = seen
    assert start is RunsScreen and "o" in keys
    assert fleet is FleetScreen
    assert [(r[0], r[1], r[2]) for r in rows] == [("mill-1", "X", "minimum_zone"), ("mill-1", "Y", "minimum_zone")]
    assert rows[0][8] == "BEYOND since 2025-01-01" and rows[0][4] == "6.000 ± 0.200"
    assert rows[1][8] == "no date: < 3 runs"
    assert trend is TrendScreen and back is FleetScreen and rows_again == rows and end is RunsScreen


def test_without_a_catalogue_the_key_is_not_offered(tmp_path: Path) -> None:
    write_run(tmp_path, "a", summary=straightness_summary(1.0, 0.1))
    offered: set[str] = set()

    async def main() -> None:
        app = GuidewayApp(runs_dir=tmp_path, start="runs", catalog_url=None)
        async with app.run_test(size=(100, 30)) as pilot:
            await pilot.pause()
            offered.update(k for k, b in app.active_bindings.items() if b.enabled)
            await pilot.press("o")
            await pilot.pause()
            assert isinstance(app.screen, RunsScreen)

    asyncio.run(main())
    assert "o" not in offered
