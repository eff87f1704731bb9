"""Compare screen: two saved runs of one kind (A before, B after), evaluated as ``guideway compare``
evaluates them, with the overlay of both and the table of changes with their uncertainty
(docs/compare.md).  Standalone: push ``CompareScreen(run_a, run_b)``; Escape goes back."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from textual import work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import VerticalScroll
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import Footer, Header, Static

from fleet.compare.compare import Comparison, compare_runs
from fleet.compare.positioning import PositioningComparison
from fleet.compare.text import change_table, run_line, value_lines
from saved_runs.errors import EXPECTED_ERRORS

from ..text import literal
from ..widgets.plot import Plot, PlotData, Series

A_STYLES = {1: "dark_green", -1: "dark_goldenrod"}  # run A dimmer than run B
B_STYLES = {1: "bold green", -1: "bold yellow"}


def positioning_overlay(d: PositioningComparison) -> PlotData:
    """The mean deviation per direction of both runs (A dim, B bright; up green, down yellow)."""
    series = []
    for side, styles in (("a", A_STYLES), ("b", B_STYLES)):
        for direction, name in ((1, "up"), (-1, "down")):
            pts = [(t.target, getattr(t, side).mean) for t in d.targets
                   if t.direction == direction and getattr(t, side) is not None]
            if pts:
                series.append(Series(pts, styles[direction], f"{side.upper()} {name}", join=True))
    return PlotData(series, x_label=f"target {d.target_unit} · A dim, B bright · up green, down yellow",
                    y_label=d.unit)


def straightness_overlay(d: Any) -> PlotData:
    """Both profiles against their own least-squares lines (A dim, B bright) and the change (magenta)."""
    a = [(s.x_mm, s.a) for s in d.stations if s.a is not None]
    b = [(s.x_mm, s.b) for s in d.stations if s.b is not None]
    ch = [(s.x_mm, s.change) for s in d.matched() if s.change is not None]
    return PlotData([Series(a, "dark_cyan", "A", join=True), Series(b, "bold cyan", "B", join=True),
                     Series(ch, "magenta", "change", join=True)],
                    x_label="x mm · A dim, B bright cyan · change B - A magenta", y_label="um")


class CompareScreen(Screen):
    SCREEN_NAME = "Compare"
    SUB_TITLE = SCREEN_NAME
    DEFAULT_CSS = """
    #compare-body { height: 1fr; }
    #compare-title { padding: 0 1; height: auto; }
    #compare-body #compare-plot { height: 10; margin: 0 1; }
    #compare-table, #compare-values, #compare-notes { padding: 0 1; height: auto; }
    #compare-notes { color: $text-muted; }
    """
    BINDINGS = [Binding("escape", "back", "back"), Binding("f3", "app.runs", "runs")]

    def __init__(self, run_a: Path, run_b: Path) -> None:
        super().__init__()
        self.run_a = Path(run_a)
        self.run_b = Path(run_b)
        self.comparison: Comparison | None = None
        self.problem = ""

    def compose(self) -> ComposeResult:
        yield Header()
        with VerticalScroll(id="compare-body"):
            yield Static(f"A: {literal(self.run_a)}\nB: {literal(self.run_b)}", id="compare-title")
            yield Plot(id="compare-plot")
            yield Static("comparing...", id="compare-table")
            yield Static(id="compare-values")
            yield Static(id="compare-notes")
        yield Footer()

    def on_mount(self) -> None:
        self.compare()

    @work(thread=True, exclusive=True, group="compare", exit_on_error=False)
    def compare(self) -> None:
        try:
            comparison = compare_runs(self.run_a, self.run_b)
        except EXPECTED_ERRORS as exc:
            self.app.call_from_thread(self.show_problem, str(exc))
            return
        self.app.call_from_thread(self.show, comparison)

    def show_problem(self, text: str) -> None:
        self.problem = text
        self.query_one("#compare-table", Static).update(f"[red]cannot compare: {escape(text)}[/red]")

    def show(self, c: Comparison) -> None:
        self.comparison = c
        self.query_one("#compare-title", Static).update(
            f"[b]{escape(c.kind)}[/b] · change = B - A\n{escape(run_line('A', c.a))}\n{escape(run_line('B', c.b))}")
        d = c.detail
        self.query_one("#compare-plot", Plot).show(
            positioning_overlay(d) if isinstance(d, PositioningComparison) else straightness_overlay(d))
        self.query_one("#compare-table", Static).update(escape("\n".join(change_table(c))))
        self.query_one("#compare-values", Static).update(escape("\n".join(["values:", *value_lines(c)])))
        self.query_one("#compare-notes", Static).update(escape("\n".join(f"note: {n}" for n in (*c.notes,
                                                                                                  *d.notes))))

    def action_back(self) -> None:
        """Back to the screen this one was pushed over (the runs browser), else to the runs browser."""
        if len(self.app.screen_stack) > 2 and self.app.screen is self:
            self.app.pop_screen()
        elif hasattr(self.app, "action_runs"):
            self.app.action_runs()
