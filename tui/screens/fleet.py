"""Fleet screen: the fleet overview (``guideway fleet`` in the TUI): one row per machine, axis and tolerance
value of the catalogue, most urgent first (beyond the limit, then by the date the trend reaches it, then by
the age of the last run), with the latest run, its value ± U and verdict, the trend per year, the limit state,
the last step, the compensation state and when the axis is due for calibration.

Pushed from the runs browser (``o``) or anywhere: ``app.push_screen(FleetScreen(url))``.  Enter opens the
trend of the selected row; Escape goes back.  The catalogue is read in a worker (docs/fleet.md).
"""

from __future__ import annotations

from rich.text import Text
from textual import work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import DataTable, Footer, Header, Static

from fleet.catalog.database import open_catalog
from fleet.overview.output import HEADER, printable, row_cells
from fleet.overview.overview import Overview, fleet_overview
from saved_runs.errors import UserError

from ..text import literal


class FleetScreen(Screen):
    SCREEN_NAME = "Fleet"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("escape", "back", "back"), Binding("enter", "trend", "trend of the row"),
                Binding("r", "reload", "reload")]
    DEFAULT_CSS = """
    FleetScreen #fleet-table { height: 1fr; }
    FleetScreen #fleet-detail { height: 2; padding: 0 1; background: $boost; }
    """

    def __init__(self, catalog_url: str | None) -> None:
        super().__init__()
        self.catalog_url = catalog_url
        self.overview: Overview | None = None

    def compose(self) -> ComposeResult:
        yield Header()
        yield Static(id="fleet-title")
        yield DataTable(id="fleet-table", cursor_type="row", zebra_stripes=True)
        yield Static(id="fleet-detail")
        yield Footer()

    def on_mount(self) -> None:
        self.action_reload()

    def action_reload(self) -> None:
        self.query_one("#fleet-title", Static).update("reading the catalogue ...")
        self.read()

    @work(thread=True, exclusive=True, group="fleet")
    def read(self) -> None:
        try:
            with open_catalog(self.catalog_url, create=False) as cat:
                ov = fleet_overview(cat)
        except UserError as exc:
            self.app.call_from_thread(self.show, None, str(exc))
            return
        self.app.call_from_thread(self.show, ov, "")

    def show(self, ov: Overview | None, problem: str) -> None:
        if not self.is_mounted:  # closed while the worker read
            return
        self.overview = ov
        table = self.query_one(DataTable)
        table.clear(columns=True)
        title = self.query_one("#fleet-title", Static)
        if ov is None:
            title.update(literal(problem))
            return
        due = sum(1 for r in ov.rows if r.overdue)
        beyond = sum(1 for r in ov.rows if r.beyond)
        title.update(escape(f"{len(ov.rows)} row(s), most urgent first: {beyond} beyond the limit, {due} overdue "
                            f"calibration(s) · U = 2u · Enter: the row's trend"))
        for label in HEADER:
            table.add_column(label)
        for r in ov.rows:
            cells = [Text(printable(c)) for c in row_cells(r)]
            if r.beyond:
                cells = [Text(c.plain, style="bold red") for c in cells]
            table.add_row(*cells)
        self.show_detail()

    def selected_row(self):  # noqa: ANN201 - a FleetRow or None
        if self.overview is None or not self.overview.rows:
            return None
        i = self.query_one(DataTable).cursor_row
        return self.overview.rows[i] if 0 <= i < len(self.overview.rows) else None

    def show_detail(self) -> None:
        r = self.selected_row()
        text = ""
        if r is not None and r.run is not None:
            note = r.trend.crossing_note if r.trend is not None else ""
            text = printable(f"{r.machine} {r.axis} {r.value}: run {r.run.name}, verdict {r.verdict or '-'} "
                             f"({r.decision_rule}); limit {r.limit_source or 'none'}; compensation "
                             f"{r.compensation_text()}" + (f"; {note}" if note else ""))
        self.query_one("#fleet-detail", Static).update(Text(text))

    def on_data_table_row_highlighted(self, event: DataTable.RowHighlighted) -> None:
        self.show_detail()

    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        event.stop()
        self.action_trend()

    def action_trend(self) -> None:
        r = self.selected_row()
        if r is None or r.run is None:
            return
        from .trend import TrendScreen

        self.app.push_screen(TrendScreen(self.catalog_url, r.machine, r.axis, r.value, r.limit_um))

    def action_back(self) -> None:
        self.app.pop_screen()
