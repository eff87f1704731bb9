"""Set-up screen: the run's set-up as a form over the set-up file's TOML structure.

Every change is checked with the set-up loader of the run's kind
(:func:`acquisition.setup.files.setup_from_dict`, the checks of ``guideway
acquire``) and its message is shown next to the field it names.  Keys not on
the form (loaded from a file) are kept as they are.
"""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from textual import on, work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical, VerticalScroll
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import Checkbox, Footer, Header, Input, RadioButton, RadioSet, Select, Static

from saved_runs.errors import SetupError

# The set-up loaders (and the drivers, numpy, pymodbus behind them) are imported in a worker after the
# first frame (SetupScreen.prepare): the screen paints at once and its fields appear when they can be checked.

RUN_KINDS = (("straightness", "gauge-block straightness"), ("linear", "linear positioning"),
             ("rotary", "rotary positioning"))

SKETCH = """\
Block frame (docs/conventions.md): origin at the rear-bottom-centre of the
block, X along the travel, Y up, Z across.  P: interferometer mirror point.
Q: where the sensor beam meets the surface; the beam points down (-Y).
        Y ^      P o
          |  +----------------+
          |  |   block     Q  |   --> X (travel, station k at x = k*L)
        ==+==+=============v==+===== guideway"""


@dataclass(frozen=True)
class Field:
    """One form field: ``table`` ('' = top level) and ``key`` of the set-up structure."""

    table: str
    key: str
    label: str
    kind: str = "float"  # str, float, int, optint, bool, vec, list, choice
    choices: tuple[str, ...] = ()
    aliases: tuple[str, ...] = ()  # other names the loader's messages use for this key
    placeholder: str = ""

    @property
    def id(self) -> str:
        return f"f-{self.table or 'top'}-{self.key}"


def straightness_fields(protocols: tuple[str, ...]) -> list[tuple[str, list[Field]]]:
    return [
        ("Run", [Field("", "machine", "machine", "str"), Field("", "axis", "axis", "str"),
                 Field("", "operator", "operator", "str")]),
        ("Block and stations", [
            Field("block", "length_mm", "block length (mm)", aliases=("block_length_mm",)),
            Field("block", "stations", "stations (incl. datum)", "int", aliases=("stations",)),
            Field("block", "samples_per_reading", "samples per reading", "int", aliases=("samples_per_reading",)),
            Field("block", "return_pass", "return pass", "bool")]),
        ("Geometry", [
            Field("geometry", "mirror_mm", "P mirror (x, y, z) mm", "vec"),
            Field("geometry", "sensor_mm", "Q sensor (x, y, z) mm", "vec"),
            Field("geometry", "sensor_beam", "beam direction", "vec", aliases=("beam",)),
            Field("geometry", "sensor_sign", "sensor sign", "choice", ("height", "gap"))]),
        ("Devices", [
            Field("sensor", "protocol", "sensor protocol", "choice", protocols),
            Field("sensor", "port", "sensor port", "str", placeholder="/dev/ttyUSB0"),
            Field("sensor", "baud", "sensor baud", "optint", placeholder="protocol's own rate"),
            Field("controller", "url", "controller URL", "str", placeholder="modbus-tcp://192.168.0.10:502"),
            Field("controller", "word_order", "word order", "choice", ("ABCD", "CDAB"))]),
        ("Warm-up", [
            Field("warmup", "enabled", "warm-up", "bool"),
            Field("warmup", "window", "window (readings)", "int"),
            Field("warmup", "interval_s", "interval (s)"),
            Field("warmup", "max_drift_ifm_um", "max drift ifm (um)"),
            Field("warmup", "max_drift_sensor_um", "max drift sensor (um)"),
            Field("warmup", "timeout_s", "timeout (s)")]),
        ("Validation limits", [
            Field("validation", "max_sensor_std_um", "max sensor std (um)"),
            Field("validation", "sensor_range_mm", "sensor range (mm)", "vec"),
            Field("validation", "max_lin_um", "max |x - k L| (um)"),
            Field("validation", "jump_ifm_um", "jump ifm (um)"),
            Field("validation", "jump_sensor_um", "jump sensor (um)"),
            Field("validation", "capture_attempts", "capture attempts", "int")]),
    ]


def positioning_fields(unit: str) -> list[tuple[str, list[Field]]]:
    u = unit
    return [
        ("Run", [Field("", "machine", "machine", "str"), Field("axis", "name", "axis name", "str"),
                 Field("", "operator", "operator", "str")]),
        ("Targets and runs", [
            Field("axis", f"start_{u}", f"start ({u})"), Field("axis", f"end_{u}", f"end ({u})"),
            Field("axis", f"targets_{u}", f"targets ({u})", "list",
                  placeholder="optional: generated per ISO 230-2"),
            Field("axis", "runs", "runs per direction", "int"),
            Field("axis", "cycle", "cycle", "choice", ("linear", "step")),
            Field("axis", f"overrun_{u}", f"overrun ({u})"),
            Field("axis", f"datum_{u}", f"datum ({u})", aliases=("datum",)),
            Field("axis", f"max_deviation_{u}", f"max deviation ({u})")]),
        ("Trigger", [
            Field("trigger", "mode", "trigger", "choice", ("in-position", "stability", "manual")),
            Field("trigger", "dwell_s", "dwell (s)"), Field("trigger", "timeout_s", "timeout (s)")]),
        ("Devices", [
            Field("controller", "url", "controller URL", "str", placeholder="modbus-tcp://192.168.0.10:502"),
            Field("controller", "word_order", "word order", "choice", ("ABCD", "CDAB")),
            *([Field("transmitter", "url", "XY-MD02 URL", "str",
                     placeholder="optional: the controller's environment unit")] if u == "mm" else [])]),
        *([("Environment (what the readings contain)", ENVIRONMENT_FIELDS)] if u == "mm" else []),
    ]


# [environment] of a linear axis (docs/run-format.md); an angle is not air-compensated, so rotary has none.
# The placeholders are the loader's defaults (acquisition/setup/positioning.py EnvironmentSetup).
ENVIRONMENT_FIELDS = [
    Field("environment", "expansion_ppm_per_k", "expansion (ppm/K)", placeholder="default 11.5 (steel)"),
    Field("environment", "readings_compensated", "readings compensated by the controller", "bool"),
    Field("environment", "refractive_index_assumed", "air index assumed", placeholder="default 1.0 (uncompensated)"),
    Field("environment", "wavelength_nm", "wavelength (nm)", placeholder="default 632.991 (HeNe)"),
    Field("environment", "dead_path_mm", "dead path (mm)", placeholder="default 0"),
    Field("environment", "abbe_offset_mm", "Abbe offset y, z (mm)", "vec", placeholder="default 0, 0"),
    Field("environment", "co2_ppm", "CO2 (ppm)", placeholder="default 450"),
    Field("environment", "index_equation", "air-index equation", "choice", ("ciddor", "edlen")),
]


def default_source(run_kind: str) -> dict[str, Any]:
    """A new set-up of ``run_kind`` (straightness: the default simulated block, as in docs/setup-straightness.toml)."""
    if run_kind == "straightness":
        from acquisition.simulated.sensors import default_block

        length, geo = default_block()
        return {"kind": "straightness", "machine": "", "axis": "X", "operator": "",
                "block": {"length_mm": length, "stations": 20, "samples_per_reading": 5, "return_pass": False},
                "geometry": geo.to_dict(), "sensor": {"protocol": "keyence-lkg"},
                "controller": {"word_order": "ABCD"}, "warmup": {"enabled": False}}
    if run_kind == "rotary":
        return {"kind": "positioning", "machine": "", "operator": "",
                "axis": {"name": "C", "type": "rotary", "start_deg": 0.0, "end_deg": 360.0, "runs": 5},
                "trigger": {"mode": "in-position"}, "controller": {}}
    return {"kind": "positioning", "machine": "", "operator": "",
            "axis": {"name": "X", "type": "linear", "start_mm": 0.0, "end_mm": 1000.0, "runs": 5},
            "trigger": {"mode": "in-position"}, "controller": {}}


def run_kind_of(source: dict[str, Any]) -> str:
    if source.get("kind", "straightness") == "positioning":
        return "rotary" if (source.get("axis") or {}).get("type") == "rotary" else "linear"
    return "straightness"


def _text(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, list | tuple):
        return ", ".join(f"{x:g}" if isinstance(x, float) else str(x) for x in v)
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def field_for_message(message: str, fields: list[Field]) -> Field | None:
    """The form field a loader message names (``[table] key``, else the key or an alias), earliest first."""
    found: list[tuple[int, int, Field]] = []
    for f in fields:
        names = [f"[{f.table}] {f.key}" if f.table else None, *f.aliases, f.key]
        for rank, name in enumerate(n for n in names if n):
            m = re.search(r"(?<![\w\]])" + re.escape(name) + r"(?!\w)", message) if rank else None
            idx = message.find(name) if rank == 0 and f.table else (m.start() if m else -1)
            if idx >= 0:
                found.append((rank, idx, f))
                break
    if not found:
        return None
    found.sort(key=lambda t: (t[0] > 0, t[1]))
    return found[0][2]


class SetupScreen(Screen):
    SCREEN_NAME = "Set-up"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("f5", "start", "start run"), Binding("ctrl+l", "load", "load"),
                Binding("ctrl+s", "save", "save"), Binding("f3", "app.runs", "runs")]

    def __init__(self, source: dict[str, Any] | None = None, *, setup_path: Path | None = None,
                 out: Path | None = None, simulate: bool = False) -> None:
        super().__init__()
        self.source: dict[str, Any] = copy.deepcopy(source) if source is not None else {}
        self.setup_path = setup_path
        self.out = out
        self.simulate = simulate
        self.problem: str | None = "not checked yet"
        self._building = True  # until prepare() has loaded the set-up checks
        self.protocols: tuple[str, ...] = ()

    # -- layout ---------------------------------------------------------------------------------
    def compose(self) -> ComposeResult:
        yield Header()
        with VerticalScroll(id="setup-form"):
            with Horizontal(classes="row"):
                yield Static("set-up file", classes="label")
                yield Input(str(self.setup_path or ""), placeholder="SETUP.toml (ctrl+l load, ctrl+s save)",
                            id="setup-file", compact=True)
            with Horizontal(classes="row"):
                yield Static("run directory", classes="label")
                yield Input(str(self.out or ""), placeholder="default: RUNS/KIND-<UTC time>", id="run-dir",
                            compact=True)
            yield Checkbox("simulated devices (the set-up's devices are not opened)", self.simulate, id="simulate")
            kind = run_kind_of(self.source)
            with RadioSet(id="run-kind"):
                for value, label in RUN_KINDS:
                    yield RadioButton(label, value == kind, name=value)
            yield Vertical(Static("loading the set-up checks...", classes="section"), id="fields")
        yield Static("", id="setup-status")
        yield Footer()

    def on_mount(self) -> None:
        self.prepare()

    @property
    def ready(self) -> bool:
        """The form is built and checked (F5 can start a run)."""
        return not self._building

    @work(thread=True, exit_on_error=False)
    def prepare(self) -> None:
        """Import the set-up loaders (seconds on a slow machine) off the UI thread, then build the form."""
        import acquisition.setup.files  # noqa: F401 - loaded here, used by check()
        from acquisition.rig import SENSOR_PROTOCOLS

        source = self.source or default_source("straightness")
        self.app.call_from_thread(self._prepared, SENSOR_PROTOCOLS, source)

    def _prepared(self, protocols: tuple[str, ...], source: dict[str, Any]) -> None:
        self.protocols = protocols
        self.load(source)

    def fields(self) -> list[Field]:
        return [f for _, group in self.groups() for f in group]

    def groups(self) -> list[tuple[str, list[Field]]]:
        kind = run_kind_of(self.source)
        if kind == "straightness":
            return straightness_fields(self.protocols)
        return positioning_fields("deg" if kind == "rotary" else "mm")

    def build_fields(self) -> None:
        box = self.query_one("#fields", Vertical)
        box.remove_children()
        widgets: list[Any] = []
        for title, group in self.groups():
            widgets.append(Static(title, classes="section"))
            if title == "Geometry":
                widgets.append(Static(SKETCH, classes="sketch"))
            for f in group:
                value = (self.source.get(f.table) or {}).get(f.key) if f.table else self.source.get(f.key)
                if f.kind == "bool":
                    widget: Any = Checkbox(f.label, bool(value), id=f.id)
                    widgets.append(Vertical(widget, Static("", classes="error", id=f"{f.id}-error"), classes="row"))
                    continue
                if f.kind == "choice":
                    widget = Select([(c, c) for c in f.choices], value=value if value in f.choices else f.choices[0],
                                    allow_blank=False, id=f.id, compact=True)
                else:
                    widget = Input(_text(value), placeholder=f.placeholder or "default", id=f.id, compact=True)
                widgets.append(Vertical(Horizontal(Static(f.label, classes="label"), widget, classes="row"),
                                        Static("", classes="error", id=f"{f.id}-error")))
        self._building = True
        box.mount_all(widgets)
        self.call_after_refresh(self._built)

    def _built(self) -> None:
        self._building = False
        self.check()

    # -- form <-> set-up structure -------------------------------------------------------------
    def read_form(self) -> dict[Field, str]:
        """Parse every field into ``self.source``; returns the fields whose text is not a value."""
        bad: dict[Field, str] = {}
        for f in self.fields():
            try:
                widget = self.query_one(f"#{f.id}")
            except Exception:  # the form is being rebuilt
                continue
            table = self.source if not f.table else self.source.setdefault(f.table, {})
            if isinstance(widget, Checkbox):
                table[f.key] = widget.value
                continue
            if isinstance(widget, Select):
                if widget.value in f.choices:  # (blank for a moment after mounting: keep the set-up's value)
                    table[f.key] = widget.value
                continue
            text = widget.value.strip()
            try:
                value = self._parse(f, text)
            except ValueError as exc:
                bad[f] = str(exc)
                continue
            if value is None:
                table.pop(f.key, None)
            else:
                table[f.key] = value
        kind = run_kind_of(self.source)
        if kind != "straightness":
            self.source.setdefault("axis", {})["type"] = kind
        return bad

    @staticmethod
    def _parse(f: Field, text: str) -> Any:
        if f.kind == "str":
            return text if text or not f.table else None
        if not text:  # the loader's default (a required key: the loader says it is missing)
            return None
        try:
            if f.kind in ("int", "optint"):
                return int(text)
            if f.kind in ("vec", "list"):
                return [float(x) for x in text.replace(";", ",").split(",") if x.strip()]
            return float(text)
        except ValueError:
            what = "a whole number" if f.kind in ("int", "optint") else "numbers separated by commas" \
                if f.kind in ("vec", "list") else "a number"
            raise ValueError(f"{f.label}: {text!r} is not {what}") from None

    def check(self) -> bool:
        """Read the form, validate with the loader; show each message next to its field."""
        from acquisition.setup.files import setup_from_dict

        if self._building:
            return False
        for err in self.query(".error"):
            err.update("")
            err.display = False
        bad = self.read_form()
        problem = None
        if bad:
            f, problem = next(iter(bad.items()))
            self._show(f, problem)
        else:
            try:
                setup_from_dict(self.source, "set-up")
            except SetupError as exc:
                problem = str(exc).removeprefix("set-up: ")
                f = field_for_message(problem, self.fields())
                if f is not None:
                    self._show(f, problem)
        self.problem = problem
        status = self.query_one("#setup-status", Static)
        if problem is None:
            status.update("[green]set-up valid[/green]: F5 starts the run")
        else:
            status.update(f"[red]set-up not valid:[/red] {escape(problem)}")
        return problem is None

    def _show(self, f: Field, text: str) -> None:
        try:
            err = self.query_one(f"#{f.id}-error", Static)
        except Exception:
            return
        err.update(f"[red]{escape(text)}[/red]")
        err.display = True

    @on(Input.Changed)
    @on(Checkbox.Changed)
    @on(Select.Changed)
    def _changed(self, event: Any) -> None:
        if getattr(event, "input", None) is not None and event.input.id in ("setup-file", "run-dir"):
            return
        if getattr(event, "checkbox", None) is not None and event.checkbox.id == "simulate":
            self.simulate = event.value
            return
        self.check()

    @on(RadioSet.Changed, "#run-kind")
    def _kind(self, event: RadioSet.Changed) -> None:
        kind = event.pressed.name or "straightness"
        if not self.protocols or kind == run_kind_of(self.source):
            return
        keep = {k: self.source.get(k, "") for k in ("machine", "operator")}
        self.source = {**default_source(kind), **keep}
        self.build_fields()

    # -- actions --------------------------------------------------------------------------------
    def _path(self) -> Path | None:
        text = self.query_one("#setup-file", Input).value.strip()
        if not text:
            self.query_one("#setup-status", Static).update("[red]give the set-up file name first[/red]")
            return None
        return Path(text)

    def action_load(self) -> None:
        from saved_runs.toml_file import read_toml

        path = self._path()
        if path is None:
            return
        try:
            self.load(read_toml(path))
        except SetupError as exc:
            self.query_one("#setup-status", Static).update(f"[red]{escape(str(exc))}[/red]")
            return
        self.notify(f"set-up loaded from {path}", markup=False)

    def load(self, source: dict[str, Any]) -> None:
        self.source = copy.deepcopy(source)
        radios = self.query_one("#run-kind", RadioSet)
        kind = run_kind_of(self.source)
        for b in radios.query(RadioButton):
            b.value = b.name == kind
        self.build_fields()

    def action_save(self) -> None:
        from acquisition.setup.files import setup_toml_text
        from saved_runs.store.files import write_text_atomic

        path = self._path()
        if path is None:
            return
        self.read_form()
        try:
            write_text_atomic(path, setup_toml_text(self.source))
        except (SetupError, OSError) as exc:
            self.query_one("#setup-status", Static).update(f"[red]cannot save: {escape(str(exc))}[/red]")
            return
        self.notify(f"set-up saved to {path}", markup=False)

    def action_start(self) -> None:
        if self._building:
            self.notify("the set-up form is still loading", severity="warning")
            return
        if not self.check():
            self.notify(f"the set-up is not valid: {self.problem}", severity="error", markup=False)
            return
        out = self.query_one("#run-dir", Input).value.strip()
        self.app.start_run(copy.deepcopy(self.source), Path(out) if out else None,  # type: ignore[attr-defined]
                           simulate=self.query_one("#simulate", Checkbox).value,
                           source_name=str(self._path_or_none() or "set-up"))

    def _path_or_none(self) -> Path | None:
        text = self.query_one("#setup-file", Input).value.strip()
        return Path(text) if text else None
