"""The braille plot (tui/widgets/plot.py): joined segments stay lines however steep, and the legend row."""

from __future__ import annotations

import asyncio

from textual.app import App, ComposeResult

from tui.widgets.plot import MARGIN, Plot, PlotData, Series


def rendered(data: PlotData, size: tuple[int, int] = (60, 14)) -> list[str]:
    out: list[str] = []

    class One(App[None]):
        CSS = "Plot { height: 1fr; }"

        def compose(self) -> ComposeResult:
            yield Plot(id="p")

        def on_mount(self) -> None:
            self.query_one(Plot).show(data)

    async def main() -> None:
        app = One()
        async with app.run_test(size=size) as pilot:
            await pilot.pause()
            out.extend(str(app.query_one(Plot).render()).splitlines())

    asyncio.run(main())
    return out


def test_a_steep_segment_is_a_line_through_every_row() -> None:
    # a step of 100 over 1 % of the x range: the segment crosses every row of the plot within its first cell
    rows = rendered(PlotData([Series([(0.0, 0.0), (0.01, 100.0), (1.0, 100.0)], "cyan", join=True)]))
    body = rows[:-1]  # the last row holds the x axis
    assert len(body) == 13
    assert all(ln[MARGIN] != " " for ln in body), body  # the first plot column has a dot in every row


def test_the_legend_names_each_labelled_series_after_the_axis_row() -> None:
    data = PlotData([Series([(0.0, 1.0), (2.0, 3.0)], "green", "mean", join=True),
                     Series([(1.0, 2.0)], "yellow", "points"), Series([(1.5, 2.5)], "red")], x_label="x (mm)",
                    legend=True)
    rows = rendered(data)
    assert rows[-1].strip() == "━ mean  • points"
    assert rows[-2].split() == ["0.00", "x", "(mm)", "2.00"]
