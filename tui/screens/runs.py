"""Runs screen: the saved runs of the runs folder; open one into Results, or resume an unfinished one."""

from __future__ import annotations

from pathlib import Path

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import DataTable, Footer, Header, Static

from acquisition.runs import RunSummary, list_runs  # json only: the browser paints at once


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
        table = self.query_one(DataTable)
        table.add_columns("run", "kind", "created (UTC)", "status", "points", "machine", "axis")
        self.action_reload()

    def on_screen_resume(self) -> None:
        self.action_reload()

    def action_reload(self) -> None:
        self.runs = list_runs(self.runs_dir)
        table = self.query_one(DataTable)
        table.clear()
        for r in self.runs:
            status = r.problem or r.status
            cells = (r.path.name, r.kind or "?", r.created.replace("T", " ").removesuffix("Z"), status,
                     str(r.points), r.machine, r.axis)
            table.add_row(*(Text(c) for c in cells))  # as they are: a str cell would be read as markup
        n = len(self.runs)
        self.query_one("#runs-title", Static).update(
            f"{n} run(s) in {escape(str(self.runs_dir))}" if n
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
