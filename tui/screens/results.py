"""Results of a run (when it ends, or any saved run): the evaluation of ``guideway process`` with the
``[tolerance]`` verdict shown large, the HTML report and the compensation tables (with the residual they
leave, as ``guideway export --json`` gives it), re-processed with other options by a key; ``d`` opens
the diagnosis of the run (tui/screens/diagnosis.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rich.text import Text
from textual import work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, VerticalScroll
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import Footer, Static
from textual.worker import get_current_worker

from saved_runs.errors import EXPECTED_ERRORS
from saved_runs.evaluation.options import EDITIONS, METHODS
from saved_runs.export.options import FORMATS, MODEL_NAMES, ExportOptions

from ..text import literal
from ..widgets.header import RunHeader
from ..widgets.plot import Plot, PlotData, Series
from .dialogs import ConfirmScreen

LINE_NAMES = {"endpoint": "end-point", "least_squares": "least squares", "minimum_zone": "minimum zone"}
LINE_STYLES = {"endpoint": "yellow", "least_squares": "green", "minimum_zone": "magenta"}
MC_CHOICES: tuple[int | None, ...] = (None, 1000, 0)  # default (10 000, fewer on long runs), 1000, off
K_CHOICES = (2.0, 3.0)
ISO_ROWS = (("B", "reversal B"), ("R_up", "repeatability R ↑"), ("R_down", "repeatability R ↓"),
            ("R", "repeatability R"), ("E_up", "systematic E ↑"), ("E_down", "systematic E ↓"),
            ("E", "systematic E"), ("M", "mean positional M"), ("A_up", "accuracy A ↑"),
            ("A_down", "accuracy A ↓"), ("A", "accuracy A"))
# what each key needs: a run of that kind (None: any kind, once evaluated)
KIND_ACTIONS = {"method": "straightness", "uncertainty": "straightness", "coverage": "positioning",
                "edition": "positioning", "model": "positioning", "export": "positioning"}
# the residual columns of ``guideway export --json`` (saved_runs/export/residuals.py), as the screen names them
RESIDUAL_LABELS = (("in_sample", "in-sample"), ("leave_one_run_out", "run held out"),
                   ("leave_one_target_out", "target held out"))

# a two-row block font for the verdict: large enough to read from the machine
BIG = {"P": ("█▀█", "█▀▀"), "A": ("▄▀█", "█▀█"), "S": ("█▀", "▄█"), "F": ("█▀▀", "█▀ "), "I": ("█", "█"),
       "L": ("█  ", "█▄▄")}


def big_word(word: str) -> str:
    """``word`` (letters of :data:`BIG`) in the two-row block font, letters one column apart."""
    return "\n".join(" ".join(BIG[c][row] for c in word) for row in range(2))


def _num(v: Any, digits: int = 3) -> str:
    return f"{v:.{digits}f}" if isinstance(v, int | float) and math.isfinite(v) else "n/a"


def verdict_category(verdict: Any) -> str:
    """The verdict of saved_runs.evaluation.tolerance as the screen names it: ``PASS``, ``FAIL``, ``PASS within
    uncertainty`` / ``FAIL within uncertainty`` (a deciding check lies within its U of the limit: conformance,
    or non-conformance, is not proven, ISO 14253-1) or ``NOT EVALUATED``."""
    result = verdict.result
    if result not in ("pass", "fail"):
        return "NOT EVALUATED"
    # pass: every check decides, so any one within U leaves it unproven; fail: unproven only when every
    # failing check is within its U (one clear failure proves non-conformance)
    deciding = [c for c in verdict.checks if c.result == result]
    within = all(c.within_uncertainty for c in deciding) if result == "fail" else \
        any(c.within_uncertainty for c in deciding)
    return result.upper() + (" within uncertainty" if within else "")


def check_text(c: Any, name: bool = True) -> str:
    """One tolerance check: value, limit and U, e.g. ``A 3.214 um ≤ limit 10 um · U 0.405 um (k = 2): pass``
    (``name``: with the quantity and the result; without, for the one check the verdict's title names)."""
    value = "not evaluated" if c.value is None else f"{c.value:.3f} {c.unit}"
    op = "≤" if c.value is None or c.value <= c.tolerance else ">"
    u = "U not estimated" if c.uncertainty is None else f"U {c.uncertainty:.3f} {c.unit} (k = 2)"
    text = f"{value} {op} limit {c.tolerance:g} {c.unit} · {u}"
    return f"{c.quantity} {text}: {c.result}" if name else text


def straightness_summary(d: dict[str, Any], mc_trials: int | None) -> str:
    """The straightness values of ``guideway process --json`` (``d``) as the screen shows them."""
    profile = d["profile"]
    travel = profile[-1]["x_mm"] - profile[0]["x_mm"] if profile else 0.0
    unc = (d.get("uncertainty_um") or {}).get("straightness", {})
    mc = "Monte Carlo off" if mc_trials == 0 else (d.get("uncertainty_um") or {}).get("straightness_method", "")
    lines = [f"decoupling [b]{d['method']}[/b] · {len(profile)} stations · {travel:g} mm · "
             f"{','.join(mc.split(';')[0].split(',')[:2])}",
             f"{'reference line':<16}{'straightness':>14}{'U (k = 2)':>14}"]
    for name, value in d["straightness_um"].items():
        u = f"± {unc[name]:.3f} um" if name in unc else "n/a"
        lines.append(f"{LINE_NAMES.get(name, name):<16}{value:>11.3f} um{u:>14}")
    rp = d.get("return_pass")
    if rp:
        lines.append(f"return pass: closure {_num(rp.get('closure_um'))} um, drift {_num(rp.get('drift_um_per_h'))} "
                     "um/h, profile = mean of passes")
    return "\n".join(lines)


def positioning_summary(d: dict[str, Any]) -> str:
    """The ISO 230-2 axis values of ``guideway process --json`` (``d``) as the screen shows them."""
    iso = d["iso230_2"]
    unit = d["unit"]
    head = (f"{d.get('edition') or 'ISO 230-2'}, k = {d.get('k', 2):g} · {d['axis_type']} axis · "
            f"{len(d['targets'])} targets · runs ↑{d.get('runs_up')} ↓{d.get('runs_down')} · {unit}")
    cells = [f"{label:<20}{_num(iso.get(q)):>9}" for q, label in ISO_ROWS]
    rows = [cells[i] + "   " + cells[i + 6] if i + 6 < len(cells) else cells[i] for i in range(6)]
    return "\n".join([head, *rows])


def residual_text(export: dict[str, Any]) -> str:
    """The residual a compensation table leaves, from ``guideway export --json`` (``export``): RMS / max of the
    chosen model in-sample and cross-validated (docs/compensation.md), one line."""
    unit = export.get("unit", "um")
    model = export.get("model", "")
    res = (export.get("residuals") or {}).get(model) or {}
    parts = []
    for key, label in RESIDUAL_LABELS:
        o = res.get(key) or {}
        rms, mx = o.get(f"rms_{unit}"), o.get(f"max_{unit}")
        parts.append(f"{label} {_num(rms)} / {_num(mx)}" if rms is not None else f"{label} n/a")
    return f"residual ({model}, RMS / max {unit}): " + " · ".join(parts)


def default_model_path(run_dir: Path, kind: str) -> str:
    """The model a diagnosis starts from: the run's own (``RUN_DIR/model.toml``, as ``guideway diagnose --out``
    writes it) or the documented example of its kind (``docs/model-<kind>.toml``), "" (no model) if neither."""
    for path in (run_dir / "model.toml", Path("docs") / f"model-{kind}.toml"):
        if path.is_file():
            return str(path)
    return ""


CONTROLLER_FORMATS = ("linuxcnc", "fanuc", "siemens")  # acquisition.setup.compensation: a controller applies them


@dataclass(frozen=True)
class WrittenTable:
    """A compensation table the screen wrote: where, its format and SHA-256, the steps that load it (numbered, as
    ``guideway export`` prints them), and what the controller needs besides the file (the LinuxCNC
    COMP_FILE_TYPE; ``backlash``: the lost motion for the backlash parameter, um or arcsec, Siemens MD32450)."""

    path: Path
    fmt: str
    sha256: str
    steps: list[str]
    comp_file_type: int | None = None
    backlash: float | None = None


def written_table(meta: dict[str, Any], export: Any, path: Path, options: ExportOptions) -> WrittenTable:
    """The :class:`WrittenTable` of an export just written (``meta``: the run's run.json)."""
    from saved_runs.export.load import export_load_instructions, numbered
    from saved_runs.export.provenance import sha256_of

    axis = str((meta.get("setup") or {}).get("axis_name") or meta.get("axis") or "X")
    steps = numbered(export_load_instructions(export, path, options, axis))
    # a one-table export leaves the reversal to the backlash parameter: the lost motion -B̄ the steps name
    # (MD32450 takes a lost motion >= 0; a negative one is left to the technician, as the steps say)
    lost = -float(export.table.backlash) if export.table.mode == "backlash" and options.fmt == "siemens" else None
    backlash = round(lost, 3) if lost is not None and lost >= 0 else None
    return WrittenTable(Path(path), options.fmt, sha256_of(Path(path)), steps,
                        options.linuxcnc_type if options.fmt == "linuxcnc" else None, backlash)


def as_left_name(found: Path) -> str:
    from acquisition.as_left import as_left_dir

    return as_left_dir(found).name


class ResultsScreen(Screen):
    SCREEN_NAME = "Results"
    SUB_TITLE = SCREEN_NAME
    HORIZONTAL_BREAKPOINTS = [(0, "-narrow"), (140, "-wide")]
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
                Binding("d", "diagnose", "diagnose"),
                # the loop (docs/compensation.md): measure again with the table just written, verify the as-left run
                Binding("n", "measure_again", "measure again"),
                Binding("v", "verify", "verify"),
                Binding("pagedown", "scroll_values(1)", "scroll down", show=False),
                Binding("pageup", "scroll_values(-1)", "scroll up", show=False),
                Binding("p", "certificate", "certificate (PDF)", show=False),
                Binding("f3", "app.runs", "runs"), Binding("f2", "app.setup", "set-up")]

    def __init__(self, run_dir: Path, note: str = "") -> None:
        super().__init__()
        self.run_dir = Path(run_dir)
        self.note = note
        self.kind = ""
        self.axis_type = ""
        self.method = METHODS[0]
        self.mc_index = 0
        self.k_index = 0
        self.edition = EDITIONS[-1]
        self.model = MODEL_NAMES[0]
        self.written: list[str] = []
        self.evaluation: Any = None
        self.run: Any = None
        self.evaluating = False
        self.problem = ""
        self.table: WrittenTable | None = None  # the controller table written last (keys 1-3): n measures again
        self.found_run: Path | None = None  # this run's as-found run (it was measured with a table exported there)

    def compose(self) -> ComposeResult:
        yield RunHeader()
        yield Static(id="run-title")
        with Horizontal(id="verdict"):
            yield Static(id="verdict-word")
            yield Static(id="verdict-text")
        with Horizontal(id="results-main"):
            yield Plot(id="plot")
            with VerticalScroll(id="results-side"):
                yield Static("evaluating…", id="summary")
                yield Static(id="load")  # the steps that load the table written last (above the keys' line)
                yield Static(id="options")
        yield Static(id="written")
        yield Footer()

    def on_mount(self) -> None:
        self.query_one("#plot", Plot).empty_text = "evaluating…"
        self.query_one("#verdict").display = False
        self.query_one("#load").display = False  # until a table is written: an empty line would push the values
        self.show_title()
        self.evaluate()

    def on_resize(self) -> None:
        self.show_title(self.run)

    def show_title(self, run: Any = None) -> None:
        parts = []
        if run is not None:
            m = run.meta
            status = m.get("status", "")
            colour = "green" if status == "complete" else "yellow"
            parts = [f"[b]{escape(run.kind)}[/b]"]
            if str(m.get("machine") or "").strip():  # an empty machine name is left out, not shown as "machine"
                parts.append(literal(m["machine"]))
            if str(m.get("axis") or "").strip():
                parts.append(f"axis {literal(m['axis'])}")
            parts += [f"[{colour}]{literal(status)}[/{colour}]", f"{len(run.points)} points"]
        # the run directory's name at 80 columns (one line), its path where there is room
        where = str(self.run_dir) if self.app.size.width >= 140 else self.run_dir.name
        title = " · ".join([*parts, literal(where)])
        if self.note:
            title += f"\n[yellow]{escape(self.note)}[/yellow]"
        if self.found_run is not None:  # the loop's next step: said where it is seen first
            title += f"\nas-left of {escape(self.found_run.name)} (measured with its table): [b]v[/b] verifies it"
        self.query_one("#run-title", Static).update(title)

    def options(self) -> dict[str, Any]:
        if self.kind == "straightness":
            return {"method": self.method, "mc_trials": MC_CHOICES[self.mc_index]}
        if self.kind == "positioning":
            return {"k": K_CHOICES[self.k_index], "edition": self.edition}
        return {}

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """Only the keys that do something on this run are live (footer and help list only those)."""
        if action in KIND_ACTIONS:
            return self.kind == KIND_ACTIONS[action]
        if action == "write":
            return self.evaluation is not None
        if action == "measure_again":
            return self.table is not None
        if action == "verify":
            return self.found_run is not None
        if action == "diagnose":  # the diagnosis covers straightness and linear positioning runs
            return self.kind == "straightness" or (self.kind == "positioning" and self.axis_type == "linear")
        return True

    def evaluate(self) -> None:
        """Evaluate (again) with the current options in a worker; the screen says so meanwhile."""
        self.evaluating = True
        self.show_options()
        self._evaluate(self.options())

    @work(thread=True, exclusive=True, group="evaluate", exit_on_error=False)
    def _evaluate(self, options: dict[str, Any]) -> None:
        worker = get_current_worker()
        try:
            # imported here, in the worker: numpy, pandas, scipy and the evaluators take seconds to load, and the
            # screen answers keys meanwhile
            from saved_runs.evaluation.evaluate import process_run_dir

            run, evaluation = process_run_dir(self.run_dir, **options)
            found = self._found_run(run)
        except EXPECTED_ERRORS as exc:
            if not worker.is_cancelled:
                self.app.call_from_thread(self.show_problem, str(exc))
            return
        if not worker.is_cancelled:  # a newer evaluation (another option) replaces this one
            self.found_run = found
            self.app.call_from_thread(self.show, run, evaluation)

    def _found_run(self, run: Any) -> Path | None:
        """The as-found run of this one when it was measured with a table exported from another run (that run's
        results/ records it): looked for where the table lies, beside this run and in the runs folder."""
        if run.kind != "positioning":
            return None
        from fleet.verify.pairs import found_run_of

        return found_run_of(self.run_dir, [self.run_dir.parent, getattr(self.app, "runs_dir", self.run_dir.parent)])

    def show_problem(self, text: str) -> None:
        self.evaluating = False
        self.problem = text
        self.query_one("#plot", Plot).empty_text = "not evaluated"
        self.query_one("#plot", Plot).refresh()
        self.query_one("#summary", Static).update(f"[red]not evaluated: {escape(text)}[/red]")
        self.show_options()

    def show(self, run: Any, evaluation: Any) -> None:
        self.kind = run.kind
        self.axis_type = str(run.meta.get("axis_type") or "linear")
        self.evaluation = evaluation
        self.run = run
        self.evaluating = False
        self.problem = ""
        self.show_title(run)
        d = evaluation.to_dict()
        plot = self.query_one("#plot", Plot)
        plot.empty_text = "no points to plot"
        if run.kind == "straightness":
            plot.show(straightness_plot(d))
            self.query_one("#summary", Static).update(straightness_summary(d, MC_CHOICES[self.mc_index]))
        else:
            plot.show(positioning_plot(evaluation))
            self.query_one("#summary", Static).update(positioning_summary(d))
        self.show_verdict(getattr(evaluation, "verdict", None))
        self.show_options()
        self.refresh_bindings()

    def show_verdict(self, verdict: Any) -> None:
        """The ``[tolerance]`` verdict, large: PASS / FAIL (within uncertainty) with value, limit and U."""
        box = self.query_one("#verdict")
        box.display = verdict is not None
        if verdict is None:
            return
        category = verdict_category(verdict)
        colour = "green" if category == "PASS" else "red" if category == "FAIL" else "yellow"
        box.set_classes(colour)
        word = category.split()[0]
        self.query_one("#verdict-word", Static).update(
            f"[b {colour}]{big_word(word)}[/]" if word in ("PASS", "FAIL") else f"[b {colour}]NOT\nEVALUATED[/]")
        head = f"[b {colour}]{category}[/]"
        if category == "NOT EVALUATED" and getattr(verdict, "reason", ""):  # why, in plain words
            head += f"[b {colour}]: {escape(verdict.reason)}[/]"
        note = "within U of the limit: not proven (ISO 14253-1)" if "within uncertainty" in category else ""
        checks = sorted(verdict.checks, key=lambda c: c.result != verdict.result)  # the deciding ones first
        if len(checks) == 1:  # the title names the quantity, the next line its value, limit and U
            lines = [f"{head} · {escape(checks[0].quantity)}", escape(check_text(checks[0], name=False))]
            lines += [note] if note else []
        else:
            lines = [head + (f" · {note}" if note else ""), *(escape(check_text(c)) for c in checks[:2])]
            if len(checks) > 2:
                lines.append(f"and {len(checks) - 2} more: " + ", ".join(f"{c.quantity} {c.result}"
                                                                         for c in checks[2:]))
        self.query_one("#verdict-text", Static).update("\n".join(lines))

    def show_options(self) -> None:
        if self.kind == "straightness":
            mc = MC_CHOICES[self.mc_index]
            text = (f"[b]m[/b] method {self.method}   [b]u[/b] Monte Carlo "
                    f"{'default' if mc is None else 'off' if mc == 0 else mc}   [b]h[/b] report   [b]w[/b] results/"
                    "   [b]d[/b] diagnose")
        elif self.kind == "positioning":
            text = (f"[b]k[/b] k = {K_CHOICES[self.k_index]:g}   [b]e[/b] {self.edition}   [b]c[/b] model {self.model}"
                    f"   [b]1-4[/b] {'/'.join(FORMATS)}   [b]h[/b] report   [b]w[/b] results/"
                    + ("   [b]d[/b] diagnose" if self.axis_type == "linear" else ""))
        else:
            text = ""
        self.query_one("#options", Static).update(text)
        # the newest file whole (a table with its residual) first, the earlier ones named on one line after it:
        # the status never pushes the newest residual, nor the title, off the screen (#written's max-height)
        status = self.written[-1:]
        if self.evaluating and self.evaluation is not None:
            status = [*status, f"[yellow]evaluating ({escape(self._options_text())})…[/yellow]"]
        if len(self.written) > 1:
            earlier = ", ".join(w.split("\n", 1)[0].removeprefix("written: ") for w in reversed(self.written[:-1]))
            status.append(f"[dim]earlier: {earlier}[/dim]")
        written = self.query_one("#written", Static)
        written.update("\n".join(status))
        written.display = bool(status)

    def action_scroll_values(self, pages: int) -> None:
        """PageDown / PageUp: the values that do not fit (80x24: the ISO table and the options under the plot)."""
        for selector in ("#results-main", "#results-side"):  # narrow: the column scrolls; wide: the values
            box = self.query_one(selector)
            if box.max_scroll_y > 0:
                (box.scroll_page_down if pages > 0 else box.scroll_page_up)(animate=False)

    def _options_text(self) -> str:
        return ", ".join(f"{k} {'default' if v is None else v}" for k, v in self.options().items())

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

    def action_diagnose(self) -> None:
        from .diagnosis import DiagnosisScreen

        if self.check_action("diagnose", ()):
            self.app.push_screen(DiagnosisScreen(self.run_dir, default_model_path(self.run_dir, self.kind)))

    # -- files ------------------------------------------------------------------------------------
    @work(thread=True, group="files", exit_on_error=False)
    def action_report(self) -> None:
        from saved_runs.report.build import build_report

        self._written(lambda: build_report(self.run_dir, **self.options()))

    @work(thread=True, group="files", exit_on_error=False)
    def action_certificate(self) -> None:
        """results/certificate.pdf with the screen's evaluation options (docs/certificate.md); a refusal is a
        notice."""
        from saved_runs.certificate.build import CertificateOptions, build_certificate

        def write() -> Path:
            (self.run_dir / "results").mkdir(exist_ok=True)
            return build_certificate(self.run_dir, self.run_dir / "results" / "certificate.pdf",
                                     CertificateOptions(evaluation=self.options()))  # as the screen evaluates

        self._written(write)

    @work(thread=True, group="files", exit_on_error=False)
    def action_write(self) -> None:
        if self.evaluation is not None:
            self._written(lambda: self.evaluation.write(self.run_dir / "results"))

    @work(thread=True, group="files", exit_on_error=False)
    def action_export(self, fmt: str) -> None:
        if self.kind == "positioning":
            from saved_runs.export.build import write_export

            tables: list[WrittenTable] = []

            def write() -> tuple[Path, str]:
                options = ExportOptions(fmt=fmt, model=self.model)
                run, export, path = write_export(self.run_dir, options)
                tables.append(written_table(run.meta, export, path, options))
                return path, residual_text(export.to_dict())  # the same object as guideway export --json

            self._written(write)
            if tables:
                self.app.call_from_thread(self.show_load, tables[0])

    def show_load(self, table: WrittenTable) -> None:
        """The steps that load the table just written into its controller (``guideway export`` prints them) and,
        for a controller table, ``n`` to measure again with it; scrolled into view."""
        self.table = table if table.fmt in CONTROLLER_FORMATS else None
        # a Text, not markup: the steps hold INI section names ([JOINT_n]) that markup would take for tags
        text = Text.assemble((f"load {table.path.name}", "bold"), f" (sha256 {table.sha256[:12]}…) into the "
                             "controller as below (the tool writes nothing into it)")
        if self.table is not None:  # the next step first: seen without scrolling
            text.append_text(Text.assemble(", then ", ("n", "bold"), " measure again with it (the as-left run "
                                           f"{as_left_name(self.run_dir)}, same set-up); ", ("v", "bold"),
                                           " then verifies it"))
        text.append(":\n" + "\n".join(table.steps))
        load = self.query_one("#load", Static)
        load.update(text)
        load.display = True
        self.refresh_bindings()
        self.call_after_refresh(lambda: load.scroll_visible(top=True, animate=False))

    def action_measure_again(self) -> None:
        """A new positioning run on this run's set-up with the table written last active in the controller: in
        simulation the simulated controller applies it; with real devices the technician confirms first that it
        is loaded (the tool never loads it)."""
        table, run = self.table, self.run
        if table is None or run is None:
            return
        from acquisition.as_left import as_left_dir, as_left_simulation, as_left_source
        from acquisition.compensation import load_compensation
        from acquisition.setup.files import setup_from_dict

        try:
            source = as_left_source(run.meta, self.run_dir, table.path, table.fmt,
                                    comp_file_type=table.comp_file_type, backlash=table.backlash)
            setup = setup_from_dict(source, f"{self.run_dir.name}/run.json setup_source")
            # read as its controller reads it here, not in the run's thread: a table that does not fit is said on
            # this screen
            active = load_compensation(setup.compensation, setup)  # type: ignore[arg-type, union-attr]
        except EXPECTED_ERRORS as exc:
            self.notify(f"cannot measure again: {exc}", severity="error", markup=False)
            return
        if active.sha256 != table.sha256:  # the dialog quotes the bytes the steps were written for
            self.notify(f"cannot measure again: {table.path} changed since it was written (sha256 now "
                        f"{active.sha256[:12]}…, written {table.sha256[:12]}…); write the table again (1-3)",
                        severity="error", markup=False)
            return
        out = as_left_dir(self.run_dir)
        app: Any = self.app
        simulated = "simulation" in run.meta or bool(getattr(app, "simulate", False))
        name = f"{self.run_dir.name} + {table.path.name}"
        if simulated:
            app.start_run(source, out, simulate=True, source_name=name, back=self.run_dir,
                          sim=as_left_simulation(run.meta, app.sim_options))
            return
        if not setup.devices.controller_url:  # type: ignore[union-attr]
            self.notify(f"cannot measure again: the set-up of {self.run_dir.name} names no controller ([controller] "
                        "url); start the as-left run from the Set-up screen (F2) with the controller's address and "
                        f"[compensation] file = {table.path}", severity="error", markup=False)
            return

        def answered(yes: bool | None) -> None:
            if yes:
                app.start_run(source, out, simulate=False, source_name=name, back=self.run_dir)
            else:
                self.notify(f"not started: load {table.path.name} into the controller first (the steps on this "
                            "screen), then n again", severity="warning", markup=False)

        app.push_screen(ConfirmScreen(
            "Is the table loaded in the controller?",
            f"Measure {out.name} with {table.path} (sha256 {table.sha256[:12]}…) active in the controller? The tool "
            "does not load it: answer y only when the steps are done (the controller restarted or referenced with "
            "this table). The run records this file as the table that was active."), answered)

    def action_verify(self) -> None:
        """The Verify screen: this as-left run against its as-found run."""
        if self.found_run is not None:
            from .verify import VerifyScreen

            self.app.push_screen(VerifyScreen(self.found_run, self.run_dir))

    def _written(self, write: Any) -> None:
        try:
            out = write()
        except (*EXPECTED_ERRORS, OSError) as exc:  # OSError: a full disk, a read-only folder
            self.app.call_from_thread(self.notify, str(exc), severity="error", markup=False)
            return
        path, detail = out if isinstance(out, tuple) else (out, "")
        path = Path(path)  # shown relative to the run directory (the title names it) where it is inside it
        shown = str(path.relative_to(self.run_dir) if path.is_relative_to(self.run_dir) else path)
        self.written.append(f"written: {escape(shown)}" + (f"\n  {escape(detail)}" if detail else ""))
        self.app.call_from_thread(self.show_options)


def straightness_plot(d: dict[str, Any]) -> PlotData:
    """The profile and its reference lines, heights from the least-squares line: the laser's arbitrary tilt
    (tens of um over the travel) would otherwise hide a form of a few um."""
    lines = d.get("reference_lines", {})
    lsq = lines.get("least_squares")

    def base(x: float) -> float:
        return lsq["intercept_um"] + lsq["slope_um_per_mm"] * x if lsq else 0.0

    pts = [(p["x_mm"], p["height_um"] - base(p["x_mm"])) for p in d["profile"]]
    series = []
    if pts:
        x0, x1 = pts[0][0], pts[-1][0]
        for name, line in lines.items():
            s, c = line["slope_um_per_mm"], line["intercept_um"]
            series.append(Series([(x, c + s * x - base(x)) for x in (x0, x1)], LINE_STYLES.get(name, "white"),
                                 LINE_NAMES.get(name, name), join=True))
    series.append(Series(pts, "bold cyan", "profile", join=True))  # drawn last: on top of the lines
    what = "height from the least-squares line" if lsq else "height"
    return PlotData(series, x_label=f"x (mm) · {what} (um)", y_label="um", legend=True)


def positioning_plot(evaluation: Any) -> PlotData:
    dev = evaluation.deviations
    pt = evaluation.result.per_target
    unit = evaluation.result.unit
    up = [(float(r.target), float(r.deviation)) for r in dev.itertuples() if r.direction > 0]
    down = [(float(r.target), float(r.deviation)) for r in dev.itertuples() if r.direction < 0]
    mean_up = [(float(t), float(m)) for t, m in zip(pt["target"], pt["mean_up"], strict=True) if math.isfinite(m)]
    mean_down = [(float(t), float(m)) for t, m in zip(pt["target"], pt["mean_down"], strict=True)
                 if math.isfinite(m)]
    return PlotData([Series(up, "green", "up ↑"), Series(down, "yellow", "down ↓"),
                     Series(mean_up, "green", "mean ↑", join=True),
                     Series(mean_down, "yellow", "mean ↓", join=True)],
                    x_label=f"target ({evaluation.result.target_unit}) · deviation ({unit})", y_label=unit,
                    legend=True)
