"""Trend screen: one headline value over every catalogued run of a machine axis (``guideway trend`` in
the TUI): the values with their uncertainty and the fitted line as a plot against the run dates, the runs
(by name) as a table, the slope per year and the date the limit is reached, or since which run the axis is
beyond it.

Taking its inputs as constructor arguments, it is pushed from the runs browser (the selected run's
machine and axis) or from anywhere else: ``app.push_screen(TrendScreen(url, machine, axis, value))``.
``v`` steps through the values the axis' runs have; Escape goes back.
"""

from __future__ import annotations

from datetime import timedelta

from rich.text import Text
from textual import work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.screen import Screen
from textual.widgets import DataTable, Footer, Header, Static

from fleet.catalog.browse import CatalogFilter, browse_catalog, trend_values
from fleet.catalog.database import open_catalog
from fleet.trend.fit import DAYS_PER_YEAR, parse_date, years_between
from fleet.trend.of_catalog import MAGNITUDE_NOTE, AxisTrend, axis_trend
from saved_runs.errors import UserError, printable

from ..text import literal
from ..widgets.plot import Plot, PlotData, Series


def trend_plot(at: AxisTrend) -> PlotData:
    """Values (cyan), their ± u bars (blue), the fitted line (yellow) and the limit (red) against the run
    date (x: years since the first run, labelled as UTC dates)."""
    t = at.trend
    if not t.points:
        return PlotData()
    t0 = parse_date(t.points[0].date)
    xs = [years_between(t0, parse_date(p.date)) for p in t.points]
    series = []
    for x, p in zip(xs, t.points, strict=True):
        if p.u_um is not None:
            series.append(Series([(x, p.value_um - p.u_um), (x, p.value_um + p.u_um)], "blue", join=True))
    x_end = max(xs)
    if t.slope_um_per_year is not None and t.intercept_um is not None:
        series.append(Series([(0.0, t.intercept_um), (x_end, t.intercept_um + t.slope_um_per_year * x_end)],
                             "yellow", "trend", join=True))
    if t.limit_um is not None:
        series.append(Series([(0.0, t.limit_um), (x_end, t.limit_um)], "red", "limit", join=True))
        if t.signed:  # the limit bounds |value|
            series.append(Series([(0.0, -t.limit_um), (x_end, -t.limit_um)], "red", join=True))
    series.append(Series(list(zip(xs, [p.value_um for p in t.points], strict=True)), "bold cyan", at.value))

    def date(x: float) -> str:
        try:
            return (t0 + timedelta(days=x * DAYS_PER_YEAR)).strftime("%Y-%m-%d")
        except OverflowError:
            return "?"

    return PlotData(series, x_label="date · cyan value ± u · yellow trend · red limit", y_label=at.unit,
                    x_format=date)


def trend_text(at: AxisTrend) -> str:
    """The fit in one line, and the limit in a second: beyond it since which run, the crossing date or why
    there is none (plain text)."""
    t, u = at.trend, at.unit
    limit = ""
    if t.limit_um is not None:
        limit = f"limit {t.limit_um:g} {u}"
        if t.beyond_limit:
            limit += f": {printable(at.beyond_text)}"  # (it names a run: as every name shown, escaped)
        if t.crossing_date is not None:
            ud = f" ± {t.u_crossing_days:.0f} d" if t.u_crossing_days is not None else ""
            limit += f"{';' if t.beyond_limit else ':'} the line reaches it {t.crossing_date[:10]}{ud}"
            limit += f" ({t.crossing_note})" if t.crossing_note else ""
        elif t.slope_um_per_year is not None:
            limit += f"{';' if t.beyond_limit else ':'} no crossing date ({t.crossing_note})"
    if t.slope_um_per_year is None:
        return "\n".join(x for x in (f"{len(t.points)} run(s): no trend ({t.crossing_note})", limit) if x)
    us = "?" if t.u_slope_um_per_year is None else f"{t.u_slope_um_per_year:.3f}"
    scaled = f", u ×{t.u_scale:.1f} for the scatter" if t.u_scale is not None else ""
    text = f"{len(t.points)} runs · trend {t.slope_um_per_year:+.3f} ± {us} {u}/year (k = 1{scaled})"
    if t.steps:
        text += f" · {len(t.steps)} step(s)"
    if at.left_out:
        text += f" · {len(at.left_out)} run(s) left out"
    if at.value in MAGNITUDE_NOTE:
        text += " · B is a magnitude: B_mean is signed"
    return text + (f"\n{limit}" if limit else "")


class TrendScreen(Screen):
    SCREEN_NAME = "Trend"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("escape", "back", "back"), Binding("v", "next_value", "next value")]
    DEFAULT_CSS = """
    TrendScreen #trend-plot { height: 10; }
    TrendScreen #trend-table { height: 1fr; }
    """

    def __init__(self, catalog_url: str | None, machine: str, axis: str, value: str,
                 limit_um: float | None = None) -> None:
        super().__init__()
        self.catalog_url = catalog_url
        self.machine, self.axis, self.value = machine, axis, value
        self.limit_um = limit_um
        self.trend: AxisTrend | None = None
        self.values: list[str] = [value]

    def compose(self) -> ComposeResult:
        yield Header()
        yield Static(id="trend-title")
        yield Plot(id="trend-plot")
        yield Static(id="trend-fit")
        yield DataTable(id="trend-table", cursor_type="row", zebra_stripes=True)
        yield Footer()

    def on_mount(self) -> None:
        self.load(first=True)

    def load(self, first: bool = False) -> None:
        """Read the trend in a worker (a database server that does not answer must not freeze the
        screen; docs/fleet.md) and show it when it is read."""
        self.query_one("#trend-title", Static).update(literal(f"reading the trend of {self.value} ..."))
        self.read(first)

    @work(thread=True, exclusive=True, group="trend")
    def read(self, first: bool) -> None:
        values = self.values
        try:
            if first:
                view = browse_catalog(self.catalog_url, CatalogFilter(self.machine, self.axis))
                values = trend_values(view.entries, self.machine, self.axis) or [self.value]
            with open_catalog(self.catalog_url, create=False) as cat:
                at = axis_trend(cat, self.machine, self.axis, self.value, self.limit_um)
        except UserError as exc:
            self.app.call_from_thread(self.show, None, str(exc), values)
            return
        self.app.call_from_thread(self.show, at, "", values)

    def show(self, at: AxisTrend | None, problem: str, values: list[str]) -> None:
        if not self.is_mounted:  # closed while the worker read
            return
        self.values = values
        self.trend = at
        title = self.query_one("#trend-title", Static)
        table = self.query_one(DataTable)
        table.clear(columns=True)
        if at is None:
            title.update(literal(problem))
            self.query_one("#trend-plot", Plot).show(PlotData())
            self.query_one("#trend-fit", Static).update("")
            return
        title.update(literal(f"{at.value} · machine {at.machine or '-'} · axis {at.axis or '-'} "
                             f"(v: next value of {len(self.values)})"))
        self.query_one("#trend-plot", Plot).show(trend_plot(at))
        self.query_one("#trend-fit", Static).update(Text(trend_text(at)))
        stepped = {s.to_run: s for s in at.trend.steps}
        for label in ("created (UTC)", f"{at.value} {at.unit}", f"u {at.unit}", "step", "run"):
            table.add_column(label)
        for p in at.trend.points:
            step = stepped.get(p.run)
            table.add_row(Text(printable(p.date.replace("T", " ").removesuffix("Z"))),
                          Text(f"{p.value_um:.3f}", justify="right"),
                          Text("-" if p.u_um is None else f"{p.u_um:.3f}", justify="right"),
                          Text("" if step is None else f"{step.change_um:+.3f}", justify="right"),
                          Text(printable(p.name)))

    def action_next_value(self) -> None:
        i = self.values.index(self.value) if self.value in self.values else -1
        self.value = self.values[(i + 1) % len(self.values)]
        self.load()

    def action_back(self) -> None:
        self.app.pop_screen()
