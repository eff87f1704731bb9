"""The compare screen pushed over the runs browser: the overlay and the table of changes of two runs, a
refusal shown as one line, Escape back to the browser."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest

from tests.fleet.test_compare import SCALE_EFFECT, positioning_scenario, simulate, straightness_scenario
from tests.tui.sessions import screen_name, widget_text
from tests.waiting import wait_for_app
from tui.app import GuidewayApp
from tui.screens.compare import CompareScreen


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("compare-tui")
    return {"before": simulate(tmp, "before", positioning_scenario(), 1),
            "after": simulate(tmp, "after", positioning_scenario(SCALE_EFFECT), 2),
            "straight": simulate(tmp, "straight", straightness_scenario([(2.5, 380.0, 0.7)]), 1)}


def on_compare_screen(runs_dir: Path, run_a: Path, run_b: Path, check: Any, *, keys: tuple[str, ...] = ()) -> Any:
    """Push CompareScreen(run_a, run_b) over the runs browser, wait for it to settle, ``check(app, screen)``,
    then press ``keys`` and return (check's result, the screen's name after the keys)."""
    out: list[Any] = []

    async def main() -> None:
        app = GuidewayApp(runs_dir=runs_dir, start="runs")
        async with app.run_test(size=(100, 40)) as pilot:
            await wait_for_app(pilot, lambda: screen_name(app) == "RunsScreen", what="the runs browser")
            screen = CompareScreen(run_a, run_b)
            app.push_screen(screen)
            await wait_for_app(pilot, lambda: screen.comparison is not None or bool(screen.problem),
                               timeout_s=60.0, what="the comparison")
            await pilot.pause()
            out.append(check(app, screen))
            for key in keys:
                await pilot.press(key)
                await pilot.pause()
            out.append(screen_name(app))

    asyncio.run(main())
    return tuple(out)


def test_the_screen_shows_the_overlay_and_the_changes(runs: dict[str, Path]) -> None:
    def check(app: Any, screen: CompareScreen) -> tuple[str, list[str], str]:
        plot = app.screen.query_one("#compare-plot").data
        return widget_text(app, "#compare-table"), [s.label for s in plot.series], widget_text(app, "#compare-values")

    (table, series, values), after = on_compare_screen(runs["before"].parent, runs["before"], runs["after"], check,
                                                       keys=("escape",))
    assert series == ["A up", "A down", "B up", "B down"]
    lines = table.splitlines()
    assert lines[0].startswith("per target and direction (um; U = 2 * sqrt(s_a^2/n_a + s_b^2/n_b))")
    assert len(lines) == 2 + 22  # heading, column names, 11 targets x 2 directions
    last = lines[-1].split()  # 1000 mm, down: 8 ppm of 1000 mm = 8 um, far above its U
    assert last[0] == "1000.0000" and last[1] == "-" and 7.0 < float(last[4]) < 9.0 and last[6] == "yes"
    assert "E " in values and "change" in values
    assert after == "RunsScreen"  # Escape goes back to the browser it was pushed over


def test_a_refusal_is_shown_as_one_line(runs: dict[str, Path]) -> None:
    text, _ = on_compare_screen(runs["before"].parent, runs["before"], runs["straight"],
                                lambda app, _s: widget_text(app, "#compare-table"))
    assert text.startswith("cannot compare: ") and "same kind" in text and "\n" not in text.strip()
