"""Verify screen: an as-found run, the table exported from it, the as-left run measured with the table active
— what the table did against what the export predicted, as ``guideway verify FOUND LEFT`` shows it
(fleet/verify/, docs/compensation.md "Verify").  Pushed from the Results screen of an as-left run (``v``)
or from the runs browser (``v`` on an as-left run); Escape goes back.

Top to bottom: the verdict line, the table line (the table exported from AS_FOUND, or not), the ISO 230-2
values (found, left, predicted, reduction in %, as predicted; rotary in arcsec), the flags and the drift,
the overlay of the means (found dim, left bright, predicted dots), the per-target table, the notes.  Below
140 columns the values stand in a compact table that fits 80 columns; from 140 the command line's own lines.
"""

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

from saved_runs.errors import EXPECTED_ERRORS

from ..text import literal
from ..widgets.plot import Plot, PlotData, Series

WIDE = 140  # from this many columns on, the command line's full value lines
# the values the technician reads first (ISO 230-2's axis values), then the directional ones
MAIN_VALUES = ("E", "M", "B", "A", "R")
MORE_VALUES = ("E_up", "E_down", "A_up", "A_down", "R_up", "R_down", "B_mean")
LABELS = {"E_up": "E ↑", "E_down": "E ↓", "A_up": "A ↑", "A_down": "A ↓", "R_up": "R ↑", "R_down": "R ↓",
          "B_mean": "B mean"}


def _n(v: float | None, digits: int = 3) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


def _pm(v: float | None, u: float | None) -> str:
    return "n/a" if v is None else f"{v:.3f}" + ("" if u is None else f" ± {u:.3f}")


def _pct(v: float | None, u: float | None) -> str:
    return "n/a" if v is None else f"{v:.1f}" + ("" if u is None else f" ± {u:.1f}") + " %"


def value_rows(c: Any) -> list[str]:
    """The ISO 230-2 values of a :class:`~fleet.verify.verify.Verification` in columns that fit 80: found ± u,
    left ± u, predicted, reduction ± u, whether left is as predicted, ``*`` when flagged (the flags follow)."""
    head = (f"{'value':<7}{'found ± u':>16}{'left ± u':>16}{'predicted':>10}{'reduction ± u':>16}{'as pred.':>9}")
    rows = [f"ISO 230-2 values ({c.unit}); reduction = 100 (1 - |left| / |found|)", head]
    for group in (MAIN_VALUES, MORE_VALUES):
        for q in group:
            v = c.values.get(q)
            if v is None:
                continue
            agree = {True: "yes", False: "NO", None: "n/a"}[v.agrees]
            rows.append(f"{LABELS.get(q, q):<7}{_pm(v.found, v.u_found):>16}{_pm(v.left, v.u_left):>16}"
                        f"{_n(v.predicted):>10}{_pct(v.reduction_pct, v.u_reduction_pct):>16}{agree:>9}"
                        + (" *" if v.flags else ""))
        if group is MAIN_VALUES:
            rows.append("")
    return rows


def flag_lines(c: Any) -> list[str]:
    """``* E: gain ... < repeatability ...``: why each flagged value is flagged; the drift and between-points
    lines of ``guideway verify``."""
    lines = [f"* {LABELS.get(q, q)}: {'; '.join(c.values[q].flags)}" for q in (*MAIN_VALUES, *MORE_VALUES)
             if q in c.values and c.values[q].flags]
    if lines:
        lines.insert(0, f"flagged ({len(lines)}): the gain is smaller than the repeatability or the drift between "
                        "the runs")
    else:
        lines.append("flagged: none (every gain is larger than the repeatability and the drift between the runs)")
    if c.drift is not None:
        lines.append(c.drift.text(c.unit))
    if c.between is not None:
        lines.append(c.between.text(c.unit, c.detail.target_unit))
    return lines


def verify_overlay(c: Any) -> PlotData:
    """The mean deviation per target and direction: found dim, left bright (up green, down yellow), predicted
    as magenta dots."""
    d = c.detail
    series = []
    for side, styles, name in (("a", {1: "dark_green", -1: "dark_goldenrod"}, "found"),
                               ("b", {1: "bold green", -1: "bold yellow"}, "left")):
        for direction, arrow in ((1, "↑"), (-1, "↓")):
            pts = [(t.target, getattr(t, side).mean) for t in d.targets
                   if t.direction == direction and getattr(t, side) is not None]
            if pts:
                series.append(Series(pts, styles[direction], f"{name} {arrow}", join=True))
    if c.drift is not None:
        pts = [(t.target, t.a.mean) for t in c.drift.residual.targets if t.a is not None]
        if pts:
            series.append(Series(pts, "magenta", "predicted"))
    return PlotData(series, x_label=f"target ({d.target_unit}) · mean deviation ({c.unit})", y_label=c.unit,
                    legend=True)


class VerifyScreen(Screen):
    SCREEN_NAME = "Verify"
    SUB_TITLE = SCREEN_NAME
    DEFAULT_CSS = """
    #verify-body { height: 1fr; }
    #verify-title, #verify-verdict, #verify-table, #verify-values, #verify-flags, #verify-targets, #verify-notes {
        padding: 0 1; height: auto;
    }
    #verify-verdict { text-style: bold; }
    #verify-body #verify-plot { height: 12; margin: 0 1; }
    #verify-notes { color: $text-muted; }
    """
    BINDINGS = [Binding("escape", "back", "back"),
                Binding("pagedown", "scroll(1)", "scroll down", show=False),
                Binding("pageup", "scroll(-1)", "scroll up", show=False),
                Binding("f3", "app.runs", "runs")]

    def __init__(self, found: Path, left: Path) -> None:
        super().__init__()
        self.found = Path(found)
        self.left = Path(left)
        self.verification: Any = None
        self.problem = ""

    def compose(self) -> ComposeResult:
        yield Header()
        with VerticalScroll(id="verify-body"):
            yield Static(f"AS_FOUND: {literal(self.found.name)}\nAS_LEFT: {literal(self.left.name)}", id="verify-title")
            yield Static("verifying… (both runs evaluated, the table applied to AS_FOUND)", id="verify-verdict")
            yield Static(id="verify-table")
            yield Static(id="verify-values")
            yield Static(id="verify-flags")
            yield Plot(id="verify-plot")
            yield Static(id="verify-targets")
            yield Static(id="verify-notes")
        yield Footer()

    def on_mount(self) -> None:
        self.query_one("#verify-plot", Plot).empty_text = "verifying…"
        self.verify()

    def on_resize(self) -> None:
        if self.verification is not None:
            self.show(self.verification)

    @work(thread=True, exclusive=True, group="verify", exit_on_error=False)
    def verify(self) -> None:
        try:
            # in the worker: numpy, pandas and the evaluators take seconds to import and to run
            from fleet.verify.verify import verify_runs

            verification = verify_runs(self.found, self.left)
        except EXPECTED_ERRORS as exc:
            self.app.call_from_thread(self.show_problem, str(exc))
            return
        self.app.call_from_thread(self.show, verification)

    def show_problem(self, text: str) -> None:
        self.problem = text
        self.query_one("#verify-verdict", Static).update(f"[red]cannot verify: {escape(text)}[/red]")
        plot = self.query_one("#verify-plot", Plot)
        plot.empty_text = "not verified"
        plot.refresh()

    def show(self, c: Any) -> None:
        from fleet.compare.text import run_line
        from fleet.verify.text import target_lines, value_lines

        self.verification = c
        wide = self.app.size.width >= WIDE
        self.query_one("#verify-title", Static).update(
            f"{literal(run_line('AS_FOUND', c.found))}\n{literal(run_line('AS_LEFT', c.left))}")
        self.query_one("#verify-verdict", Static).update(escape(f"verdict: {c.verdict()}"))
        self.query_one("#verify-table", Static).update(escape(f"table: {c.table.text()}"))
        values = value_lines(c) if wide else value_rows(c)
        self.query_one("#verify-values", Static).update(escape("\n".join(values)))
        self.query_one("#verify-flags", Static).update(escape("\n".join(flag_lines(c))))
        plot = self.query_one("#verify-plot", Plot)
        plot.empty_text = "no means to plot"
        plot.show(verify_overlay(c))
        self.query_one("#verify-targets", Static).update(escape("\n".join(target_lines(c))))
        notes = (*c.notes, *c.comparison.notes, *c.detail.notes)
        self.query_one("#verify-notes", Static).update(escape("\n".join(f"note: {n}" for n in notes)))

    def action_scroll(self, pages: int) -> None:
        body = self.query_one("#verify-body", VerticalScroll)
        (body.scroll_page_down if pages > 0 else body.scroll_page_up)(animate=False)

    def action_back(self) -> None:
        """Back to the screen this one was pushed over (Results or the runs browser), else to the runs browser."""
        if len(self.app.screen_stack) > 2 and self.app.screen is self:
            self.app.pop_screen()
        elif hasattr(self.app, "action_runs"):
            self.app.action_runs()
