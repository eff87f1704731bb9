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
from textual.content import Content
from textual.markup import escape
from textual.message import Message
from textual.reactive import reactive
from textual.screen import ModalScreen, Screen
from textual.widget import Widget
from textual.widgets import Checkbox, Footer, Header, Input, RadioButton, RadioSet, Static

from acquisition.setup.maxima import STATIONS_MAX, TARGETS_MAX
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
    """One form field: ``table`` ('' = top level) and ``key`` of the set-up structure.

    ``placeholder`` is what an empty field means, shown in parentheses so that it cannot be taken
    for a value: the loader's default (``(default 2)``), ``(required)`` or what happens instead.
    """

    table: str
    key: str
    label: str
    kind: str = "float"  # str, float, int, optint, bool, vec, list, choice
    choices: tuple[str, ...] = ()
    aliases: tuple[str, ...] = ()  # other names the loader's messages use for this key
    placeholder: str = ""
    text: bool = False  # free text (a name, a port, a URL): the letter keys type into it

    @property
    def id(self) -> str:
        return f"f-{self.table or 'top'}-{self.key}"

    @property
    def hint(self) -> str:
        """The placeholder as shown: in parentheses."""
        return f"({self.placeholder})" if self.placeholder else ""


def _default(v: Any) -> str:
    return f"default {_text(v)}"


def straightness_fields(protocols: tuple[str, ...]) -> list[tuple[str, list[Field]]]:
    from acquisition.setup.straightness import WarmupSetup  # (imported by then: the form is built after the loaders)
    from saved_runs.evaluation.limits import ValidationSetup

    w, v = WarmupSetup(), ValidationSetup()
    return [
        ("Run", [Field("", "machine", "machine", "str", placeholder="none", text=True),
                 Field("", "axis", "axis", "str", placeholder="none", text=True),
                 Field("", "operator", "operator", "str", placeholder="none", text=True)]),
        ("Block and stations", [
            Field("block", "length_mm", "block length (mm)", aliases=("block_length_mm",), placeholder="required"),
            Field("block", "stations", "stations (incl. datum)", "int", aliases=("stations",),
                  placeholder=f"required; at most {STATIONS_MAX}"),
            Field("block", "samples_per_reading", "samples per reading", "int", aliases=("samples_per_reading",),
                  placeholder=_default(5)),
            Field("block", "return_pass", "return pass", "bool")]),
        ("Geometry", [
            Field("geometry", "mirror_mm", "P mirror (x, y, z) mm", "vec", placeholder="required: x, y, z"),
            Field("geometry", "sensor_mm", "Q sensor (x, y, z) mm", "vec", placeholder="required: x, y, z"),
            Field("geometry", "sensor_beam", "beam direction", "vec", aliases=("beam",),
                  placeholder=_default([0.0, -1.0, 0.0])),
            Field("geometry", "sensor_sign", "sensor sign", "choice", ("height", "gap"))]),
        ("Devices", [
            Field("sensor", "protocol", "sensor protocol", "choice", protocols),
            Field("sensor", "port", "sensor port", "str", placeholder="required: e.g. /dev/ttyUSB0", text=True),
            Field("sensor", "baud", "sensor baud", "optint", placeholder="default: the protocol's own rate"),
            Field("controller", "url", "controller URL", "str",
                  placeholder="required: e.g. modbus-tcp://192.168.0.10:502", text=True),
            Field("controller", "word_order", "word order", "choice", ("ABCD", "CDAB"))]),
        ("Warm-up", [
            Field("warmup", "enabled", "warm-up", "bool"),
            Field("warmup", "window", "window (readings)", "int", placeholder=_default(w.window)),
            Field("warmup", "interval_s", "interval (s)", placeholder=_default(w.interval_s)),
            Field("warmup", "max_drift_ifm_um", "max drift ifm (um)", placeholder=_default(w.max_drift_ifm_um)),
            Field("warmup", "max_drift_sensor_um", "max drift sensor (um)",
                  placeholder=_default(w.max_drift_sensor_um)),
            Field("warmup", "timeout_s", "timeout (s)", placeholder=_default(w.timeout_s))]),
        ("Validation limits", [
            Field("validation", "max_sensor_std_um", "max sensor std (um)", placeholder=_default(v.max_sensor_std_um)),
            Field("validation", "sensor_range_mm", "sensor range (mm)", "vec",
                  placeholder=_default(list(v.sensor_range_mm))),
            Field("validation", "max_lin_um", "max |x - k L| (um)", placeholder=_default(v.max_lin_um)),
            Field("validation", "jump_ifm_um", "jump ifm (um)", placeholder=_default(v.jump_ifm_um)),
            Field("validation", "jump_sensor_um", "jump sensor (um)", placeholder=_default(v.jump_sensor_um)),
            Field("validation", "capture_attempts", "capture attempts", "int",
                  placeholder=_default(v.capture_attempts))]),
    ]


def positioning_fields(unit: str) -> list[tuple[str, list[Field]]]:
    u = unit
    rotary = u == "deg"
    return [
        ("Run", [Field("", "machine", "machine", "str", placeholder="none", text=True),
                 Field("axis", "name", "axis name", "str", placeholder=_default("C" if rotary else "X"), text=True),
                 Field("", "operator", "operator", "str", placeholder="none", text=True)]),
        ("Targets and runs", [
            Field("axis", f"start_{u}", f"start ({u})", placeholder=_default(0)),
            Field("axis", f"end_{u}", f"end ({u})",
                  placeholder=_default(360) if rotary else "required unless targets are given"),
            Field("axis", f"targets_{u}", f"targets ({u})", "list",
                  placeholder=f"optional: generated per ISO 230-2; at most {TARGETS_MAX}"),
            Field("axis", "runs", "runs per direction", "int",
                  placeholder=_default(5) if rotary else "default 5; 1 above 2000 mm"),
            Field("axis", "cycle", "cycle", "choice", ("linear", "step")),
            Field("axis", f"overrun_{u}", f"overrun ({u})", placeholder=_default(2 if rotary else 5)),
            Field("axis", f"datum_{u}", f"datum ({u})", aliases=("datum",), placeholder="default: the start"),
            Field("axis", f"max_deviation_{u}", f"max deviation ({u})", placeholder=_default(0.1 if rotary else 1))]),
        ("Trigger", [
            Field("trigger", "mode", "trigger", "choice", ("in-position", "stability", "manual")),
            Field("trigger", "dwell_s", "dwell (s)", placeholder=_default(2)),
            Field("trigger", "timeout_s", "timeout (s)", placeholder=_default(120))]),
        ("Devices", [
            Field("controller", "url", "controller URL", "str",
                  placeholder="required: e.g. modbus-tcp://192.168.0.10:502", text=True),
            Field("controller", "word_order", "word order", "choice", ("ABCD", "CDAB")),
            *([Field("transmitter", "url", "XY-MD02 URL", "str",
                     placeholder="optional: the controller's environment unit", text=True)] if not rotary else [])]),
        *([("Environment (what the readings contain)", ENVIRONMENT_FIELDS)] if not rotary else []),
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


# loader messages about keys the form has no field of, said in the form's words
FORM_WORDS = {"[block] give exactly one of stations or travel_length_mm":
              "give the stations (a set-up file may give [block] travel_length_mm instead)"}


def form_message(message: str, fields: list[Field], source: str = "set-up") -> str:
    """A loader message in the form's words: without the set-up's name, each key it names
    (``[block] length_mm``, ``block_length_mm``) replaced by the label on the form."""
    text = message.removeprefix(f"{source}: ")
    for loader, form in FORM_WORDS.items():
        text = text.replace(loader, form)
    for f in fields:
        names = ([f"[{f.table}] {f.key}"] if f.table else []) + [n for n in (*f.aliases, f.key) if "_" in n]
        for name in names:
            text = re.sub(r"(?<![\w\]])" + re.escape(name) + r"(?!\w)", lambda _m, f=f: f.label, text)
    return text


NUMBER_KEYS = frozenset("0123456789.,;-+eE ")


class NumberInput(Input):
    """A field for numbers: it takes the characters numbers are written with, so that the letter
    keys stay the form's (``q`` quits from here, as from a tick box)."""

    def check_consume_key(self, key: str, character: str | None) -> bool:
        return character is not None and character in NUMBER_KEYS


class Tick(Checkbox):
    """A check box that reads without colour: ``[x]`` ticked, ``[ ]`` not."""

    @property
    def _button(self) -> Content:
        return Content("[x]" if self.value else "[ ]")


class Choice(RadioButton):
    """A radio button that reads without colour: ``(•)`` selected, ``( )`` not."""

    @property
    def _button(self) -> Content:
        return Content("(•)" if self.value else "( )")


class Pick(Widget, can_focus=True):
    """One of a few choices, all shown on one line (``(•) height  ( ) gap``): Left / Right (or
    Space) selects.  Readable without colour; no drop-down to open."""

    DEFAULT_CSS = """
    Pick { height: 1; width: 1fr; padding: 0 1 0 0; }
    Pick:focus { text-style: bold; }
    """
    BINDINGS = [Binding("right,space", "move(1)", "next choice", show=False),
                Binding("left", "move(-1)", "previous choice", show=False)]
    value: reactive[str] = reactive("")

    class Changed(Message):
        def __init__(self, pick: Pick, value: str) -> None:
            super().__init__()
            self.pick, self.value = pick, value

        @property
        def control(self) -> Pick:
            return self.pick

    def __init__(self, choices: tuple[str, ...], value: str, *, id: str | None = None) -> None:  # noqa: A002
        super().__init__(id=id)
        self.choices = choices
        self.set_reactive(Pick.value, value if value in choices else choices[0])

    def render(self) -> Content:
        parts = []
        for c in self.choices:
            mark = "(•) " if c == self.value else "( ) "
            parts.append(Content.styled(mark + c, "reverse") if c == self.value and self.has_focus else
                         Content(mark + c))
        return Content("  ").join(parts)

    def watch_value(self, value: str) -> None:
        self.post_message(self.Changed(self, value))

    def action_move(self, step: int) -> None:
        i = self.choices.index(self.value) if self.value in self.choices else 0
        self.value = self.choices[(i + step) % len(self.choices)]

    def on_focus(self) -> None:
        self.refresh()

    def on_blur(self) -> None:
        self.refresh()


class JumpScreen(ModalScreen[int]):
    """The form's sections, one key each: dismisses with the index of the section chosen."""

    BINDINGS = [Binding("escape", "dismiss_none", "back")]

    def __init__(self, titles: list[str]) -> None:
        super().__init__()
        self.titles = titles
        self.keys = [str(i + 1) if i < 9 else chr(ord("a") + i - 9) for i in range(len(titles))]

    def compose(self) -> ComposeResult:
        with Vertical(id="dialog"):
            yield Static("Go to a section", id="dialog-title")
            yield Static("\n".join(f"[b]{k}[/b]  {escape(t)}" for k, t in zip(self.keys, self.titles, strict=True)),
                         id="dialog-text")
            yield Static("a key jumps to its section; Esc goes back", id="dialog-keys")

    def on_key(self, event) -> None:  # noqa: ANN001 - textual.events.Key
        if event.key in self.keys:
            event.stop()
            self.dismiss(self.keys.index(event.key))

    def action_dismiss_none(self) -> None:
        self.dismiss(None)


class SetupScreen(Screen):
    SCREEN_NAME = "Set-up"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("f5", "start", "start run"), Binding("f4", "jump", "sections"),
                Binding("ctrl+l", "load", "load"), Binding("ctrl+s", "save", "save"),
                Binding("f3", "app.runs", "runs"),
                # the form's own navigation, ahead of the field's (an Input would take End for its cursor:
                # Ctrl+E / Ctrl+A move it there)
                Binding("pagedown", "section(1)", "next section", show=False, priority=True),
                Binding("pageup", "section(-1)", "previous section", show=False, priority=True),
                Binding("end,ctrl+end", "edge(1)", "last field", show=False, priority=True),
                Binding("home,ctrl+home", "edge(-1)", "first field", show=False, priority=True),
                # q quits from every field but one that takes free text (there it is a letter; Esc leaves it):
                # the number fields do not take letters (NumberInput)
                Binding("q", "quit_form", "quit", show=False, priority=True),
                Binding("escape", "leave_field", "leave the field", show=False)]
    DEFAULT_CSS = """
    SetupScreen #run-kind { layout: horizontal; width: 1fr; }
    SetupScreen #run-kind Choice { width: auto; margin-right: 1; }
    SetupScreen .row:focus-within > .label { text-style: reverse; color: $text; }
    SetupScreen Tick:focus > .toggle--label, SetupScreen Choice:focus > .toggle--label { text-style: reverse; }
    SetupScreen #setup-form Input:focus { text-style: bold; }
    SetupScreen .box { height: auto; }
    SetupScreen .box > Vertical { height: auto; }
    SetupScreen.-wide #fields { layout: grid; grid-size: 2; grid-gutter: 0 2; grid-rows: auto; }
    SetupScreen #setup-status { height: 2; }
    SetupScreen #file-error { padding-left: 1; }
    """

    def __init__(self, source: dict[str, Any] | None = None, *, setup_path: Path | None = None,
                 out: Path | None = None, simulate: bool = False) -> None:
        super().__init__()
        self.source: dict[str, Any] = copy.deepcopy(source) if source is not None else {}
        self.setup_path = setup_path
        self.out = out
        self.simulate = simulate
        self.problem: str | None = "not checked yet"
        self.problems: list[tuple[Field | None, str]] = []
        self._building = True  # until prepare() has loaded the set-up checks
        self._checked = False  # the loader has checked the set-up once (before its fields are on the form)
        self._start_pending = False  # F5 pressed before the set-up could be checked
        self._starting = False  # F5 has started a run (until this screen is shown again)
        self.protocols: tuple[str, ...] = ()

    # -- layout ---------------------------------------------------------------------------------
    def compose(self) -> ComposeResult:
        yield Header()
        with VerticalScroll(id="setup-form"):
            with Horizontal(classes="row"):
                yield Static("set-up file", classes="label")
                yield Input(str(self.setup_path or ""), placeholder="(none: a name, then ctrl+l load, ctrl+s save)",
                            id="setup-file", compact=True)
            yield Static("", classes="error", id="file-error")
            with Horizontal(classes="row"):
                yield Static("run directory", classes="label")
                yield Input(str(self.out or ""), placeholder="(default: RUNS/KIND-<UTC time>)", id="run-dir",
                            compact=True)
            yield Tick("simulated devices (the set-up's devices are not opened)", self.simulate, id="simulate")
            kind = run_kind_of(self.source)
            with RadioSet(id="run-kind"):
                for value, label in RUN_KINDS:
                    yield Choice(label, value == kind, name=value)
            yield Vertical(Static("checking the set-up...", classes="section"), id="fields")
        yield Static("checking the set-up...", id="setup-status")
        yield Footer()

    def on_mount(self) -> None:
        self.prepare()

    def on_screen_resume(self) -> None:
        self._starting = False

    def on_resize(self) -> None:
        self.set_class(self.size.width >= 120, "-wide")  # two columns of sections on a wide terminal

    @property
    def ready(self) -> bool:
        """The form is built and checked (F5 can start a run)."""
        return not self._building

    @work(thread=True, exit_on_error=False)
    def prepare(self) -> None:
        """Import the set-up loaders off the UI thread, check the set-up, then build the form.

        The status line says whether the set-up is valid as soon as it is checked, before its
        fields are on the form: F5 starts the run from then on (benchmarks/bench_tui_first_frame.py)."""
        from acquisition.setup.files import setup_problems

        source = self.source or default_source("straightness")
        problems = setup_problems(source, "set-up")
        self.app.call_from_thread(self._checked_early, source, problems)
        from acquisition.rig import SENSOR_PROTOCOLS

        self.app.call_from_thread(self._prepared, SENSOR_PROTOCOLS, source)
        # what F5 needs next (the run's screens and session: pandas, the run store, the simulated rig),
        # loaded while the technician reads the form
        import tui.screens.run  # noqa: F401
        import tui.session  # noqa: F401

    def _checked_early(self, source: dict[str, Any], problems: list[str]) -> None:
        if not self._building:
            return
        self.source = copy.deepcopy(source)
        self._checked = True
        device = self._device_problems()
        self.problems = [(None, p) for p in [*problems, *device]]
        self.problem = self.problems[0][1] if self.problems else None
        self._show_status()
        if self._start_pending and self.problem is None:
            self._start_pending = False
            self.action_start()

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
        boxes: list[Any] = []
        for title, group in self.groups():
            widgets: list[Any] = [Static(title, classes="section")]
            if title == "Geometry":
                widgets.append(Static(SKETCH, classes="sketch"))
            for f in group:
                value = (self.source.get(f.table) or {}).get(f.key) if f.table else self.source.get(f.key)
                if f.kind == "bool":
                    widget: Any = Tick(f.label, bool(value), id=f.id)
                    widgets.append(Vertical(widget, Static("", classes="error", id=f"{f.id}-error"), classes="row"))
                    continue
                if f.kind == "choice":  # a value the form does not offer (from a file) stays, for the loader to name
                    extra = (value,) if isinstance(value, str) and value not in f.choices else ()
                    widget = Pick(f.choices + extra, value if value in f.choices + extra else f.choices[0], id=f.id)
                else:
                    kind = Input if f.text else NumberInput
                    widget = kind(_text(value), placeholder=f.hint, id=f.id, compact=True)
                widgets.append(Vertical(Horizontal(Static(f.label, classes="label"), widget, classes="row"),
                                        Static("", classes="error", id=f"{f.id}-error")))
            boxes.append(Vertical(*widgets, classes="box"))
        self._building = True
        box.mount_all(boxes)
        self.call_after_refresh(self._built)

    def _built(self) -> None:
        self._building = False
        self.check()
        if self._start_pending:
            self._start_pending = False
            self.action_start()

    # -- form <-> set-up structure -------------------------------------------------------------
    def read_form(self) -> dict[Field, str]:
        """Parse every field into ``self.source``; returns the fields whose text is not a value
        (those keys are taken out of the structure, so the loader's messages are about the rest)."""
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
            if isinstance(widget, Pick):
                table[f.key] = widget.value
                continue
            text = widget.value.strip()
            try:
                value = self._parse(f, text)
            except ValueError as exc:
                bad[f] = str(exc)
                table.pop(f.key, None)
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

    def _device_problems(self) -> list[str]:
        """Without simulated devices, the ports and addresses the run opens must be given."""
        if self.simulate:
            return []
        out = []
        if run_kind_of(self.source) == "straightness" and not (self.source.get("sensor") or {}).get("port"):
            out.append("[sensor] port is missing: give the sensor's serial port (e.g. /dev/ttyUSB0), "
                       "or tick simulated devices")
        if not (self.source.get("controller") or {}).get("url"):
            out.append("[controller] url is missing: give the controller's address (e.g. "
                       "modbus-tcp://192.168.0.10:502), or tick simulated devices")
        return out

    def check(self) -> bool:
        """Read the form and check it with the loader; every problem is shown under its field (those
        naming no field under the set-up file) until it is fixed, and counted in the status line."""
        from acquisition.setup.files import setup_problems

        if self._building:
            return False
        for err in self.query(".error"):
            err.update("")
            err.display = False
        bad = self.read_form()
        fields = self.fields()
        problems: list[tuple[Field | None, str]] = list(bad.items())
        for message in [*setup_problems(self.source, "set-up"), *self._device_problems()]:
            text = message.removeprefix("set-up: ")
            problems.append((field_for_message(text, fields), form_message(text, fields)))
        self.problems = problems
        self.problem = problems[0][1] if problems else None
        shown: dict[str, list[str]] = {}
        for f, text in problems:
            shown.setdefault(f.id if f is not None else "file", []).append(text)
        for key, texts in shown.items():
            self._show(key, "\n".join(texts))
        self._show_status()
        return not problems

    def _show_status(self) -> None:
        status = self.query_one("#setup-status", Static)
        n = len(self.problems)
        if not self._checked and self._building:
            status.update("checking the set-up...")
        elif n == 0:
            status.update("[green]set-up valid[/green]: F5 starts the run")
        else:
            more = f" ({n} problems, each under its field)" if n > 1 else ""
            status.update(f"[red]set-up not valid{more}:[/red] {escape(self.problems[0][1])}")

    def _show(self, key: str, text: str) -> None:
        try:
            err = self.query_one("#file-error" if key == "file" else f"#{key}-error", Static)
        except Exception:
            return
        err.update(f"[red]{escape(text)}[/red]")
        err.display = True

    @on(Input.Changed)
    @on(Checkbox.Changed)
    @on(Pick.Changed)
    def _changed(self, event: Any) -> None:
        if getattr(event, "input", None) is not None and event.input.id in ("setup-file", "run-dir"):
            return
        if getattr(event, "checkbox", None) is not None and event.checkbox.id == "simulate":
            self.simulate = event.value
        self.check()

    @on(RadioSet.Changed, "#run-kind")
    def _kind(self, event: RadioSet.Changed) -> None:
        kind = event.pressed.name or "straightness"
        if not self.protocols or kind == run_kind_of(self.source):
            return
        keep = {k: self.source.get(k, "") for k in ("machine", "operator")}
        self.source = {**default_source(kind), **keep}
        self.build_fields()

    # -- navigation -----------------------------------------------------------------------------
    def _section_boxes(self) -> list[Any]:
        return list(self.query("#fields > .box"))

    def _focus_in(self, node: Any) -> None:
        """Focus the first field in ``node`` and bring it into view."""
        target = next((w for w in node.query("*") if w.focusable), None) if node is not None else None
        if target is not None:
            self.query_one("#setup-form", VerticalScroll).scroll_to_widget(node, top=True, animate=False)
            target.focus(scroll_visible=False)

    def action_section(self, step: int) -> None:
        """PageDown / PageUp: the first field of the next / previous section."""
        boxes = self._section_boxes()
        if not boxes:
            return
        focused = self.focused
        here = next((i for i, b in enumerate(boxes) if focused is not None and focused in b.query("*")), -1)
        i = min(max(here + step, 0), len(boxes) - 1) if here >= 0 or step > 0 else -1
        if i < 0:
            self.query_one("#setup-file", Input).focus()
            self.query_one("#setup-form", VerticalScroll).scroll_home(animate=False)
            return
        self._focus_in(boxes[i])

    def action_edge(self, step: int) -> None:
        """End: the last field of the form; Home: the first."""
        form = self.query_one("#setup-form", VerticalScroll)
        focusable = [w for w in form.query("*") if w.focusable]
        if not focusable:
            return
        (focusable[-1] if step > 0 else focusable[0]).focus()
        (form.scroll_end if step > 0 else form.scroll_home)(animate=False)

    def action_jump(self) -> None:
        titles = ["Set-up file, run directory, run kind", *(t for t, _ in self.groups())] if not self._building \
            else []
        if not titles:
            return

        def chosen(i: int | None) -> None:
            if i is None:
                return
            if i == 0:
                self.query_one("#setup-file", Input).focus()
                self.query_one("#setup-form", VerticalScroll).scroll_home(animate=False)
            else:
                self._focus_in(self._section_boxes()[i - 1])

        self.app.push_screen(JumpScreen(titles), chosen)

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "quit_form":  # (a field of free text keeps its letters: Textual does not offer it q)
            return not (isinstance(self.focused, Input) and not isinstance(self.focused, NumberInput))
        return True

    def action_quit_form(self) -> None:
        self.app.exit()

    def action_leave_field(self) -> None:
        self.set_focus(None)

    # -- actions --------------------------------------------------------------------------------
    def _path(self) -> Path | None:
        text = self.query_one("#setup-file", Input).value.strip()
        if not text:
            self.query_one("#setup-status", Static).update("[red]give the set-up file name first[/red]")
            self.query_one("#setup-file", Input).focus()
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
        """F5: start the run; while the set-up is being checked, as soon as it is valid; when it is not,
        the first field with a problem takes the focus (the problems stay shown until fixed)."""
        if self._starting:  # a second F5 before the run's screen is up: one run
            return
        if not self._checked:
            self._start_pending = True
            self.query_one("#setup-status", Static).update("checking the set-up... (F5: the run starts when "
                                                           "it is valid)")
            return
        if self._building:  # checked, fields not on the form yet: the set-up as loaded
            if self.problem is not None:
                self._start_pending = True
                return
            source = copy.deepcopy(self.source)
        else:
            if not self.check():
                f = next((f for f, _ in self.problems if f is not None), None)
                target = self.query_one(f"#{f.id}") if f is not None else self.query_one("#setup-file", Input)
                target.focus()
                self.query_one("#setup-form", VerticalScroll).scroll_to_widget(target, animate=False)
                return
            source = copy.deepcopy(self.source)
        out = self.query_one("#run-dir", Input).value.strip()
        self._starting = True
        self.app.start_run(source, Path(out) if out else None,  # type: ignore[attr-defined]
                           simulate=self.simulate, source_name=str(self._path_or_none() or "set-up"))

    def _path_or_none(self) -> Path | None:
        text = self.query_one("#setup-file", Input).value.strip()
        return Path(text) if text else None
