"""Results of a run (when it ends, or any saved run): the evaluation of ``guideway process``, the
HTML report and the compensation tables, re-processed with other options by a key."""

from __future__ import annotations

import math
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
from saved_runs.evaluation.evaluate import process_run_dir
from saved_runs.evaluation.options import EDITIONS, METHODS
from saved_runs.export.build import write_export
from saved_runs.export.options import FORMATS, MODEL_NAMES, ExportOptions
from saved_runs.report.build import build_report

from ..widgets.plot import Plot, PlotData, Series

LINE_NAMES = {"endpoint": "end-point", "least_squares": "least squares", "minimum_zone": "minimum zone"}
LINE_STYLES = {"endpoint": "yellow", "least_squares": "green", "minimum_zone": "magenta"}
MC_CHOICES: tuple[int | None, ...] = (None, 1000, 0)  # default (10 000, fewer on long runs), 1000, off
K_CHOICES = (2.0, 3.0)
ISO_ROWS = (("B", "reversal B"), ("R_up", "repeatability R ↑"), ("R_down", "repeatability R ↓"),
            ("R", "repeatability R"), ("E_up", "systematic E ↑"), ("E_down", "systematic E ↓"),
            ("E", "systematic E"), ("M", "mean positional M"), ("A_up", "accuracy A ↑"),
            ("A_down", "accuracy A ↓"), ("A", "accuracy A"))


def _num(v: Any, digits: int = 3) -> str:
    return f"{v:.{digits}f}" if isinstance(v, int | float) and math.isfinite(v) else "n/a"


def straightness_summary(d: dict[str, Any], mc_trials: int | None) -> str:
    """The straightness values of ``guideway process --json`` (``d``) as the screen shows them."""
    profile = d["profile"]
    travel = profile[-1]["x_mm"] - profile[0]["x_mm"] if profile else 0.0
    unc = (d.get("uncertainty_um") or {}).get("straightness", {})
    mc = "Monte Carlo off" if mc_trials == 0 else (d.get("uncertainty_um") or {}).get("straightness_method", "")
    lines = [f"decoupling [b]{d['method']}[/b] · {len(profile)} stations, travel {travel:g} mm · "
             f"{mc.split(';')[0]}",
             f"{'reference line':<16}{'straightness':>14}{'U (k = 2)':>14}"]
    for name, value in d["straightness_um"].items():
        u = f"± {unc[name]:.3f} um" if name in unc else "n/a"
        lines.append(f"{LINE_NAMES.get(name, name):<16}{value:>11.3f} um{u:>14}")
    rp = d.get("return_pass")
    if rp:
        lines.append(f"return pass: closure {_num(rp.get('closure_um'))} um, drift {_num(rp.get('drift_um_per_h'))} "
                     "um/h (profile = mean of both passes)")
    return "\n".join(lines)


def positioning_summary(d: dict[str, Any]) -> str:
    """The ISO 230-2 axis values of ``guideway process --json`` (``d``) as the screen shows them."""
    iso = d["iso230_2"]
    unit = d["unit"]
    head = (f"ISO 230-2 ({d.get('edition', '')}, k = {d.get('k', 2):g}) · {d['axis_type']} axis · "
            f"{len(d['targets'])} targets · runs ↑/↓ {d.get('runs_up')}/{d.get('runs_down')} · {unit}")
    cells = [f"{label:<20}{_num(iso.get(q)):>9}" for q, label in ISO_ROWS]
    rows = [cells[i] + "   " + cells[i + 6] if i + 6 < len(cells) else cells[i] for i in range(6)]
    return "\n".join([head, *rows])


class ResultsScreen(Screen):
    SCREEN_NAME = "Results"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("h", "report", "report"), Binding("w", "write", "results/", show=False),
                Binding("m", "method", "decoupling method", show=False),
                Binding("u", "uncertainty", "Monte Carlo trials", show=False),
                Binding("k", "coverage", "coverage factor k", show=False),
                Binding("e", "edition", "ISO 230-2 edition", show=False),
                Binding("c", "model", "compensation model", show=False),
                Binding("1", "export('linuxcnc')", "LinuxCNC table", show=False),
                Binding("2", "export('fanuc')", "Fanuc table", show=False),
                Binding("3", "export('siemens')", "Siemens table", show=False),
                Binding("4", "export('csv')", "CSV table", show=False),
                Binding("f3", "app.runs", "runs"), Binding("f2", "app.setup", "set-up")]

    def __init__(self, run_dir: Path, note: str = "") -> None:
        super().__init__()
        self.run_dir = Path(run_dir)
        self.note = note
        self.kind = ""
        self.method = METHODS[0]
        self.mc_index = 0
        self.k_index = 0
        self.edition = EDITIONS[-1]
        self.model = MODEL_NAMES[0]
        self.written: list[str] = []
        self.evaluation: Any = None

    def compose(self) -> ComposeResult:
        yield Header()
        with VerticalScroll(id="results-body"):
            yield Static(id="run-title")
            yield Plot(id="plot")
            yield Static("evaluating...", id="summary")
            yield Static(id="options")
            yield Static(id="written")
        yield Footer()

    def on_mount(self) -> None:
        self.query_one("#run-title", Static).update(escape(str(self.run_dir)) + (
            f"\n[yellow]{escape(self.note)}[/yellow]" if self.note else ""))
        self.evaluate()

    def options(self) -> dict[str, Any]:
        if self.kind == "straightness":
            return {"method": self.method, "mc_trials": MC_CHOICES[self.mc_index]}
        if self.kind == "positioning":
            return {"k": K_CHOICES[self.k_index], "edition": self.edition}
        return {}

    @work(thread=True, exclusive=True, group="evaluate", exit_on_error=False)
    def evaluate(self) -> None:
        try:
            run, evaluation = process_run_dir(self.run_dir, **self.options())
        except EXPECTED_ERRORS as exc:
            self.app.call_from_thread(self.show_problem, str(exc))
            return
        self.app.call_from_thread(self.show, run, evaluation)

    def show_problem(self, text: str) -> None:
        self.query_one("#summary", Static).update(f"[red]not evaluated: {escape(text)}[/red]")

    def show(self, run: Any, evaluation: Any) -> None:
        self.kind = run.kind
        self.evaluation = evaluation
        m = run.meta
        status = m.get("status", "")
        colour = "green" if status == "complete" else "yellow"
        title = (f"[b]{escape(run.kind)}[/b] · {escape(m.get('machine') or 'machine')} · axis "
                 f"{escape(m.get('axis') or '-')} · [{colour}]{escape(status)}[/{colour}] · {len(run.points)} points · "
                 f"{escape(str(self.run_dir))}")
        if self.note:
            title += f"\n[yellow]{escape(self.note)}[/yellow]"
        self.query_one("#run-title", Static).update(title)
        d = evaluation.to_dict()
        plot = self.query_one("#plot", Plot)
        if run.kind == "straightness":
            plot.show(straightness_plot(d))
            self.query_one("#summary", Static).update(straightness_summary(d, MC_CHOICES[self.mc_index]))
        else:
            plot.show(positioning_plot(evaluation))
            self.query_one("#summary", Static).update(positioning_summary(d))
        self.show_options()

    def show_options(self) -> None:
        if self.kind == "straightness":
            mc = MC_CHOICES[self.mc_index]
            text = (f"[b]m[/b] method {self.method}   [b]u[/b] Monte Carlo "
                    f"{'default' if mc is None else 'off' if mc == 0 else mc}   [b]h[/b] report   [b]w[/b] results/")
        else:
            text = (f"[b]k[/b] k = {K_CHOICES[self.k_index]:g}   [b]e[/b] {self.edition}   [b]c[/b] model {self.model}"
                    f"   [b]1-4[/b] {'/'.join(FORMATS)}   [b]h[/b] report")
        self.query_one("#options", Static).update(text)
        self.query_one("#written", Static).update("\n".join(f"written: {escape(p)}" for p in self.written[-4:]))
        if self.written:
            self.query_one("#results-body", VerticalScroll).scroll_end(animate=False)

    # -- re-processing ----------------------------------------------------------------------------
    def action_method(self) -> None:
        if self.kind == "straightness":
            self.method = METHODS[(METHODS.index(self.method) + 1) % len(METHODS)]
            self.evaluate()

    def action_uncertainty(self) -> None:
        if self.kind == "straightness":
            self.mc_index = (self.mc_index + 1) % len(MC_CHOICES)
            self.evaluate()

    def action_coverage(self) -> None:
        if self.kind == "positioning":
            self.k_index = (self.k_index + 1) % len(K_CHOICES)
            self.evaluate()

    def action_edition(self) -> None:
        if self.kind == "positioning":
            self.edition = EDITIONS[(EDITIONS.index(self.edition) + 1) % len(EDITIONS)]
            self.evaluate()

    def action_model(self) -> None:
        if self.kind == "positioning":
            self.model = MODEL_NAMES[(MODEL_NAMES.index(self.model) + 1) % len(MODEL_NAMES)]
            self.show_options()

    # -- files ------------------------------------------------------------------------------------
    @work(thread=True, group="files", exit_on_error=False)
    def action_report(self) -> None:
        self._written(lambda: build_report(self.run_dir, **self.options()))

    @work(thread=True, group="files", exit_on_error=False)
    def action_write(self) -> None:
        if self.evaluation is not None:
            self._written(lambda: self.evaluation.write(self.run_dir / "results"))

    @work(thread=True, group="files", exit_on_error=False)
    def action_export(self, fmt: str) -> None:
        if self.kind == "positioning":
            self._written(lambda: write_export(self.run_dir, ExportOptions(fmt=fmt, model=self.model))[2])

    def _written(self, write: Any) -> None:
        try:
            path = write()
        except (*EXPECTED_ERRORS, OSError) as exc:  # OSError: a full disk, a read-only folder
            self.app.call_from_thread(self.notify, str(exc), severity="error", markup=False)
            return
        path = Path(path)  # shown relative to the run directory (the title names it) where it is inside it
        self.written.append(str(path.relative_to(self.run_dir) if path.is_relative_to(self.run_dir) else path))
        self.app.call_from_thread(self.show_options)


def straightness_plot(d: dict[str, Any]) -> PlotData:
    pts = [(p["x_mm"], p["height_um"]) for p in d["profile"]]
    series = []
    if pts:
        x0, x1 = pts[0][0], pts[-1][0]
        for name, line in d.get("reference_lines", {}).items():
            s, c = line["slope_um_per_mm"], line["intercept_um"]
            series.append(Series([(x0, c + s * x0), (x1, c + s * x1)], LINE_STYLES.get(name, "white"), name,
                                 join=True))
    series.append(Series(pts, "bold cyan", "profile", join=True))  # drawn last: on top of the lines
    return PlotData(series, x_label="x mm · profile cyan · lines: end-point yellow, LSQ green, min. zone magenta",
                    y_label="um")


def positioning_plot(evaluation: Any) -> PlotData:
    dev = evaluation.deviations
    pt = evaluation.result.per_target
    unit = evaluation.result.unit
    up = [(float(r.target), float(r.deviation)) for r in dev.itertuples() if r.direction > 0]
    down = [(float(r.target), float(r.deviation)) for r in dev.itertuples() if r.direction < 0]
    mean_up = [(float(t), float(m)) for t, m in zip(pt["target"], pt["mean_up"], strict=True) if math.isfinite(m)]
    mean_down = [(float(t), float(m)) for t, m in zip(pt["target"], pt["mean_down"], strict=True)
                 if math.isfinite(m)]
    return PlotData([Series(up, "green", "up"), Series(down, "yellow", "down"),
                     Series(mean_up, "green", "mean up", join=True),
                     Series(mean_down, "yellow", "mean down", join=True)],
                    x_label=f"target ({evaluation.result.target_unit}) · deviation ({unit}), up green, down yellow",
                    y_label=unit)
