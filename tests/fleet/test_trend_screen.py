"""The TUI's trend screen, pushed in a test app, and the catalogue filter of the runs browser."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest
from textual.app import App
from textual.widgets import DataTable, Static

from fleet.catalog.browse import CatalogFilter, browse_catalog, trend_values
from tests.cli import guideway
from tui.screens.trend import TrendScreen
from tui.widgets.plot import Plot

from .runs import positioning_summary, straightness_summary, write_run


def catalogue(tmp_path: Path) -> str:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    # minimum zone 5.0, 5.5, 6.0 one year apart: +0.5 um/year exactly
    for i in range(3):
        write_run(tmp_path / "runs", f"x{i}", created=f"{2023 + i}-01-01T00:00:00Z",
                  summary=straightness_summary(5.0 + 0.5 * i, 0.1),
                  tolerance={"straightness_um": 7.0, "reference_line": "minimum_zone"})
    write_run(tmp_path / "runs", "y", axis="Y", created="2024-06-01T00:00:00Z", summary=straightness_summary(3.0, 0.1))
    write_run(tmp_path / "runs", "lathe", machine="lathe", axis="Z", kind="positioning",
              created="2025-03-01T00:00:00Z", summary=positioning_summary({"E": 2.0, "A": 4.0}))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0
    return url


def test_filter_helper(tmp_path: Path) -> None:
    url = catalogue(tmp_path)
    view = browse_catalog(url)
    assert view.machines == ["lathe", "mill-1"] and view.axes == ["X", "Y", "Z"]
    assert [r.path.name for r in view.runs] == ["lathe", "x2", "y", "x1", "x0"]  # newest first
    view = browse_catalog(url, CatalogFilter(machine="mill-1"))
    assert view.axes == ["X", "Y"] and {r.path.name for r in view.runs} == {"x0", "x1", "x2", "y"}
    view = browse_catalog(url, CatalogFilter(machine="mill-1", axis="X"))
    assert [r.path.name for r in view.runs] == ["x2", "x1", "x0"] and view.runs[0].kind == "straightness"
    assert trend_values(view.entries, "mill-1", "X") == ["minimum_zone", "least_squares", "endpoint"]


async def settle(app: App, pilot: Any) -> None:
    """The screen reads the catalogue in a worker: wait for it, then for the screen to show it."""
    await pilot.pause()
    await app.workers.wait_for_complete()
    await pilot.pause()


class TrendApp(App):
    def __init__(self, screen: TrendScreen) -> None:
        super().__init__()
        self.trend_screen = screen

    def on_mount(self) -> None:
        self.push_screen(self.trend_screen)


def test_trend_screen_shows_plot_table_and_fit(tmp_path: Path) -> None:
    url = catalogue(tmp_path)

    async def drive() -> None:
        screen = TrendScreen(url, "mill-1", "X", "minimum_zone")
        app = TrendApp(screen)
        async with app.run_test(size=(100, 40)) as pilot:
            await settle(app, pilot)
            table = screen.query_one(DataTable)
            assert table.row_count == 3
            assert [str(table.get_row_at(i)[1]) for i in range(3)] == ["5.000", "5.500", "6.000"]
            fit = str(screen.query_one("#trend-fit", Static).render())
            # +0.5 um/year from 5.0 in 2023-01-01 (years of 365.25 d): 7.0 is reached 4.0 years later
            assert "+0.500" in fit and "limit 7" in fit and "reaches it 2027-01-01" in fit
            assert screen.query_one(Plot).data.series
            # the runs by name (their directories), not by uid; the x axis from the first to the newest run's date
            assert [str(table.get_row_at(i)[4]) for i in range(3)] == ["x0", "x1", "x2"]
            plot = str(screen.query_one(Plot).render()).splitlines()
            axis = next(ln for ln in plot if "yellow trend" in ln)
            assert axis.split()[0] == "2023-01-01" and axis.split()[-1] == "2025-01-01"
            await pilot.press("v")
            await settle(app, pilot)
            assert screen.value == "least_squares"
            assert [str(table.get_row_at(i)[1]) for i in range(3)] == ["5.250", "5.750", "6.250"]
            await pilot.press("escape")
            await pilot.pause()
            assert app.screen is not screen

    asyncio.run(drive())


def test_trend_screen_says_what_is_missing(tmp_path: Path) -> None:
    url = catalogue(tmp_path)

    async def drive() -> None:
        screen = TrendScreen(url, "mill-9", "X", "E")
        app = TrendApp(screen)
        async with app.run_test(size=(100, 30)) as pilot:
            await settle(app, pilot)
            assert "no catalogued run of machine 'mill-9'" in str(screen.query_one("#trend-title", Static).render())

    asyncio.run(drive())


def test_a_catalogue_that_does_not_answer_does_not_freeze_the_screen(tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """The catalogue is read in a worker: while a server keeps the reading waiting, the screen says
    so and Escape still goes back."""
    import threading

    import tui.screens.trend as trend_screen

    release = threading.Event()

    def waiting(*args: Any, **kwargs: Any) -> Any:
        release.wait(10)
        raise trend_screen.UserError("the server did not answer")

    monkeypatch.setattr(trend_screen, "browse_catalog", waiting)

    async def drive() -> None:
        screen = TrendScreen("postgresql://nowhere/db", "mill-1", "X", "E")
        app = TrendApp(screen)
        async with app.run_test(size=(100, 30)) as pilot:
            await pilot.pause()
            assert "reading the trend of E" in str(screen.query_one("#trend-title", Static).render())
            await pilot.press("escape")
            await pilot.pause()
            assert app.screen is not screen  # answered while the reading still waits
            release.set()
            await app.workers.wait_for_complete()

    asyncio.run(drive())


def test_trend_screen_says_the_axis_is_beyond_its_limit(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    for i, e in enumerate((7.1, 5.9, 4.6, 3.5)):  # E falling, every run above the limit of 2
        write_run(tmp_path / "runs", f"q{i}", kind="positioning", created=f"{2023 + i}-03-01T00:00:00Z",
                  summary=positioning_summary({"E": e}))
    write_run(tmp_path / "runs", "rising", axis="Y", created="2023-01-01T00:00:00Z",
              summary=straightness_summary(5.0, 0.1))
    for i, v in enumerate((5.5, 6.1, 7.6)):  # the line past 7 at the newest run; the newest value beyond it too
        write_run(tmp_path / "runs", f"y{i}", axis="Y", created=f"{2024 + i}-01-01T00:00:00Z",
                  summary=straightness_summary(v, 0.1))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0

    async def drive() -> None:
        for axis, value, limit, expected in (
                ("X", "E", 2.0, ("beyond the limit since run q0 (2023-03-01): every run above 2 um", "no crossing date",
                                 "the value falls")),
                ("Y", "minimum_zone", 7.0, ("beyond the limit since run y2 (2026-01-01)",
                                            "the line was past the limit at the last run already"))):
            screen = TrendScreen(url, "mill-1", axis, value, limit_um=limit)
            app = TrendApp(screen)
            async with app.run_test(size=(80, 24)) as pilot:
                await settle(app, pilot)
                fit = str(screen.query_one("#trend-fit", Static).render())
                assert "never" not in fit
                for frag in expected:
                    assert frag in fit, fit

    asyncio.run(drive())
