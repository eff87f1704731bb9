"""Set-up screen: the run's set-up as a form over the set-up file's TOML structure.

Every change is checked with the set-up loader of the run's kind
(:func:`acquisition.setup.files.setup_from_dict`, the checks of ``guideway
acquire``) and its message is shown next to the field it names.  Keys not on
the form (loaded from a file) are kept as they are.
"""

from __future__ import annotations

import contextlib
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
from saved_runs.evaluation.tolerance import REFERENCE_LINES

from .dialogs import ConfirmScreen

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
    address: bool = False  # a port or URL: ``?`` is part of it (modbus-rtu:/dev/ttyUSB1?baud=19200), not help

    @property
    def id(self) -> str:
        return f"f-{self.table or 'top'}-{self.key}"

    @property
    def hint(self) -> str:
        """The placeholder as shown: in parentheses."""
        return f"({self.placeholder})" if self.placeholder else ""


# [tolerance] (saved_runs.evaluation.tolerance): the most each value may be; an empty limit is not
# checked; no limit at all, no verdict
TOLERANCE_TITLE = "Tolerance: the most allowed (PASS / FAIL)"
NO_VERDICT = "none: not checked"


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
            Field("sensor", "port", "sensor port", "str", placeholder="required: e.g. /dev/ttyUSB0", text=True,
                  address=True),
            Field("sensor", "baud", "sensor baud", "optint", placeholder="default: the protocol's own rate"),
            Field("controller", "url", "controller URL", "str",
                  placeholder="required: e.g. modbus-tcp://192.168.0.10:502", text=True, address=True),
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
        (TOLERANCE_TITLE, [
            Field("tolerance", "straightness_um", "straightness (um)", placeholder=NO_VERDICT),
            Field("tolerance", "reference_line", "against the line", "choice", REFERENCE_LINES)]),
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
                  placeholder="required: e.g. modbus-tcp://192.168.0.10:502", text=True, address=True),
            Field("controller", "word_order", "word order", "choice", ("ABCD", "CDAB")),
            *([Field("transmitter", "url", "XY-MD02 URL", "str", placeholder="optional: the controller's "
                     "environment unit", text=True, address=True)] if not rotary else [])]),
        *([("Environment (what the readings contain)", ENVIRONMENT_FIELDS)] if not rotary else []),
        (TOLERANCE_TITLE, positioning_tolerance_fields("arcsec" if rotary else "um")),
    ]


# the ISO 230-2 values of an axis the form offers a limit for (a set-up file may give the others:
# A_up, R_down, ... saved_runs.evaluation.tolerance; they are kept)
TOLERANCE_QUANTITIES = (("A", "A accuracy"), ("R", "R repeatability"), ("E", "E systematic"),
                        ("M", "M mean error"), ("B", "B reversal"))


def positioning_tolerance_fields(unit: str) -> list[Field]:
    """[tolerance] of a positioning set-up: one limit per ISO 230-2 value, ``unit`` um or arcsec."""
    # (a label has 22 columns: "R repeatability (arcsec)" is shortened)
    return [Field("tolerance", f"{q}_{unit}", f"{label if len(label) + len(unit) < 20 else label[:10] + '.'} "
                  f"({unit})", placeholder=NO_VERDICT) for q, label in TOLERANCE_QUANTITIES]


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


class FieldInput(Input):
    """A text field of the form.  Focusing it does not select its text: the next key types at the
    end of the value, it never replaces a value the technician was not looking at."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("select_on_focus", False)
        super().__init__(*args, **kwargs)


    def check_consume_key(self, key: str, character: str | None) -> bool:
        # ? opens the help (SetupScreen's binding), it is not typed: a name or a path has no ?
        return character != "?" and super().check_consume_key(key, character)


class AddressInput(FieldInput):
    """A port or URL: ``?`` is typed into it (``modbus-rtu:/dev/ttyUSB1?baud=19200``); F1 opens the help."""

    def check_consume_key(self, key: str, character: str | None) -> bool:
        return character is not None and character.isprintable()


class NumberInput(FieldInput):
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
                # ? opens the help from every field but a port or URL (where it is part of the address):
                # ahead of the field, which would type it; F1 opens it from everywhere (the application's)
                Binding("question_mark", "help_here", "help", key_display="?/F1", priority=True),
                Binding("escape", "leave_field", "leave the field", show=False)]
    DEFAULT_CSS = """
    SetupScreen #run-kind { layout: horizontal; width: 1fr; }
    SetupScreen #run-kind Choice { width: auto; margin-right: 1; }
    SetupScreen .label.-focused { text-style: reverse; color: $text; }
    SetupScreen Tick:focus > .toggle--label, SetupScreen Choice:focus > .toggle--label { text-style: reverse; }
    SetupScreen #setup-form Input:focus { text-style: bold; }
    SetupScreen .box { height: auto; }
    SetupScreen .box > Vertical { height: auto; }
    SetupScreen.-wide #fields { layout: grid; grid-size: 2; grid-gutter: 0 2; grid-rows: auto; }
    SetupScreen #setup-status { height: 2; }
    SetupScreen #file-error, SetupScreen #file-note { padding-left: 1; }
    SetupScreen #file-note { height: auto; display: none; }
    SetupScreen #start-error { height: auto; padding: 0 1; text-style: bold; color: $error; display: none; }
    SetupScreen .warning { height: auto; padding-left: 25; text-style: bold; color: $warning; display: none; }
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
        self.warnings: list[tuple[Field, str]] = []  # not problems: the run starts, but the technician should know
        self.start_error: str | None = None  # why the last F5 did not start the run (shown until the next F5)
        self._clean: tuple[Any, ...] | None = None  # the form as loaded or saved (q asks when it differs)
        self._reset_clean = True  # the next form built is the clean one (a load, the first form)
        self._loaded_text: str | None = None  # the set-up file's text as loaded: a save keeps its comments
        if setup_path is not None:
            with contextlib.suppress(OSError, UnicodeDecodeError):
                self._loaded_text = Path(setup_path).read_text(encoding="utf-8")

    # -- layout ---------------------------------------------------------------------------------
    def compose(self) -> ComposeResult:
        yield Header()
        with VerticalScroll(id="setup-form"):
            with Horizontal(classes="row"):
                yield Static("set-up file", classes="label")
                yield FieldInput(str(self.setup_path or ""),
                                 placeholder="(none: a name, then ctrl+l load, ctrl+s save)",
                            id="setup-file", compact=True)
            yield Static("", classes="error", id="file-error")
            yield Static("", id="file-note")
            with Horizontal(classes="row"):
                yield Static("run directory", classes="label")
                yield FieldInput(str(self.out or ""), placeholder="(default: RUNS/KIND-<UTC time>)", id="run-dir",
                            compact=True)
            yield Tick("simulated devices (the set-up's devices are not opened)", self.simulate, id="simulate")
            kind = run_kind_of(self.source)
            with RadioSet(id="run-kind"):
                for value, label in RUN_KINDS:
                    yield Choice(label, value == kind, name=value)
            yield Vertical(Static("checking the set-up...", classes="section"), id="fields")
        yield Static("", id="start-error")
        yield Static("checking the set-up...", id="setup-status")
        yield Footer()

    def on_mount(self) -> None:
        self.prepare()

    def on_screen_resume(self) -> None:
        self._starting = False

    def on_descendant_focus(self, event: Any) -> None:
        self._mark_focused(event.widget)

    def on_descendant_blur(self, event: Any) -> None:
        self.call_after_refresh(lambda: self._mark_focused(self.focused))

    def _mark_focused(self, widget: Any) -> None:
        """The label of the focused field in reverse video, and no other (the highlight follows the focus)."""
        row = next((a for a in widget.ancestors_with_self if a.has_class("row")), None) \
            if widget is not None else None
        mine = row.query_children(".label").first() if row is not None and row.query_children(".label") else None
        for label in self.query(".label.-focused"):
            if label is not mine:
                label.remove_class("-focused")
        if mine is not None:
            mine.add_class("-focused")

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
                    kind = (AddressInput if f.address else FieldInput) if f.text else NumberInput
                    widget = kind(_text(value), placeholder=f.hint, id=f.id, compact=True)
                widgets.append(Vertical(Horizontal(Static(f.label, classes="label"), widget, classes="row"),
                                        Static("", classes="error", id=f"{f.id}-error"),
                                        Static("", classes="warning", id=f"{f.id}-warning")))
            boxes.append(Vertical(*widgets, classes="box"))
        self._building = True
        box.mount_all(boxes)
        self.call_after_refresh(self._built)

    def _built(self) -> None:
        self._building = False
        self.check()
        if self._reset_clean:
            self._reset_clean = False
            self._clean = self._form_state()
        if self._start_pending:
            self._start_pending = False
            self.action_start()

    # -- form <-> set-up structure -------------------------------------------------------------
    def read_form(self) -> dict[Field, str]:
        """Parse every field into ``self.source``; returns the fields whose text is not a value
        (those keys are taken out of the structure, so the loader's messages are about the rest)."""
        bad: dict[Field, str] = {}
        had = {k for k, v in self.source.items() if isinstance(v, dict)}
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
        for name in [k for k, v in self.source.items() if v == {} and k not in had]:
            del self.source[name]  # a table only an empty field asked for ([transmitter] without its URL)
        tolerance = self.source.get("tolerance")
        if isinstance(tolerance, dict) and not set(tolerance) - {"reference_line"}:
            # no limit given: no [tolerance] (the line alone, which the form always has, is no tolerance)
            del self.source["tolerance"]
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
        self.warnings = self._warnings(fields) if not problems else []
        for w in self.query(".warning"):
            w.display = False
        for f, text in self.warnings:
            try:
                box = self.query_one(f"#{f.id}-warning", Static)
            except Exception:  # noqa: BLE001 - the form is being rebuilt
                continue
            box.update(escape(text))
            box.display = True
        shown: dict[str, list[str]] = {}
        for f, text in problems:
            shown.setdefault(f.id if f is not None else "file", []).append(text)
        for key, texts in shown.items():
            self._show(key, "\n".join(texts))
        self._show_status()
        return not problems

    def _warnings(self, fields: list[Field]) -> list[tuple[Field, str]]:
        """What a valid set-up will not give: one run per direction has no standard deviation, so no A
        and no R (ISO 230-2): a limit on them is NOT EVALUATED."""
        from acquisition.setup.files import setup_from_dict

        if run_kind_of(self.source) == "straightness":
            return []
        try:
            setup: Any = setup_from_dict(copy.deepcopy(self.source), "set-up")
        except SetupError:
            return []
        runs_field = next((f for f in fields if f.table == "axis" and f.key == "runs"), None)
        if setup.runs >= 2 or runs_field is None:
            return []
        limits = sorted(k.split("_")[0] for k in setup.tolerance if k.split("_")[0] in ("A", "R"))
        then = (f": the limit{'s' if len(set(limits)) > 1 else ''} on {' and '.join(sorted(set(limits)))} "
                "will be NOT EVALUATED" if limits else "")
        return [(runs_field, f"{setup.runs} run per direction cannot give A or R (they need 2+){then}")]

    def _alert(self) -> str:
        """The markup style of a problem: red, or bold in the normal foreground without colour (NO_COLOR)."""
        return "b" if self.app.no_color else "red"

    def _show_status(self) -> None:
        status = self.query_one("#setup-status", Static)
        n = len(self.problems)
        if not self._checked and self._building:
            status.update("checking the set-up...")
        elif n == 0:
            note = f" · note: {escape(self.warnings[0][1])}" if self.warnings else ""
            if self.start_error is not None:  # the set-up is valid, the devices are not: never "valid" alone
                status.update(f"set-up valid, [{self._alert()}]but the run did not start[/] (above): F5 tries again")
            else:
                status.update(f"[{'b' if self.app.no_color else 'green'}]set-up valid[/]: F5 starts the run{note}")
        else:
            more = f" ({n} problems, each under its field)" if n > 1 else ""
            status.update(f"[{self._alert()}]set-up not valid{more}:[/] {escape(self.problems[0][1])}")

    def _show(self, key: str, text: str) -> None:
        try:
            err = self.query_one("#file-error" if key == "file" else f"#{key}-error", Static)
        except Exception:
            return
        err.update(escape(text))  # (its colour: .error in the stylesheet, bold without colour)
        err.display = True

    def _file_note(self, text: str, problem: bool = False) -> None:
        """A line under the set-up file about loading or saving it (cleared when the name changes)."""
        note = self.query_one("#file-note", Static)
        note.update(f"[{self._alert()}]{escape(text)}[/]" if problem and text else escape(text))
        note.display = bool(text)

    def show_start_error(self, error: str) -> None:
        """The run did not start (a device that cannot be opened): said in plain words above the status
        line until the next F5; the driver's own line only in the log."""
        from acquisition.fault_words import start_words

        self._starting = False
        sensor_port = (self.source.get("sensor") or {}).get("port")
        words = start_words(error, {sensor_port: "sensor"} if isinstance(sensor_port, str) else None)
        self.start_error = error
        box = self.query_one("#start-error", Static)
        box.update(f"The run did not start. {escape(words.what)}\n{escape(words.check)}")
        box.display = True
        self._show_status()

    def _form_state(self) -> tuple[Any, ...]:
        """What the technician can edit of the set-up: the run kind and every field's value."""
        values = []
        for f in self.fields():
            try:
                values.append((f.id, self.query_one(f"#{f.id}").value))  # type: ignore[attr-defined]
            except Exception:  # noqa: BLE001 - the form is being rebuilt
                values.append((f.id, None))
        return (run_kind_of(self.source), tuple(values))

    @property
    def edited(self) -> bool:
        """The form differs from the set-up as loaded (or last saved)."""
        return self._clean is not None and (self._building or self._form_state() != self._clean)

    @on(Input.Changed)
    @on(Checkbox.Changed)
    @on(Pick.Changed)
    def _changed(self, event: Any) -> None:
        if getattr(event, "input", None) is not None and event.input.id in ("setup-file", "run-dir"):
            if event.input.id == "setup-file":
                self._file_note("")
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
        if action == "help_here":  # a port or URL keeps its ? (F1 opens the help there)
            return not isinstance(self.focused, AddressInput)
        return True

    def action_help_here(self) -> None:
        self.app.action_help()  # type: ignore[attr-defined]

    def action_quit_form(self) -> None:
        """q: quit; with changes not saved, ask first (the application's question, as Ctrl+Q asks it)."""
        self.app.action_quit_app()  # type: ignore[attr-defined]

    def action_leave_field(self) -> None:
        self.set_focus(None)

    # -- actions --------------------------------------------------------------------------------
    def _path(self) -> Path | None:
        text = self.query_one("#setup-file", Input).value.strip()
        if not text:
            self._file_note("give the set-up file name first", problem=True)
            self.query_one("#setup-file", Input).focus()
            return None
        return Path(text)

    def action_load(self) -> None:
        from saved_runs.toml_file import read_toml

        path = self._path()
        if path is None:
            return
        try:
            source = read_toml(path)
            text = path.read_text(encoding="utf-8")
        except (SetupError, OSError, UnicodeDecodeError) as exc:
            self._file_note(f"cannot load: {exc}", problem=True)
            return
        self._loaded_text = text
        self.load(source)
        self._file_note(f"loaded from {path}")
        self.notify(f"set-up loaded from {path}", markup=False)

    def load(self, source: dict[str, Any]) -> None:
        self._reset_clean = True
        self.source = copy.deepcopy(source)
        radios = self.query_one("#run-kind", RadioSet)
        kind = run_kind_of(self.source)
        for b in radios.query(RadioButton):
            b.value = b.name == kind
        self.build_fields()

    def action_save(self) -> None:
        """Ctrl+S: save the form's set-up to the file named; an existing file is overwritten only when the
        technician says so, and keeps its comments and the keys the form does not show."""
        path = self._path()
        if path is None:
            return
        self.read_form()
        if not path.exists():
            self.save(path)
            return

        def answered(yes: bool | None) -> None:
            if yes:
                self.save(path)
            else:
                self._file_note("not saved")

        self.app.push_screen(ConfirmScreen("Overwrite the set-up file?", f"{path} exists. Overwrite it with the "
                                           "set-up on the form? Its comments and the keys the form does not "
                                           "show are kept."), answered)

    def save(self, path: Path) -> None:
        """Write the form's set-up to ``path`` over the file's own text (``path``'s, else the file loaded):
        every comment stays (acquisition.setup.files.setup_toml_update)."""
        from acquisition.setup.files import setup_toml_update
        from saved_runs.store.files import write_text_atomic

        self.read_form()
        try:
            base = path.read_text(encoding="utf-8") if path.exists() else self._loaded_text
        except (OSError, UnicodeDecodeError):
            base = None
        try:
            text = setup_toml_update(base, self.source)
            write_text_atomic(path, text)
        except (SetupError, OSError) as exc:
            self._file_note(f"cannot save: {exc}", problem=True)
            return
        self._loaded_text = text
        self._clean = self._form_state()
        self._file_note(f"saved to {path}")
        self.notify(f"set-up saved to {path}", markup=False)

    def action_start(self) -> None:
        """F5: start the run; while the set-up is being checked, as soon as it is valid; when it is not,
        the first field with a problem takes the focus (the problems stay shown until fixed)."""
        if self._starting:  # a second F5 before the run's screen is up: one run
            return
        if self.start_error is not None:
            self.start_error = None
            self.query_one("#start-error", Static).display = False
            self._show_status()
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
