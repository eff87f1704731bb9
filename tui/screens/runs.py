"""Runs screen: the saved runs of the runs folder, or of the catalogue when one is configured
(``--catalog`` / ``GUIDEWAY_CATALOG``, docs/fleet.md); open one into Results, resume an unfinished
one, mark two and compare them, open the trend of the selected run's axis.

With a catalogue, ``m`` and ``a`` step the machine and axis filters through what the catalogue
holds and ``l`` switches between the catalogue and the folder.  Space marks a run (two at most);
``x`` compares the two marked runs, the older as A (before) and the newer as B (after).  The
catalogue is read in a worker (SQLAlchemy and a database server take their time), so the screen
paints at once.

Below 120 columns each run takes two lines (its name over its creation time, its kind over its axis),
so that every column fits an 80-column terminal; the machine column takes the width that is left
and wraps.  From 120 columns on, one line per run with every column side by side.  The line under
the table tells the selected run's status in full (why a run is damaged, whether it can be resumed).
"""

from __future__ import annotations

from pathlib import Path

from rich.text import Text
from textual import work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import DataTable, Footer, Header, Static

from fleet.catalog.clock import is_future
from fleet.catalog.config import configured_url, masked_url
from fleet.verify.pairs import Pairs, found_left_pairs
from saved_runs.catalog.folder import DAMAGED, RunSummary, list_runs  # no pandas: the browser paints at once
from saved_runs.errors import UserError, printable

from ..text import literal

NAME_WIDTH = 32
KIND_WIDTH = 12
STATUS_WIDTH = 11  # "in-progress"
POINTS_WIDTH = 9  # "1234/2000"
MACHINE_FLOOR = 8  # the least the machine column gets on screen ("Machine 7, bed" over two lines)
AXIS_MIN_WIDTH, AXIS_MAX_WIDTH = 4, 16  # wide layout: the axis column
WIDE = 120  # from this many columns on, one line per run
CREATED_WIDTH = 19



def wrap(text: str, width: int) -> list[str]:
    """``text`` over lines of at most ``width`` cells, whole (a word longer than the line is split)."""
    import textwrap

    return textwrap.wrap(text, max(1, width), break_on_hyphens=False) or [""]


def is_empty(r: RunSummary) -> bool:
    """A run that ended (or was left) before its first point: F5, then q before any capture."""
    return not r.problem and r.status != "complete" and r.points == 0


class RunsScreen(Screen):
    SCREEN_NAME = "Runs"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("enter", "open", "open results"), Binding("c", "resume", "continue (resume)"),
                Binding("space", "mark", "mark"), Binding("x", "compare", "compare marked"),
                Binding("t", "trend", "trend"), Binding("o", "fleet", "fleet overview"),
                Binding("m", "filter('machine')", "machine"),
                Binding("a", "filter('axis')", "axis"), Binding("l", "source", "folder/catalogue"),
                Binding("r", "reload", "reload"), Binding("f2", "app.setup", "set-up"),
                Binding("v", "verify", "verify"),  # an as-left run against its as-found run
                # the first / last run (the table's own Home / End scroll sideways)
                Binding("home,ctrl+home", "edge(0)", "first run", show=False, priority=True),
                Binding("end,ctrl+end", "edge(1)", "last run", show=False, priority=True)]
    DEFAULT_CSS = """
    RunsScreen #run-detail { height: 2; padding: 0 1; background: $boost; }
    """

    def __init__(self, runs_dir: Path, catalog_url: str | None = None) -> None:
        super().__init__()
        self.runs_dir = Path(runs_dir)
        self.catalog_url = configured_url(catalog_url)  # None: no catalogue, the folder only
        self.from_catalog = self.catalog_url is not None
        self.machine: str | None = None  # the catalogue's filters (None: any)
        self.axis: str | None = None
        self.machines: list[str] = []
        self.axes: list[str] = []
        self.catalog_problem = ""
        self.marked: list[Path] = []  # at most two, in the order they were marked
        self.runs: list[RunSummary] = []
        self.pairs = Pairs({}, {})  # as-found / as-left pairs among the runs listed (fleet/verify/pairs.py)

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
        if self.from_catalog:
            shown = escape(masked_url(str(self.catalog_url)))
            self.query_one("#runs-title", Static).update(f"reading the catalogue {shown} ...")
            self.read_catalog()
        else:
            self.show_runs(list_runs(self.runs_dir))

    @work(thread=True, exclusive=True, group="catalogue")
    def read_catalog(self) -> None:
        from fleet.catalog.browse import CatalogFilter, browse_catalog

        try:
            view = browse_catalog(self.catalog_url, CatalogFilter(self.machine, self.axis))
        except UserError as exc:
            self.app.call_from_thread(self.catalog_failed, str(exc))
            return
        self.app.call_from_thread(self.catalog_read, view.runs, view.machines, view.axes)

    def catalog_read(self, runs: list[RunSummary], machines: list[str], axes: list[str]) -> None:
        self.machines, self.axes, self.catalog_problem = machines, axes, ""
        self.show_runs(runs)

    def catalog_failed(self, message: str) -> None:
        """The catalogue cannot be read: say so, and show the folder meanwhile."""
        self.catalog_problem = message
        self.from_catalog = False
        self.show_runs(list_runs(self.runs_dir))
        self.refresh_bindings()

    def show_runs(self, runs: list[RunSummary]) -> None:
        table = self.query_one(DataTable)
        keep = self.selected()
        self.runs = runs
        self.pairs = found_left_pairs([r.path for r in runs])
        self.marked = [p for p in self.marked if any(r.path == p for r in runs)]
        table.clear(columns=True)
        width = self.app.size.width
        wide = width >= WIDE
        names = [printable(r.path.name) for r in self.runs]
        name_w = min(max([10 if wide else CREATED_WIDTH, *map(len, names)]), NAME_WIDTH)
        # wide: the axis has a column of its own, as wide as the longest axis name up to AXIS_MAX_WIDTH (a longer
        # one wraps); narrow: it stands under the kind
        axis_w = min(max([AXIS_MIN_WIDTH, *(len(printable(r.axis)) for r in self.runs)]), AXIS_MAX_WIDTH)
        widths = [name_w, *([CREATED_WIDTH, KIND_WIDTH, axis_w] if wide else [KIND_WIDTH]), STATUS_WIDTH,
                  POINTS_WIDTH]
        # the rest of the screen (less a scroll bar and each column's padding of one cell either side); the
        # name column gives way so that the machine column keeps MACHINE_FLOOR cells on the screen (a long name
        # wraps instead: an 80-column screen never hides the machine beyond its right edge; the machine wraps)
        spare = width - 2 * (len(widths) + 1) - sum(widths)
        if spare < MACHINE_FLOOR:
            widths[0] = name_w = max(CREATED_WIDTH if not wide else 10, name_w - (MACHINE_FLOOR - spare))
            spare = width - 2 * (len(widths) + 1) - sum(widths)
        machine_w = max(MACHINE_FLOOR, min(spare, max(10, spare - 2)))  # a scroll bar's 2 cells when there is room
        labels = ["run", "created (UTC)", "kind", "axis", "status", "points", "machine"] if wide else \
            ["run · created (UTC)", "kind · axis", "status", "points", "machine"]
        for label, w in zip(labels, [*widths, machine_w], strict=True):
            table.add_column(label, width=w)
        for r in self.runs:
            # as they are (Text: a str cell would be read as markup, "[bold red]X" shown literally), their control
            # characters escaped (a newline or a terminal code in a run.json), cut to the column; marked: *
            # a run dated in the future (its rig's clock was wrong; left out of trends) starts with !
            future = is_future(r.created)
            flags = ("* " if r.path in self.marked else "") + ("! " if future else "")
            name_lines = wrap(flags + printable(r.path.name), name_w)
            pair = self.pair_text(r.path)
            name_lines += wrap(printable(pair), name_w) if pair else []
            created = printable(r.created.replace("T", " ").removesuffix("Z"))
            empty = is_empty(r)
            # an empty run (started, then quit before its first point: F5 then q) is marked, and dim
            style = "dim" if empty else ""
            status = Text("empty" if empty else printable(r.status or "?"),
                          style="bold" if r.status == DAMAGED else style)
            # the catalogue keeps no point count: the folder's browser counts them on disk
            points = Text("-" if self.from_catalog else r.points_text, justify="right", style=style)
            # machine and axis whole, never cut at the column: wrapped over as many lines as they need
            machine = wrap(printable(r.machine), machine_w)
            if wide:
                axis = wrap(printable(r.axis or "-"), axis_w)
                table.add_row(Text("\n".join(name_lines), style=style),
                              Text(created, style="bold" if future else style),
                              Text(printable(r.kind or "?"), style=style),
                              Text("\n".join(axis), style=style), status, points,
                              Text("\n".join(machine), style=style),
                              height=max(len(name_lines), len(axis), len(machine)))
            else:
                axis = wrap(printable(r.axis or "-"), KIND_WIDTH)
                table.add_row(Text("\n".join([*name_lines, created]), style=style),
                              Text("\n".join([printable(r.kind or "?"), *axis]), style=style), status, points,
                              Text("\n".join(machine), style=style),
                              height=max(1 + len(name_lines), 1 + len(axis), len(machine)))
        self.query_one("#runs-title", Static).update(self.title_text())
        if keep is not None:
            table.move_cursor(row=next((i for i, r in enumerate(self.runs) if r.path == keep.path), 0))
        self.show_detail()

    def title_text(self) -> str:
        n = len(self.runs)
        if self.from_catalog:
            where = f"the catalogue {escape(masked_url(str(self.catalog_url)))}"
            filters = [f"{what} {literal(v)}" for what, v in (("machine", self.machine), ("axis", self.axis))
                       if v]
            where += f" ({', '.join(filters)})" if filters else ""
        else:
            where = literal(self.runs_dir)
        problem = f"[b]catalogue: {escape(self.catalog_problem)}[/b]\n" if self.catalog_problem else ""
        marked = f" · {len(self.marked)} marked" if self.marked else ""
        if not n:
            return problem + f"no runs in {where} yet (F2: set up a run)"
        future = sum(1 for r in self.runs if is_future(r.created))
        ahead = f" · [b]{future} dated in the future (!)[/b]" if future else ""
        return problem + f"{n} run(s) in {where}{marked}{ahead} · Enter opens the results"

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """Only the keys that work now are offered (and listed by ? and the footer)."""
        if action in ("trend", "filter", "fleet"):
            return self.from_catalog
        if action == "source":
            return self.catalog_url is not None
        if action == "compare":
            return len(self.marked) == 2
        if action == "verify":
            r = self.selected()
            return r is not None and r.path in self.pairs.found_of
        return True

    def pair_text(self, path: Path) -> str:
        """``left of FOUND`` for an as-left run, ``found, left: LEFT`` for its as-found run ('' otherwise)."""
        if path in self.pairs.found_of:
            return f"left of {self.pairs.found_of[path].name}"
        if path in self.pairs.lefts_of:
            return "found, left: " + ", ".join(p.name for p in self.pairs.lefts_of[path])
        return ""

    def action_verify(self) -> None:
        """The selected as-left run against its as-found run (the Verify screen)."""
        r = self.selected()
        found = self.pairs.found_of.get(r.path) if r is not None else None
        if r is None or found is None:
            self.notify("select an as-left run (marked 'left of ...') to verify it", severity="warning")
            return
        from .verify import VerifyScreen

        self.app.push_screen(VerifyScreen(found, r.path))

    def action_mark(self) -> None:
        """Mark or unmark the selected run; a third mark replaces the oldest."""
        r = self.selected()
        if r is None:
            return
        if r.path in self.marked:
            self.marked.remove(r.path)
        else:
            self.marked = [*self.marked, r.path][-2:]
        self.show_runs(self.runs)
        self.refresh_bindings()

    def action_compare(self) -> None:
        """The two marked runs side by side: the older is A (before), the newer B (after)."""
        if len(self.marked) != 2:
            self.notify("mark two runs with Space first", severity="warning")
            return
        from fleet.trend.fit import parse_date

        from .compare import CompareScreen

        def when(path: Path) -> tuple[int, object]:
            """By time, not by text: 10:00+02:00 is before 09:00Z (a created that is no time sorts last)."""
            text = created.get(path, "")
            try:
                return 0, parse_date(text)
            except ValueError:
                return 1, text

        created = {r.path: r.created for r in self.runs}
        a, b = sorted(self.marked, key=when)
        self.app.push_screen(CompareScreen(a, b))

    def action_trend(self) -> None:
        r = self.selected()
        if r is None or not self.from_catalog:
            return
        from fleet.catalog.browse import DEFAULT_TREND_VALUE

        from .trend import TrendScreen

        self.app.push_screen(TrendScreen(self.catalog_url, r.machine, r.axis, DEFAULT_TREND_VALUE.get(r.kind, "E")))

    def action_fleet(self) -> None:
        """The fleet overview of the catalogue (tui/screens/fleet.py)."""
        if self.from_catalog:
            from .fleet import FleetScreen

            self.app.push_screen(FleetScreen(self.catalog_url))

    def action_filter(self, which: str) -> None:
        """Step the machine or axis filter: any, then each value the catalogue holds, then any again."""
        choices: list[str | None] = [None, *(self.machines if which == "machine" else self.axes)]
        now = self.machine if which == "machine" else self.axis
        following = choices[(choices.index(now) + 1) % len(choices)] if now in choices else None
        if which == "machine":
            self.machine, self.axis = following, None  # the axes differ from machine to machine
        else:
            self.axis = following
        self.action_reload()

    def action_source(self) -> None:
        """Switch between the catalogue and the runs folder."""
        self.from_catalog = not self.from_catalog
        self.catalog_problem = ""
        self.action_reload()
        self.refresh_bindings()

    def show_detail(self) -> None:
        """The selected run's status in full, under the table."""
        r = self.selected()
        name = literal(r.path.name) if r is not None else ""
        if r is None:
            text = ""
        elif r.problem:
            text = f"{name}: [b]{DAMAGED}[/b]: {literal(r.problem)}"
        elif self.from_catalog:  # the catalogue's entry: where the run is, not what is on disk now
            text = f"{name}: {literal(r.status)} when catalogued, at {literal(r.path)}; " \
                   "Enter opens its results, t its axis' trend"
        else:
            planned = f" of {r.planned} planned" if r.planned else ""
            what = "c continues it" if r.resumable else "Enter opens its results"
            text = f"{name}: {literal(r.status)}, {r.points} points on disk{planned}; {what}"
            if is_empty(r):
                text = (f"{name}: empty ({literal(r.status)} before its first point); c continues "
                        f"it, or delete its folder")
        if r is not None and is_future(r.created):
            text += (f"\n[b]! dated in the future[/b] (created {literal(r.created)}): check the rig's clock; "
                     "left out of trends")
        if r is not None and r.path in self.pairs.found_of:
            text += f"; v verifies it against {literal(printable(self.pairs.found_of[r.path].name))}"
        self.query_one("#run-detail", Static).update(text)

    def on_data_table_row_highlighted(self, event: DataTable.RowHighlighted) -> None:
        self.show_detail()
        self.refresh_bindings()  # v verifies only an as-left run

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
            self.notify(printable(f"{r.path.name} is {r.problem or r.status}; nothing to resume"), severity="warning",
                        markup=False)
            return
        self.app.resume_run(r.path)  # type: ignore[attr-defined]
