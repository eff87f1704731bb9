"""Runs screen: the saved runs of the runs folder; open one into Results, or resume an unfinished one.

Below 120 columns each run takes two lines (its name over its creation time, its kind over its axis),
so that every column fits an 80-column terminal; the machine column takes the width that is left
and wraps.  From 120 columns on, one line per run with every column side by side.  The line under
the table tells the selected run's status in full (why a run is damaged, whether it can be resumed).
"""

from __future__ import annotations

from pathlib import Path

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import DataTable, Footer, Header, Static

from saved_runs.catalog.folder import DAMAGED, RunSummary, list_runs  # no pandas: the browser paints at once

NAME_WIDTH = 32
KIND_WIDTH = 12
STATUS_WIDTH = 11  # "in-progress"
POINTS_WIDTH = 9  # "1234/2000"
MACHINE_MIN_WIDTH = 10
WIDE = 120  # from this many columns on, one line per run
CREATED_WIDTH = 19


class RunsScreen(Screen):
    SCREEN_NAME = "Runs"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("enter", "open", "open results"), Binding("c", "resume", "continue (resume)"),
                Binding("r", "reload", "reload"), Binding("f2", "app.setup", "set-up"),
                # the first / last run (the table's own Home / End scroll sideways)
                Binding("home,ctrl+home", "edge(0)", "first run", show=False, priority=True),
                Binding("end,ctrl+end", "edge(1)", "last run", show=False, priority=True)]
    DEFAULT_CSS = """
    RunsScreen #run-detail { height: 2; padding: 0 1; background: $boost; }
    """

    def __init__(self, runs_dir: Path) -> None:
        super().__init__()
        self.runs_dir = Path(runs_dir)
        self.runs: list[RunSummary] = []

    def compose(self) -> ComposeResult:
        yield Header()
        yield Static(id="runs-title")
        yield DataTable(id="runs-table", cursor_type="row", zebra_stripes=True)
        yield Static(id="run-detail")
        yield Footer()

    def on_mount(self) -> None:
        self.action_reload()

    def on_screen_resume(self) -> None:
        self.action_reload()

    def on_resize(self) -> None:
        self.action_reload()

    def action_reload(self) -> None:
        table = self.query_one(DataTable)
        keep = self.selected()
        self.runs = list_runs(self.runs_dir)
        table.clear(columns=True)
        width = self.app.size.width
        wide = width >= WIDE
        names = [r.path.name for r in self.runs]
        name_w = min(max([10 if wide else CREATED_WIDTH, *map(len, names)]), NAME_WIDTH)
        widths = [name_w, *([CREATED_WIDTH] if wide else []), KIND_WIDTH, STATUS_WIDTH, POINTS_WIDTH]
        # the rest of the screen (less a scroll bar and each column's padding of one cell either side)
        machine_w = max(MACHINE_MIN_WIDTH, width - 2 - 2 * (len(widths) + 1) - sum(widths))
        labels = ["run", "created (UTC)", "kind · axis", "status", "points", "machine"] if wide else \
            ["run · created (UTC)", "kind · axis", "status", "points", "machine"]
        for label, w in zip(labels, [*widths, machine_w], strict=True):
            table.add_column(label, width=w)
        for r in self.runs:
            # as they are (a str cell would be read as markup), cut to the column
            created = r.created.replace("T", " ").removesuffix("Z")
            status = Text(r.status or "?", style="bold" if r.status == DAMAGED else "")
            points = Text(r.points_text, justify="right")
            if wide:
                table.add_row(Text(r.path.name[:name_w]), Text(created), Text(f"{r.kind or '?'} · {r.axis or '-'}"),
                              status, points, Text(r.machine))
            else:
                table.add_row(Text(f"{r.path.name[:name_w]}\n{created}"), Text(f"{r.kind or '?'}\n{r.axis or '-'}"),
                              status, points, Text(r.machine), height=2)
        n = len(self.runs)
        self.query_one("#runs-title", Static).update(
            f"{n} run(s) in {escape(str(self.runs_dir))} · Enter opens the results" if n
            else f"no runs in {escape(str(self.runs_dir))} yet (F2: set up a run)")
        if keep is not None:
            table.move_cursor(row=next((i for i, r in enumerate(self.runs) if r.path == keep.path), 0))
        self.show_detail()

    def show_detail(self) -> None:
        """The selected run's status in full, under the table."""
        r = self.selected()
        if r is None:
            text = ""
        elif r.problem:
            text = f"{escape(r.path.name)}: [b]{DAMAGED}[/b]: {escape(r.problem)}"
        else:
            planned = f" of {r.planned} planned" if r.planned else ""
            what = "c continues it" if r.resumable else "Enter opens its results"
            text = f"{escape(r.path.name)}: {escape(r.status)}, {r.points} points on disk{planned}; {what}"
        self.query_one("#run-detail", Static).update(text)

    def on_data_table_row_highlighted(self, event: DataTable.RowHighlighted) -> None:
        self.show_detail()

    def selected(self) -> RunSummary | None:
        try:
            table = self.query_one(DataTable)
        except Exception:  # not composed yet
            return None
        if not self.runs or table.cursor_row < 0 or table.cursor_row >= len(self.runs):
            return None
        return self.runs[table.cursor_row]

    def action_edge(self, last: int) -> None:
        """Home: the newest run; End: the oldest."""
        if self.runs:
            self.query_one(DataTable).move_cursor(row=len(self.runs) - 1 if last else 0)

    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        event.stop()
        self.action_open()

    def action_open(self) -> None:
        r = self.selected()
        if r is not None:
            self.app.open_results(r.path)  # type: ignore[attr-defined]

    def action_resume(self) -> None:
        r = self.selected()
        if r is None:
            return
        if not r.resumable:
            self.notify(f"{r.path.name} is {r.problem or r.status}; nothing to resume", severity="warning",
                        markup=False)
            return
        self.app.resume_run(r.path)  # type: ignore[attr-defined]
