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
from textual.containers import Horizontal
from textual.markup import escape
from textual.screen import Screen
from textual.widgets import Digits, Footer, Header, ProgressBar, Sparkline, Static

from acquisition.messages import Instruct

from ..session import RunSession
from ..widgets.plot import Plot, PlotData, Series
from ..widgets.readout import bar, controller_state, readout_text, sensor_line

STATE_TEXT = {
    "connecting": "[b yellow]CONNECTING[/b yellow] — opening the devices",
    "connected": "[b green]CONNECTED[/b green] — the devices answer; follow the instruction",
    "drifting": "[b yellow]DRIFTING[/b yellow] — waiting for the drift to settle",
    "stable": "[b green]STABLE[/b green] — warm-up done, setting the datum",
    "overridden": "[b magenta]OVERRIDDEN[/b magenta] — warm-up overridden by the operator (recorded in the run)",
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

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "choose":
            return parameters[0] in self.offered
        return True

    def sync_bindings(self) -> None:
        """Refresh the footer when the pending instruction offers other choices (called with every view
        refresh; cheap when nothing changed)."""
        q = self.instruction
        if q is not None and q.choices != self.offered:
            self.offered = q.choices
            self.refresh_bindings()

    @property
    def instruction(self) -> Instruct | None:
        q = self.session.view.question
        return q if isinstance(q, Instruct) else None

    def choose(self, choice: str) -> None:
        q = self.instruction
        if q is not None and choice in q.choices:
            self.session.answer(choice)
            self.refresh_view()

    def action_confirm(self) -> None:
        q = self.instruction
        if q is not None:
            self.choose(q.choices[0])

    def action_choose(self, choice: str) -> None:
        self.choose(choice)

    def action_pause(self) -> None:
        self.session.pause()
        self.notify("pause requested: the run pauses at its next step")

    def action_abort(self) -> None:
        def answered(yes: bool | None) -> None:
            if yes:
                self.session.abort()

        self.app.push_screen(ConfirmAbort(), answered)

    def instruction_text(self) -> str:
        q = self.instruction
        if q is None:
            return "[dim]working...[/dim]" if self.session.view.state != "paused" else "[yellow]paused[/yellow]"
        keys = {"capture": "Space", "done": "Space", "started": "Space", "redo": "r", "skip": "s", "pause": "p",
                "abort": "a"}
        choices = "   ".join(f"[b]{escape(keys.get(c, c))}[/b] {escape(c)}" for c in q.choices)
        return f"{escape(q.text)}\n{choices}"

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
        yield Header()
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
        if self.session.info.warmup:
            self.session.override()
            self.notify("warm-up override requested (recorded in the run)")

    def state_key(self) -> str:
        v = self.session.view
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
        self.query_one("#instruction", Static).update(self.instruction_text())
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


class CaptureScreen(RunScreen):
    """Capture: station k of N (or the target, run and direction), the instruction, a large live value,
    the last point, progress and the live profile (positioning: deviations)."""

    SCREEN_NAME = "Capture"
    SUB_TITLE = SCREEN_NAME
    BINDINGS = [Binding("space,enter", "confirm", "capture / done", key_display="Space"),
                Binding("r", "choose('redo')", "redo"), Binding("s", "choose('skip')", "skip"),
                Binding("p", "pause", "pause"), Binding("a", "abort", "abort")]

    def compose(self) -> ComposeResult:
        yield Header()
        with Horizontal(id="step-row"):
            yield Static(id="step")
            yield ProgressBar(total=max(1, self.session.info.total_steps), show_eta=False, id="progress")
        yield Static(id="instruction", classes="instruction")
        with Horizontal(id="live-row"):
            yield Digits("", id="live")
            yield Static(id="live-status")
        yield Static(id="last")
        yield Plot(id="plot")
        yield Static(id="log", classes="log")
        yield Footer()

    def step_text(self) -> str:
        info, v = self.session.info, self.session.view
        q = self.instruction
        p = q.params if q is not None else {}
        if info.kind == "straightness":
            if "station" in p:
                where = "return pass" if p.get("pass") else "forward pass"
                return f"Station [b]{p['station']}[/b] of {info.stations - 1} · {where}"
            return f"{info.points_before + v.points} of {info.total_steps} points"
        if "target_index" in p:
            arrow = "up (+)" if p.get("direction", 1) > 0 else "down (-)"
            return f"Target [b]{p['target_index']}[/b] · run {p.get('run')} · {arrow}"
        return f"{info.points_before + v.points} of {info.total_steps} points"

    def last_text(self) -> str:
        v = self.session.view
        row = v.last_point
        if row is None:
            return "last point: [dim]none yet[/dim]"
        if "station" in row:
            h = self.session.view.heights.get((int(row.get("pass", 0)), int(row["station"])))
            height = f"  height {h:+.3f} um" if h is not None else ""
            return (f"last point: station {row['station']}{' (return)' if row.get('pass') else ''}  "
                    f"x {row['x_mm']:g} mm  stry {row['stry_um']:+.3f} um  sensor {row['sensor_mm']:+.5f} mm"
                    f"{height}")
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

    def refresh_view(self) -> None:
        v, info = self.session.view, self.session.info
        self.query_one("#step", Static).update(self.step_text())
        self.query_one("#progress", ProgressBar).update(progress=info.points_before + v.points + v.skipped)
        self.query_one("#instruction", Static).update(self.instruction_text())
        r = v.reading
        if info.kind == "straightness":
            value = f"{r.sensor_mm:+.4f}" if r is not None and math.isfinite(r.sensor_mm) else "-.----"
            status = sensor_line(r).replace("sensor: ", "sensor mm\n", 1)
        else:  # where the axis is, in the frame of the targets (the reading the plan records)
            axis = info.axis_reading(r)
            digits = 5 if info.rotary else 4  # 0.04 arcsec, 0.1 um
            value = f"{axis:+.{digits}f}" if math.isfinite(axis) else "-." + "-" * digits
            what = "angle" if info.rotary else "interferometer"
            status = (f"axis {'angle' if info.rotary else 'position'} {info.unit} (datum {info.datum:g} + {what})\n"
                      + controller_state(r))
        self.query_one("#live", Digits).update(value)
        problem = f"\n[red]{escape(r.problem)}[/red]" if r is not None and r.problem else ""
        self.query_one("#live-status", Static).update(status + problem)
        self.query_one("#last", Static).update(self.last_text())
        self.query_one("#plot", Plot).show(self.plot_data())
        self.query_one("#log", Static).update(self.log_text(2))
