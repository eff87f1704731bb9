"""The screens of a running session: connect and warm-up, then capture.

Both draw from :class:`~tui.session.RunSession` (``refresh_view`` after every
message the app applies) and answer the plan's pending instruction with one key.
"""

from __future__ import annotations

import gc
import math
from typing import Any

from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Container, Horizontal, Vertical
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import Digits, Footer, ProgressBar, Sparkline, Static

from acquisition.messages import Instruct

from ..session import RunSession
from ..widgets.header import RunHeader
from ..widgets.plot import Plot, PlotData, Series
from ..widgets.readout import bar, readout_text

STATE_TEXT = {
    "connecting": "[b yellow]CONNECTING[/b yellow] — opening the devices",
    "connected": "[b green]CONNECTED[/b green] — the devices answer; follow the instruction",
    "drifting": "[b yellow]DRIFTING[/b yellow] — waiting for the drift to settle",
    "stable": "[b green]STABLE[/b green] — warm-up done, setting the datum",
    "overridden": "[b magenta]OVERRIDDEN[/b magenta] — warm-up overridden by the operator (recorded in the run)",
    "fault": "[b red]DEVICE FAULT[/b red] — the run is paused; see the dialog",
    "paused": "[b yellow]PAUSED[/b yellow] — resume or abort in the dialog",
}


# acquisition.live.LiveDeviation's labels, short enough for an 80-column screen
SHORT_LABELS = {"environment-compensated": "env.-comp.", "readings compensated by the controller": "ctrl-comp.",
                "angular, not air-compensated": "not air-comp."}


def short_label(label: str) -> str:
    return SHORT_LABELS.get(label, label)


class RunScreen(Screen):
    """What both run screens share: the session, the pending instruction, the keys that answer it."""

    def __init__(self, session: RunSession) -> None:
        super().__init__()
        self.session = session
        # the choices of the last instruction: a key the plan does not offer (redo on a positioning run)
        # is not in the footer; kept between instructions so the footer does not flicker at each capture
        self.offered: tuple[str, ...] = ()
        self._cycle_offered = False

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "choose":
            return parameters[0] in self.offered
        # Space is either the simulated Cycle Start or the capture: one of its two bindings is offered
        if action == "cycle_start":
            return self._cycle_offered
        if action == "confirm":
            return not self._cycle_offered
        return True

    def action_cycle_start(self) -> None:
        self.action_confirm()  # (it presses Cycle Start while one is offered)

    def sync_bindings(self) -> None:
        """Refresh the footer when the pending instruction offers other choices (called with every view
        refresh; cheap when nothing changed)."""
        q = self.instruction
        cycle = self.cycle_start_offered()
        if q is not None and (q.choices != self.offered or cycle != self._cycle_offered):
            self.offered = q.choices
            self._cycle_offered = cycle
            self.refresh_bindings()

    def cycle_start_offered(self) -> bool:
        """Space is the simulated Cycle Start now (a manual trigger rehearsed in simulation, not pressed yet
        for this target): the footer and the help say so, not "capture"."""
        v, q = self.session.view, self.instruction
        return (q is not None and q.action == "cycle_start" and q.key == "target" and self.session.operator.can_act(q)
                and v.capture_when_stable != v.ticket)

    @property
    def instruction(self) -> Instruct | None:
        q = self.session.view.question
        return q if isinstance(q, Instruct) else None

    def choose(self, choice: str) -> None:
        q = self.instruction
        if q is None:
            self.refuse(choice)
        elif choice in q.choices:
            self.session.answer(choice)
            self.refresh_view()

    def refuse(self, choice: str) -> None:
        """A key pressed while the run is busy (capturing, paused, a device working): not queued (a second
        capture would be taken where the block is not yet), refused with a message that stays on screen
        until the next instruction."""
        v = self.session.view
        why = "the run is paused" if v.state == "paused" else f"busy ({self.busy_text()})"
        v.refused = f"'{choice}' not taken: {why}; press it again when the screen asks"
        self.notify(v.refused, severity="warning", timeout=4)
        self.refresh_view()

    def busy_text(self) -> str:
        v = self.session.view
        if not v.started:
            return "opening the devices"
        if self.session.info.kind == "straightness" and v.step is not None:
            return f"capturing {self.session.where()}"
        return "the devices are being read"

    def action_confirm(self) -> None:
        if self.session.cycle_start():  # simulated manual trigger: Space is Cycle Start, the capture follows
            self.notify("Cycle Start (simulated): the capture follows when the light is STABLE")
            self.refresh_view()
            return
        q = self.instruction
        if q is None:
            self.refuse("capture" if isinstance(self, CaptureScreen) else "done")
        else:
            self.choose(q.choices[0])

    def action_choose(self, choice: str) -> None:
        q = self.instruction
        if q is None or choice not in ("redo", "skip"):
            self.choose(choice)
            return
        ticket = self.session.view.ticket
        title, text = self.confirm_text(choice, q)

        def answered(yes: bool | None) -> None:
            if yes and self.session.view.ticket == ticket and self.instruction is q:
                self.choose(choice)

        from .dialogs import ConfirmScreen

        self.app.push_screen(ConfirmScreen(title, text), answered)

    def action_pause(self) -> None:
        self.session.pause()
        self.notify("pause requested: the run pauses at its next step")

    def action_abort(self) -> None:
        def answered(yes: bool | None) -> None:
            if yes:
                self.session.abort()

        self.app.push_screen(ConfirmAbort(), answered)

    def confirm_text(self, choice: str, q: Instruct) -> tuple[str, str]:
        """The question before a redo or a skip (both change what is on disk)."""
        p = q.params
        if self.session.info.kind == "straightness" and "station" in p:
            k, pass_ = int(p["station"]), int(p.get("pass", 0))
            if choice == "redo":
                steps = self.session.info.setup.steps() if self.session.info.setup is not None else []
                i = steps.index((pass_, k)) if (pass_, k) in steps else 0
                where = f"station {steps[i - 1][1]}{' (return)' if steps[i - 1][0] else ''}" if i > 0 \
                    else "the previous station"
                return (f"Redo {where}?", f"Its point is withdrawn from the run and the block goes back there to be "
                        f"captured again (now at station {k}).")
            return (f"Skip station {k}{' (return pass)' if pass_ else ''}?",
                    "No point is captured there; the skip is recorded in run.json (skipped). Redo (r) at the next "
                    "station brings it back.")
        return (f"Skip {self.session.where()}?", "No point is captured there; the skip is recorded in run.json "
                "(skipped).")

    def instruction_text(self) -> str:
        q = self.instruction
        v = self.session.view
        if q is None:
            if v.state == "paused":
                what = "device fault: answer the dialog" if v.fault_since is not None else "answer the dialog"
                return f"[b yellow]PAUSED[/b yellow] — {what}"
            if v.warmup.get("state") == "drifting":
                return self.warmup_text()
            return "[dim]working...[/dim]"
        keys = {"capture": "Space", "done": "Space", "started": "Space", "redo": "r", "skip": "s", "pause": "p",
                "abort": "a"}
        choices = "   ".join(f"[b]{escape(keys.get(c, c))}[/b] {escape(c)}" for c in q.choices)
        return f"{escape(q.text)}\n{choices}"

    def warmup_text(self) -> str:
        """What the warm-up waits for, where it is, and the override key."""
        w = self.session.view.warmup
        nan = math.nan
        ifm, sensor = w.get("drift_ifm_um", nan), w.get("drift_sensor_um", nan)
        # a drift needs two readings: before them there is no number to show (never "nan")
        now = (f"now {ifm:.2f} / {sensor:.2f} um" if math.isfinite(ifm) and math.isfinite(sensor)
               else "now — (waiting for the first readings)")
        return (f"[b]Warm-up:[/b] waiting until the drift (peak to peak over the last {w.get('window')} readings) "
                f"is below {w.get('max_drift_ifm_um', nan):g} um (interferometer straightness) and "
                f"{w.get('max_drift_sensor_um', nan):g} um (sensor); {now}.\n[b]o[/b] override now (recorded "
                f"in the run)   [b]a[/b] abort")

    def log_text(self, lines: int) -> str:
        return "\n".join(escape(line) for line in list(self.session.view.log)[-lines:])

    def refresh_view(self) -> None:  # pragma: no cover - overridden
        pass

    def on_mount(self) -> None:
        # Everything alive now (the imported stacks, the app, its screens) lives as long as the process: out of
        # the collector's reach, a full collection no longer walks it and stalls the screen and the live
        # monitor's thread for ~0.2 s (benchmarks/bench_tui_live_stream.py); what the run allocates is still
        # collected.
        gc.freeze()
        self.refresh_view()
        self.sync_bindings()


def ConfirmAbort() -> Any:  # noqa: N802 - a factory named like the dialog it makes
    from .dialogs import ConfirmScreen

    return ConfirmScreen("Abort the run?", "The points captured so far stay on disk and the run stays "
                         "resumable (Runs screen, or guideway acquire --resume).")


class ConnectScreen(RunScreen):
    """Connect and warm-up: live readings of both instruments, the drift against its limits, a clear state."""

    SCREEN_NAME = "Connect and warm-up"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("space,enter", "confirm", "done", key_display="Space"),
                Binding("o", "override", "override warm-up"), Binding("p", "pause", "pause"),
                Binding("a", "abort", "abort")]

    def compose(self) -> ComposeResult:
        yield RunHeader()
        yield Static(id="state")
        yield Static(id="instruction", classes="instruction")
        yield Static(id="readout")
        yield Static(id="drift")
        yield Sparkline([], id="history")
        yield Static(id="log", classes="log")
        yield Footer()

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "override":  # only a set-up with a warm-up has one to override
            return self.session.info.warmup
        return super().check_action(action, parameters)

    def action_override(self) -> None:
        if not self.session.info.warmup:
            return
        v = self.session.view
        if v.warmup.get("state") != "drifting":
            # a request now would wait for the warm-up and end it at its first reading, unseen: refused, said
            why = ("the warm-up has not started yet (it starts when the datum instruction is done)"
                   if not v.warmup else "the warm-up is over")
            v.refused = f"'o' not taken: {why}; press o while the warm-up runs"
            self.notify(v.refused, severity="warning", timeout=4)
            self.refresh_view()
            return
        self.session.override()
        self.notify("warm-up override requested (recorded in the run)")

    def state_key(self) -> str:
        v = self.session.view
        if v.fault_since is not None:
            return "fault"
        if v.state == "paused":
            return "paused"
        if not v.started:
            return "connecting"
        if v.warmup:
            return str(v.warmup.get("state", "drifting"))
        return "connected"  # before the warm-up's first reading (the datum instruction), or no warm-up

    def refresh_view(self) -> None:
        v = self.session.view
        state = STATE_TEXT[self.state_key()]
        if v.warmup:
            w = v.warmup
            state += f"   [dim]{w['elapsed_s']:.0f} s, {w['readings']} readings (window {w['window']})[/dim]"
        self.query_one("#state", Static).update(state)
        refused = f"\n[b yellow]{escape(v.refused)}[/b yellow]" if v.refused else ""
        self.query_one("#instruction", Static).update(self.instruction_text() + refused)
        self.query_one("#readout", Static).update(readout_text(v.reading, sensor=self.session.info.kind
                                                               == "straightness"))
        if self.session.info.warmup:
            w = v.warmup
            nan = math.nan
            self.query_one("#drift", Static).update(
                "drift, peak-to-peak over the window:\n"
                f"  interferometer {bar(w.get('drift_ifm_um', nan), w.get('max_drift_ifm_um', 0.0))}\n"
                f"  sensor         {bar(w.get('drift_sensor_um', nan), w.get('max_drift_sensor_um', 0.0))}")
        else:
            self.query_one("#drift", Static).update("[dim]no warm-up in this set-up[/dim]")
        self.query_one("#history", Sparkline).data = list(v.live_history)
        self.query_one("#log", Static).update(self.log_text(3))


LIGHT = {"moving": "[b red]● MOVING[/b red]", "settling": "[b yellow]◐ SETTLING[/b yellow]",
         "stable": "[b green]○ STABLE[/b green]"}  # the word reads without colour
WIDE = (120, 40)  # columns, rows from which the readings stand beside the plot


def range_bar(value: float, lo: float, hi: float, width: int = 20) -> str:
    """Where ``value`` lies in [lo, hi] as a bar with a marker (│ the middle); beyond an end red."""
    if not (math.isfinite(value) and hi > lo):
        return "[dim]" + "·" * width + "[/dim]"
    f = (value - lo) / (hi - lo)
    pos = min(width - 1, max(0, int(f * width)))
    cells = ["·"] * width
    cells[width // 2] = "│"
    colour = "green" if 0.0 <= f <= 1.0 else "red"
    cells[pos] = f"[b {colour}]█[/b {colour}]"
    return "".join(cells)


def beam_text(r: Any, sensor: bool) -> str:
    """Beam and signal state of the live reading in words (not colour alone)."""
    if r is None:
        return "[dim]beam ? · waiting for a reading[/dim]"
    ifm = r.interferometer
    if ifm is None:
        parts = ["[dim]beam: no reading yet[/dim]"]
    else:
        st = ifm.status
        parts = ["beam OK" if st.beam_ok else "[b red]BEAM LOST[/b red]",
                 "data valid" if st.data_valid else "[red]data not valid[/red]"]
        if st.error or st.error_code:
            parts.append(f"[red]error {st.error_code}[/red]")
    if sensor:
        st_s = r.sensor_status
        parts.append("sensor ok" if st_s == "ok" else f"[red]sensor {escape(st_s or 'silent')}[/red]")
    return " · ".join(parts)


def distance_text(offset_um: float, near_um: float) -> str:
    """Straightness: how far the block is from the station (µm near it, mm beyond 1 mm)."""
    if not math.isfinite(offset_um):
        return ""
    if abs(offset_um) >= 1000.0:
        return f"{abs(offset_um) / 1000.0:.3f} mm {'past' if offset_um > 0 else 'to'} the station"
    where = "at the station" if abs(offset_um) <= near_um else "off the station"
    return f"{offset_um:+.1f} um, {where}"


class CaptureScreen(RunScreen):
    """Capture: where the run is (station k of N, or target i of m · run j of n · direction), the
    instruction, the value the technician acts on in large digits (straightness: the live decoupled
    surface height; positioning: the live compensated deviation from the target) with the distance to
    the target, the stability light and auto-capture, beam and signal, the raw reading small, and the
    live profile (positioning: deviations)."""

    SCREEN_NAME = "Capture"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("space,enter", "cycle_start", "Cycle Start", key_display="Space"),  # simulated manual trigger
                Binding("space,enter", "confirm", "capture", key_display="Space"),
                Binding("r", "choose('redo')", "redo"), Binding("s", "choose('skip')", "skip"),
                Binding("t", "auto", "auto-capture"),
                Binding("p", "pause", "pause"), Binding("a", "abort", "abort")]

    def compose(self) -> ComposeResult:
        yield RunHeader()
        with Horizontal(id="step-row"):
            yield Static(id="step")
            yield ProgressBar(total=max(1, self.session.info.total_steps), show_eta=False, id="progress")
        yield Static(id="instruction", classes="instruction")
        with Container(id="capture-body"):
            with Vertical(id="readings"):
                with Horizontal(id="live-row"):
                    with Vertical(id="live-box"):
                        yield Digits("", id="live")
                        yield Static(id="live-caption")
                    yield Static(id="live-status")
                yield Static(id="last")
            yield Plot(id="plot")
        yield Static(id="log", classes="log")
        yield Footer()

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "auto":  # a positioning run captures by itself unless its trigger is manual
            setup = self.session.info.setup
            return setup is not None and (self.session.info.kind == "straightness" or setup.trigger.mode == "manual")
        return super().check_action(action, parameters)

    def instruction_text(self) -> str:
        text = super().instruction_text()
        v, q = self.session.view, self.instruction
        if q is None or q.action != "cycle_start" or q.key != "target" or not self.session.operator.can_act(q):
            return text
        if v.capture_when_stable == v.ticket:
            return (f"{escape(q.text)}\n[b]Cycle Start pressed[/b] (simulated): the capture follows when the light "
                    f"is STABLE   [b]Space[/b] capture now   [b]s[/b] skip   [b]a[/b] abort")
        return (f"{escape(q.text)}\n[b]Space[/b] Cycle Start (simulated; the capture follows when the light is "
                f"STABLE)   [b]s[/b] skip   [b]p[/b] pause   [b]a[/b] abort")

    def action_auto(self) -> None:
        on = self.session.toggle_auto_capture()
        self.notify(f"auto-capture {'on: captures when the light is STABLE' if on else 'off'}")
        self.refresh_view()

    def on_resize(self) -> None:
        w, h = self.size
        wide = w >= WIDE[0] and h >= WIDE[1]
        if wide != self.has_class("wide"):
            self.set_class(wide, "wide")
            self.refresh_view()

    def points_done(self) -> int:
        return self.session.info.points_before + self.session.view.points

    def step_text(self) -> str:
        info, v = self.session.info, self.session.view
        done = info.points_before + v.points
        if info.kind == "straightness":
            points = f"points {done} of {info.total_steps}"
            if v.step is None:
                return points
            pass_, k = v.step
            where = "return pass" if pass_ else "forward pass"
            # stations are numbered from 0 (the datum): station k is the (k+1)-th of N
            return f"Station [b]{k}[/b] (x = {k * info.step_mm:g} mm) · {k + 1} of {info.stations} stations · {where}"
        stop = self.session.current_stop()
        if stop is None:
            return f"points {done} of {info.total_steps}"
        arrow = "up (+)" if stop.direction > 0 else "down (-)"
        return f"Target [b]{stop.target_index}[/b] of {info.targets} · run {stop.run} of {info.runs} · {arrow}"

    def last_text(self) -> str:
        v = self.session.view
        row = v.last_point
        if row is None:
            return f"last point: [dim]none yet   points {self.points_done()} of {self.session.info.total_steps}[/dim]"
        if "station" in row:
            h = self.session.view.heights.get((int(row.get("pass", 0)), int(row["station"])))
            height = f"  height {h:+.3f} um" if h is not None else ""
            return (f"last point: station {row['station']}{' (return)' if row.get('pass') else ''}  "
                    f"x {row['x_mm']:g} mm{height}   [dim]points {self.points_done()} of "
                    f"{self.session.info.total_steps}[/dim]")
        unit = "deg" if "target_deg" in row else "mm"
        dev_unit = "arcsec" if unit == "deg" else "um"
        live = v.deviations.get((int(row["run"]), int(row["direction"]), int(row["target_index"])))
        dev = f"{live[1]:+.2f} {dev_unit} ({short_label(v.deviation_label)})" if live is not None else "-"
        arrow = "up" if row["direction"] > 0 else "down"
        return (f"last point: target {row['target_index']} ({row[f'target_{unit}']:g} {unit}) run {row['run']} "
                f"{arrow}  deviation {dev}")

    def plot_data(self) -> PlotData:
        v, info = self.session.view, self.session.info
        if info.kind == "straightness":
            fwd = [(k * info.step_mm, h) for (p, k), h in v.heights.items() if p == 0]
            ret = [(k * info.step_mm, h) for (p, k), h in v.heights.items() if p == 1]
            series = [Series(fwd, "cyan", "forward", join=True)]
            if ret:
                series.append(Series(ret, "magenta", "return", join=True))
            return PlotData(series, x_label="x (mm) · surface height (um), forward cyan, return magenta", y_label="um")
        up = [t_d for (_r, d, _i), t_d in v.deviations.items() if d > 0]
        down = [t_d for (_r, d, _i), t_d in v.deviations.items() if d < 0]
        unit = "arcsec" if info.unit == "deg" else "um"
        what = f", {short_label(v.deviation_label)}" if v.deviation_label else ""
        return PlotData([Series(up, "green", "up"), Series(down, "yellow", "down")],
                        x_label=f"target ({info.unit}) · {unit}{what} · ↑ green ↓ yellow", y_label=unit)

    def live_value(self) -> tuple[str, str]:
        """The big number and its caption."""
        v, info = self.session.view, self.session.info
        value = v.live_value
        if info.kind == "straightness":
            text = f"{value:+.2f}" if math.isfinite(value) else "-.--"
            if v.step is not None and not math.isfinite(value) and math.isfinite(v.offset):
                return text, f"um · not at {self.session.where()}"
            return text, f"height um · {self.session.where()}"
        unit = "arcsec" if info.rotary else "um"
        stop = self.session.current_stop()
        if not math.isfinite(value) and math.isfinite(v.offset) and stop is not None:
            return "-.--", f"{unit} · not at target {stop.target_index}"
        text = f"{value:+.2f}" if math.isfinite(value) else "-.--"
        return text, f"deviation {unit}, {short_label(v.live_label) or 'live'}"

    def status_text(self) -> str:
        """Beside the big number: stability light and auto-capture, the distance to the target, the sensor in
        its range, beam and signal, the raw reading."""
        v, info = self.session.view, self.session.info
        r = v.reading
        setup = info.setup
        lines = []
        rule = self.session.live().stability.rule if setup is not None else None
        auto = "auto-capture [b]ON[/b]" if v.auto_capture else "auto-capture off"
        if info.kind == "positioning" and setup is not None and setup.trigger.mode != "manual":
            auto = f"capture: {setup.trigger.mode} trigger"
        else:
            auto += " [dim](t)[/dim]"
        lines.append(f"{LIGHT.get(v.stability, v.stability)}  {auto}")
        if info.kind == "straightness":
            x = f"{r.interferometer.position_mm:.4f} mm" if r is not None and r.interferometer is not None else "-"
            lines.append(f"x {x} · {distance_text(v.offset, rule.near if rule else math.inf)}")
            lo, hi = info.sensor_range_mm
            sensor = r.sensor_mm if r is not None else math.nan
            value = f"{sensor:+.5f} mm" if math.isfinite(sensor) else "no value"
            lines.append(f"sensor {value} {range_bar(sensor, lo, hi, 12)} [{lo:g}, {hi:g}]")
        else:
            stop = self.session.current_stop()
            axis = info.axis_reading(r)
            digits = 5 if info.rotary else 4
            if stop is not None:
                dist = f" · axis {v.offset:+.{digits}f} {info.unit} from it" if math.isfinite(v.offset) else ""
                lines.append(f"target {stop.position:g} {info.unit}{dist}")
            raw = f"{axis:+.{digits}f} {info.unit}" if math.isfinite(axis) else "-"
            what = "angle" if info.rotary else "interferometer"
            lines.append(f"[dim]raw {raw} = datum {info.datum:g} + {what}[/dim]")
        lines.append(beam_text(r, info.kind == "straightness"))
        if r is not None and r.problem:
            lines.append(f"[red]{escape(r.problem)}[/red]")
        if rule is not None and self.has_class("wide"):
            lines.append(f"[dim]stable = {escape(rule.text())}[/dim]")
        return "\n".join(lines)

    def refresh_view(self) -> None:
        v, info = self.session.view, self.session.info
        self.query_one("#step", Static).update(self.step_text())
        self.query_one("#progress", ProgressBar).update(progress=info.points_before + v.points + v.skipped)
        instruction = self.instruction_text()
        if v.refused:
            instruction += f"\n[b yellow]{escape(v.refused)}[/b yellow]"
        self.query_one("#instruction", Static).update(instruction)
        value, caption = self.live_value()
        self.query_one("#live", Digits).update(value)
        self.query_one("#live-caption", Static).update(caption)
        self.query_one("#live-status", Static).update(self.status_text())
        self.query_one("#last", Static).update(self.last_text())
        self.query_one("#plot", Plot).show(self.plot_data())
        self.query_one("#log", Static).update(self.log_text(2))
