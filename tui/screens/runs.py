"""Runs screen: the saved runs of the runs folder; open one into Results, or resume an unfinished one.

Each run takes two lines (its name over its creation time, its kind over its axis), so that every
column fits an 80-column terminal; the machine column takes the width that is left and wraps.
"""

from __future__ import annotations

from pathlib import Path

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import DataTable, Footer, Header, Static

from saved_runs.catalog.folder import RunSummary, list_runs  # json only: the browser paints at once

NAME_WIDTH = 32
KIND_WIDTH = 12
STATUS_WIDTH = 10
POINTS_WIDTH = 6
MACHINE_MIN_WIDTH = 10


class RunsScreen(Screen):
    SCREEN_NAME = "Runs"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("enter", "open", "open results"), Binding("c", "resume", "continue (resume)"),
                Binding("r", "reload", "reload"), Binding("f2", "app.setup", "set-up")]

    def __init__(self, runs_dir: Path) -> None:
        super().__init__()
        self.runs_dir = Path(runs_dir)
        self.runs: list[RunSummary] = []

    def compose(self) -> ComposeResult:
        yield Header()
        yield Static(id="runs-title")
        yield DataTable(id="runs-table", cursor_type="row", zebra_stripes=True)
        yield Footer()

    def on_mount(self) -> None:
        self.action_reload()

    def on_screen_resume(self) -> None:
        self.action_reload()

    def on_resize(self) -> None:
        self.action_reload()

    def action_reload(self) -> None:
        self.runs = list_runs(self.runs_dir)
        table = self.query_one(DataTable)
        table.clear(columns=True)
        names = [r.path.name for r in self.runs]
        name_w = min(max([19, *map(len, names)]), NAME_WIDTH)  # 19: a creation time
        fixed = name_w + KIND_WIDTH + STATUS_WIDTH + POINTS_WIDTH
        # the rest of the screen (less a scroll bar and each column's padding of one cell either side)
        machine_w = max(MACHINE_MIN_WIDTH, self.app.size.width - 2 - 2 * 5 - fixed)
        for label, width in (("run · created (UTC)", name_w), ("kind · axis", KIND_WIDTH),
                             ("status", STATUS_WIDTH), ("points", POINTS_WIDTH), ("machine", machine_w)):
            table.add_column(label, width=width)
        for r in self.runs:
            # as they are (a str cell would be read as markup); two lines each, cut to the column
            name = Text(f"{r.path.name[:name_w]}\n{r.created.replace('T', ' ').removesuffix('Z')}")
            kind = Text(f"{r.kind or '?'}\n{r.axis or '-'}")
            status = Text(r.problem or r.status, overflow="ellipsis")
            table.add_row(name, kind, status, Text(str(r.points), justify="right"), Text(r.machine), height=2)
        n = len(self.runs)
        self.query_one("#runs-title", Static).update(
            f"{n} run(s) in {escape(str(self.runs_dir))} · Enter opens the results" if n
            else f"no runs in {escape(str(self.runs_dir))} yet (F2: set up a run)")

    def selected(self) -> RunSummary | None:
        table = self.query_one(DataTable)
        if not self.runs or table.cursor_row < 0 or table.cursor_row >= len(self.runs):
            return None
        return self.runs[table.cursor_row]

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
