"""The diagnosis of a run (``d`` on the Results screen): ``guideway diagnose`` against a model file, shown
as the steps (baseline → each effect added → final) in a table and as bars of the residual RMS, so the
gap is seen shrinking to the noise; ambiguous pairs are shown as such (docs/diagnosis.md).  With a catalogue
(``--catalog`` / ``GUIDEWAY_CATALOG``) the serial correlation of the errors is estimated from the machine's
latest earlier runs as well (``guideway diagnose --noise-history``); ``h`` switches that off and on."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from textual import work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, VerticalScroll
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import Footer, Header, Input, Label, Static
from textual.worker import get_current_worker

from fleet.catalog.config import configured_url
from saved_runs.errors import EXPECTED_ERRORS

from ..text import literal
from ..widgets.bars import Bar, BarGroup, Bars

HISTORY_RUNS = 4  # earlier runs of the machine: the benchmark's figure (docs/diagnosis.md)
STEP_HEAD = f"{'step':<6}{'effect':<16}{'RMS um':>8}{'max um':>8}{'ΔBIC':>8}{'p':>9}  result"


def _f(v: Any, fmt: str) -> str:
    """``v`` formatted with ``fmt``; a missing value as "-" in the same width (the table's columns stay)."""
    if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v):
        return format(v, fmt)
    width = fmt.split(".")[0]
    return "-".rjust(int(width) if width.isdigit() else 1)


def _value(v: Any) -> float:
    """A JSON number as a float (None, the JSON of NaN, and anything else: NaN; 0 stays 0)."""
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else math.nan


def params_text(params: dict[str, Any], se: dict[str, Any]) -> str:
    """``name = value ± se`` of a step's fitted parameters (tables: their size only)."""
    parts = []
    for name, v in (params or {}).items():
        if isinstance(v, list):
            parts.append(f"{name} [{len(v)} values]")
        elif isinstance(v, int | float) and not isinstance(v, bool):
            s = (se or {}).get(name)
            parts.append(f"{name} = {v:.4g}" + (f" ± {s:.2g}" if isinstance(s, int | float) else ""))
        elif v is not None:
            parts.append(f"{name} = {v}")
    return ", ".join(parts)


def step_label(step: dict[str, Any]) -> str:
    """A step's name: its label where the diagnosis gives one, else its effect type."""
    return str(step.get("label") or step.get("effect") or "?")


def step_channel(step: dict[str, Any], channels: dict[str, Any], primary: str) -> str:
    """The channel a step was found in (the diagnosis channel, not an Abbe effect's angle channel)."""
    for key in ("diagnosis_channel", "channel"):
        if step.get(key) in channels:
            return str(step[key])
    return primary


def step_result(step: dict[str, Any], named: list[str]) -> str:
    """What the step became: ambiguous (with what), named, or significant only with the later steps."""
    if step.get("ambiguous_with"):
        return f"[yellow]ambiguous: {escape(', '.join(map(str, step['ambiguous_with'])))}[/yellow]"
    evidence = step.get("evidence") or {}
    if evidence.get("significant") is False:
        return "significant only with later steps"
    if step_label(step) in named or step.get("effect") in named:
        return "[green]named[/green]"
    return ""


def diagnosis_view(d: dict[str, Any]) -> tuple[str, list[BarGroup]]:
    """The ``guideway diagnose --json`` object ``d`` as the screen shows it: the step table (markup) and the
    bars of the residual RMS per channel (baseline, after each step; the noise marked)."""
    channels: dict[str, Any] = d.get("channels") or {}
    primary = str(d.get("channel") or next(iter(channels), ""))
    steps = d.get("steps") or []
    lines: list[str] = []
    groups: list[BarGroup] = []
    for name, ch in channels.items():
        base, final = ch.get("baseline") or {}, ch.get("final") or {}
        noise = ch.get("noise_um")
        named = list(ch.get("named") or [])
        mine = [s for s in steps if step_channel(s, channels, primary) == name]
        if lines:
            lines.append("")
        lines.append(f"[b]{escape(name)} channel[/b] · {ch.get('points', '?')} points · noise {_f(noise, '.3f')} um")
        lines.append(f"[dim]{STEP_HEAD}[/dim]")
        lines.append(f"{'base':<6}{'the model':<16}{_f(base.get('rms_um'), '8.3f')}{_f(base.get('max_um'), '8.3f')}")
        bars = [Bar("baseline", _value(base.get("rms_um")), "red")]
        for i, s in enumerate(mine, start=1):
            ev = s.get("evidence") or {}
            label = step_label(s)
            lines.append(f"{i:<6}{escape(label[:15]):<16}{_f(s.get('rms_um'), '8.3f')}{_f(s.get('max_um'), '8.3f')}"
                         f"{_f(ev.get('delta_bic'), '8.1f')}{_f(ev.get('p_value'), '9.1e')}  {step_result(s, named)}")
            detail = params_text(s.get("params") or {}, s.get("se") or {})
            if detail:
                lines.append(f"[dim]{'':<6}{escape(detail)}[/dim]")
            bars.append(Bar(f"+ {label}", _value(s.get("rms_um")),
                            "yellow" if s.get("ambiguous_with") else "cyan"))
        left = [str(sentence) for sentence in ch.get("remains") or []]  # what the final residual still holds
        if not mine and not left:
            lines.append(f"{'':<6}[green]nothing significant is missing from the model[/green]")
        elif not mine:
            lines.append(f"{'':<6}[yellow]no effect of the library is significant, but the residual is not "
                         "white[/yellow]")
        lines.append(f"{'final':<22}{_f(final.get('rms_um'), '8.3f')}{_f(final.get('max_um'), '8.3f')}")
        lines += [f"[yellow]remains: {escape(sentence)}[/yellow]" for sentence in left]
        bars.append(Bar("final", _value(final.get("rms_um")), "green"))
        groups.append(BarGroup(f"{name}: residual RMS um", bars, noise if isinstance(noise, int | float) else None,
                               f"noise {_f(noise, '.3f')} um"))
    history = (d.get("rule") or {}).get("ar1_history") or []
    if history:
        points = sum(int(h.get("points") or 0) for h in history)
        lines.append(f"serial correlation: from this run and {len(history)} earlier run(s) of the machine "
                     f"({points} points)")
    named_all = d.get("named") or []
    lines.append(f"named: [b]{escape(', '.join(map(str, named_all)) or 'none')}[/b]")
    pairs = [" / ".join(map(str, group)) for group in d.get("ambiguous") or []]
    if pairs:
        lines.append(f"[yellow]ambiguous, cannot be told apart on this run: {escape(', '.join(pairs))}[/yellow]")
    for note in d.get("notes") or []:
        lines.append(f"[dim]note: {escape(str(note))}[/dim]")
    return "\n".join(lines), groups


class DiagnosisScreen(Screen):
    """``guideway diagnose RUN_DIR --model MODEL`` on one screen; Escape goes back to the results."""

    SCREEN_NAME = "Diagnosis"
    SUB_TITLE = SCREEN_NAME
    AUTO_FOCUS = ""  # nothing: the keys (m, Enter, Escape, q) answer until the model field is chosen with m
    HORIZONTAL_BREAKPOINTS = [(0, "-narrow"), (140, "-wide")]
    BINDINGS = [Binding("m", "edit_model", "model file"), Binding("enter", "diagnose", "diagnose"),
                Binding("h", "history", "history"), Binding("escape", "back", "results"),
                Binding("f3", "app.runs", "runs"), Binding("f2", "app.setup", "set-up")]

    def __init__(self, run_dir: Path, model_path: str = "") -> None:
        super().__init__()
        self.run_dir = Path(run_dir)
        self.model_path = model_path
        self.result: dict[str, Any] | None = None
        self.error = ""
        self.running = False
        self.use_history = True  # with a catalogue: the machine's earlier runs (h)

    @property
    def catalog_url(self) -> str | None:
        return configured_url(getattr(self.app, "catalog_url", None))

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        return self.catalog_url is not None if action == "history" else True

    def compose(self) -> ComposeResult:
        yield Header()
        # (the results name its path)
        yield Static(f"diagnosis of {literal(self.run_dir.name)}", id="diag-title")
        with Horizontal(id="model-row"):
            yield Label("model file", id="model-label")
            yield Input(self.model_path, placeholder="empty: no model (nothing known)", id="model-path",
                        select_on_focus=False)
        with Horizontal(id="diag-main"):
            with VerticalScroll(id="diag-table-box"):
                yield Static(id="diag-table")
            yield Bars(id="diag-bars")
        yield Static(id="diag-status")
        yield Footer()

    def on_mount(self) -> None:
        self.action_diagnose()

    # -- keys ---------------------------------------------------------------------------------------
    def action_edit_model(self) -> None:
        field = self.query_one("#model-path", Input)
        field.focus()
        field.cursor_position = len(field.value)

    def action_back(self) -> None:
        if self.focused is not None and self.focused.id == "model-path":
            self.set_focus(None)  # Escape leaves the field first
            return
        self.app.pop_screen()

    def action_history(self) -> None:
        self.use_history = not self.use_history
        self.action_diagnose()

    def on_input_submitted(self, event: Input.Submitted) -> None:
        event.stop()
        self.set_focus(None)
        self.action_diagnose()

    def action_diagnose(self) -> None:
        path = self.query_one("#model-path", Input).value.strip()
        self.model_path = path
        if path and not Path(path).is_file():
            self.show_error(f"model file {path}: no such file; enter the path of a model file "
                            f"(docs/model-positioning.toml) or leave it empty for no model")
            return
        self.running = True
        self.error = ""
        self.status(f"[yellow]diagnosing against {escape(path or 'no model (nothing known)')}…[/yellow]")
        self._diagnose(path or None, self.catalog_url, self.use_history)

    @work(thread=True, exclusive=True, group="diagnose", exit_on_error=False)
    def _diagnose(self, model: str | None, catalog_url: str | None, use_history: bool) -> None:
        worker = get_current_worker()
        try:
            from saved_runs.diagnosis.diagnose import diagnose_run  # seconds to load: in the worker, not the UI

            earlier, note = self._history(catalog_url, use_history)
            result = diagnose_run(self.run_dir, model, noise_from=earlier).to_dict()
            result["notes"] = [*result.get("notes", []), *([note] if note else [])]
        except EXPECTED_ERRORS as exc:
            message = str(exc)
        except Exception as exc:  # noqa: BLE001 - shown as one line: the screen stays usable
            message = f"the diagnosis failed: {type(exc).__name__}: {exc}"
        else:
            if not worker.is_cancelled:
                self.app.call_from_thread(self.show, result)
            return
        if not worker.is_cancelled:
            self.app.call_from_thread(self.show_error, message)

    def _history(self, catalog_url: str | None, use: bool) -> tuple[list[Path], str]:
        """The machine's earlier runs in the catalogue (none without one, or with ``h`` off) and a note of what
        was found; a catalogue that cannot be read, or a run it cannot place, is said: the run alone is used."""
        if catalog_url is None:
            return [], ""
        if not use:
            return [], "noise history: off, the run's own estimate (h: the machine's earlier runs)"
        from fleet.catalog.database import open_catalog
        from fleet.catalog.history import earlier_runs

        try:
            with open_catalog(catalog_url, create=False) as cat:
                history = earlier_runs(cat, self.run_dir, HISTORY_RUNS)
        except EXPECTED_ERRORS as exc:
            return [], f"noise history: none ({exc})"
        return list(history.runs), f"noise history: {history.note}" + ("; h: this run alone" if history.runs else "")

    def status(self, text: str) -> None:
        """The status line under the table: what runs, or the one-line error; hidden when there is nothing."""
        line = self.query_one("#diag-status", Static)
        line.update(text)
        line.display = bool(text)

    def show_error(self, message: str) -> None:
        self.running = False
        self.error = message
        self.status(f"[red]cannot diagnose: {escape(message)}[/red]")

    def show(self, result: dict[str, Any]) -> None:
        self.running = False
        self.result = result
        table, groups = diagnosis_view(result)
        self.query_one("#diag-title", Static).update(
            f"diagnosis of {literal(self.run_dir.name)} · {escape(str(result.get('kind', '')))}")
        self.query_one("#diag-table", Static).update(table)
        self.query_one("#diag-bars", Bars).show(groups)
        self.status("")
