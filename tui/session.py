"""One run driven from the TUI: the engine in a worker thread, and what the screens show of it.

:class:`RunSession` starts the run through :func:`acquisition.acquire.acquire`
(the entry point of ``guideway acquire``: same plans, run store and
evaluation) with a :class:`~tui.operator.TuiOperator`, a subscriber that posts
every document to the UI, and a :class:`~acquisition.monitor.LiveMonitor` on
the run's rig for the live readings.  The UI thread applies the messages to
the session (:meth:`RunSession.apply`) and the screens draw from it; it never
waits on a device.
"""

from __future__ import annotations

import collections
import contextlib
import functools
import io
import math
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from acquisition.acquire import SimOptions, acquire
from acquisition.engine import RunEngine
from acquisition.live import LiveDeviation, LiveProfile, live_row
from acquisition.messages import Instruct, Prompt
from acquisition.monitor import LiveMonitor, LiveReading
from acquisition.stillness import STABLE, LiveStability, StabilityRule
from saved_runs.errors import EXPECTED_ERRORS

from .messages import (
    DeviationArrived,
    HeightArrived,
    LiveReadingArrived,
    LogLine,
    OperatorQuestion,
    RunDocument,
    RunEnded,
)
from .operator import TuiOperator

Post = Callable[[Any], Any]
LOG_LINES = 200


class _LogStream(io.TextIOBase):
    """What the run prints (simulated endpoints, live heights, the outcome) as log lines for the UI."""

    def __init__(self, post: Post) -> None:
        self.post = post
        self._buf = ""

    def writable(self) -> bool:
        return True

    def write(self, text: str) -> int:
        self._buf += text
        *lines, self._buf = self._buf.split("\n")
        for line in lines:
            if line.strip():
                self.post(LogLine(line))
        return len(text)


@dataclass
class RunPlanInfo:
    """What a screen needs to know of the run before its documents arrive."""

    kind: str
    total_steps: int  # straightness: (pass, station) steps; positioning: measured stops
    stations: int = 0
    unit: str = "mm"  # positioning: mm or deg
    warmup: bool = False
    step_mm: float = 0.0  # straightness: block length (x of station k = k * step_mm)
    points_before: int = 0  # resumed run: points already on disk
    datum: float = 0.0  # positioning: axis position (mm or deg) where the interferometer was zeroed
    # the validated set-up (StraightnessSetup or PositioningSetup): the live values and the stability rule
    setup: Any = None

    @property
    def rotary(self) -> bool:
        return self.kind == "positioning" and self.unit == "deg"

    @functools.cached_property
    def stops(self) -> list[Any]:
        """Positioning: the measured stops in the order of the cycle (acquisition.setup.cycles.Stop)."""
        return self.setup.measured_stops() if self.kind == "positioning" and self.setup is not None else []

    @property
    def targets(self) -> int:
        return len(self.setup.targets) if self.kind == "positioning" and self.setup is not None else 0

    @property
    def runs(self) -> int:
        return int(self.setup.runs) if self.kind == "positioning" and self.setup is not None else 0

    @property
    def sensor_range_mm(self) -> tuple[float, float]:
        """Straightness: the sensor range a capture accepts ([validation] sensor_range_mm)."""
        return tuple(self.setup.validation.sensor_range_mm) if self.setup is not None else (-50.0, 50.0)

    def axis_reading(self, reading: LiveReading | None) -> float:
        """Positioning: where the axis is by a live reading, as the plan records a capture (``reading_mm`` /
        ``reading_deg``: the datum plus the interferometer position, or plus the rotary angle); NaN without one."""
        ifm = reading.interferometer if reading is not None else None
        if ifm is None:
            return math.nan
        return self.datum + (reading.angle_deg if self.rotary else ifm.position_mm)


class _LiveValues:
    """The live estimators of one run (UI thread): the profile or the deviations as ``guideway process``
    computes them (acquisition.live), fed with the points as they arrive, and the stability light."""

    def __init__(self, info: RunPlanInfo) -> None:
        setup = info.setup
        self.profile = LiveProfile(setup.geometry) if info.kind == "straightness" else None
        self.deviation = LiveDeviation(setup.axis_type, setup.environment.to_dict()) \
            if info.kind == "positioning" else None
        self.stability = LiveStability(StabilityRule.of(setup))
        # a point could not be evaluated live: the big number then shows none rather than a wrong one
        self.broken = False

    def __call__(self, name: str, doc: dict[str, Any]) -> None:
        for sub in (self.profile, self.deviation):
            if sub is not None:
                try:
                    sub(name, doc)
                except (KeyError, ValueError, TypeError):  # a row without the channels: no live value from it
                    self.broken = True

    def height_now(self, ifm: Any, sensor_mm: float, station: int, x_mm: float, pass_: int) -> float:
        assert self.profile is not None
        if not math.isfinite(sensor_mm) or self.broken:
            return math.nan
        return self.profile.height_now(live_row(ifm, sensor_mm, station, x_mm, pass_))


@dataclass
class SessionView:
    """The state the run screens draw (changed on the UI thread only)."""

    question: Instruct | Prompt | None = None
    ticket: int = 0
    reading: LiveReading | None = None
    # the live value over time: the sensor (straightness) or the axis reading (positioning)
    live_history: collections.deque[float] = field(default_factory=lambda: collections.deque(maxlen=120))
    warmup: dict[str, Any] = field(default_factory=dict)
    heights: dict[tuple[int, int], float] = field(default_factory=dict)  # (pass, station) -> um
    # (run, direction, target index) -> (target, live deviation: um environment-compensated, or arcsec)
    deviations: dict[tuple[int, int, int], tuple[float, float]] = field(default_factory=dict)
    deviation_label: str = ""  # what the live deviations are (acquisition.live.LiveDeviation.label)
    points: int = 0  # captured in this session (a resumed run: RunPlanInfo.points_before more on disk)
    rows: list[dict[str, Any]] = field(default_factory=list)  # the points on disk, in order
    skipped: int = 0  # steps skipped without a point (run.json ``skipped``), resumed ones included
    state: str = "connecting"  # connecting, running, paused, finished, failed
    log: collections.deque[str] = field(default_factory=lambda: collections.deque(maxlen=LOG_LINES))
    started: bool = False
    # where the live values are taken against: straightness (pass, station), positioning the measured stop index
    step: tuple[int, int] | None = None
    stop_index: int = 0
    # the big number: straightness the live decoupled surface height (um), positioning the live compensated
    # deviation from the target (um, arcsec on a rotary axis); NaN without one
    live_value: float = math.nan
    live_label: str = ""
    offset: float = math.nan  # from the station (um) / to the target (mm or deg): reading - target
    stability: str = "moving"  # acquisition.stillness: moving, settling, stable
    auto_capture: bool = False
    fault_attempts: int = 0  # device-fault questions in a row (the first failure is attempt 1)
    fault_since: float | None = None  # time.monotonic() of the first of them
    refused: str = ""  # a key refused while the run was busy (shown until the next instruction)
    # simulated manual trigger: the ticket whose Cycle Start Space pressed; its capture waits for STABLE
    capture_when_stable: int = 0

    @property
    def last_point(self) -> dict[str, Any] | None:
        return self.rows[-1] if self.rows else None


def add_deviation(view: SessionView, row: dict[str, Any], deviation: float, label: str) -> None:
    """Keep a positioning point's live deviation (from acquisition.live.LiveDeviation) for the display."""
    target = float(row["target_deg"] if "target_deg" in row else row["target_mm"])
    view.deviations[(int(row["run"]), int(row["direction"]), int(row["target_index"]))] = (target, deviation)
    view.deviation_label = label


class RunSession:
    """A run of ``kind`` from a set-up TOML structure (``source``; None to resume ``out``)."""

    def __init__(self, post: Post, info: RunPlanInfo, source: dict[str, Any] | None, out: Path, *,
                 simulate: SimOptions | None, resume: bool = False, source_name: str = "set-up",
                 live_interval_s: float = 0.05) -> None:
        self.post = post
        self.info = info
        self.source = source
        self.source_name = source_name
        self.out = Path(out)
        self.simulate = simulate
        self.resume = resume
        self.live_interval_s = live_interval_s
        self.operator = TuiOperator(post)
        self.view = SessionView()
        self.engine: RunEngine | None = None
        self.monitor: LiveMonitor | None = None
        self._thread: threading.Thread | None = None
        self._live: _LiveValues | None = None

    # -- the worker -----------------------------------------------------------------------------
    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="guideway-run", daemon=True)
        self._thread.start()

    @property
    def active(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def join(self, timeout_s: float) -> bool:
        """Wait for the worker (tests, and the app on its way out); True when it has finished."""
        if self._thread is not None:
            self._thread.join(timeout_s)
        return not self.active

    def _run(self) -> None:
        kwargs: dict[str, Any] = {"operator": self.operator, "stream": _LogStream(self.post),
                                  "subscribers": (self._document,), "on_engine": self._attach}
        if self.info.kind == "straightness":
            kwargs["on_height"] = lambda p, k, h: self.post(HeightArrived(p, k, h))
        else:
            kwargs["on_deviation"] = lambda row, dev, label: self.post(DeviationArrived(dict(row), dev, label))
        try:
            result = acquire(self.info.kind, self.source, self.source_name, self.out, simulate=self.simulate,
                             resume=self.resume, **kwargs)
        except EXPECTED_ERRORS as exc:
            self.post(RunEnded(self.out, None, str(exc)))
        except Exception as exc:  # a bug: say so on the screen rather than die silently in a thread
            self.post(RunEnded(self.out, None, f"internal error: {exc!r}"))
        else:
            self.post(RunEnded(self.out, result.outcome))

    @contextlib.contextmanager
    def _attach(self, engine: RunEngine) -> Iterator[None]:
        self.engine = engine
        self.monitor = LiveMonitor(engine.rig, lambda r: self.post(LiveReadingArrived(r)),
                                   interval_s=self.live_interval_s, angle=self.info.rotary)
        with self.monitor:
            yield

    def _document(self, name: str, doc: dict[str, Any]) -> None:
        self.post(RunDocument(name, doc))

    # -- requests from the UI (UI thread; none of them waits on a device) ------------------------
    def answer(self, choice: str) -> None:
        q = self.view.question
        if q is None:
            return
        self.view.question = None
        # what the light showed as the key was pressed: the plan asks before capturing a point not still
        self.operator.light = self.view.stability if self.info.setup is not None else None
        self.operator.answer(self.view.ticket, choice)

    def cycle_start(self) -> bool:
        """Simulated manual trigger: Space is the Cycle Start the technician presses at the machine; the axis
        goes to the target, and the capture follows when the light turns STABLE there (as a technician waits
        for the axis to stop before capturing).  False when the instruction is not a simulated Cycle Start."""
        v = self.view
        q = v.question
        if not (isinstance(q, Instruct) and q.action == "cycle_start" and q.key == "target"
                and self.operator.can_act(q)) or v.capture_when_stable == v.ticket:
            return False
        if not self.operator.act(v.ticket, q):
            return False
        v.capture_when_stable = v.ticket
        if self.info.setup is not None:  # the axis has been told to move: the light starts again from MOVING
            self.live().stability.window.clear()
            v.stability = self.live().stability.state = "moving"
        v.log.append(f"Cycle Start (simulated): the axis goes to {self.where()}; capture when it is STABLE")
        return True

    def pause(self) -> None:
        if self.view.question is not None and "pause" in self.view.question.choices:
            self.answer("pause")
        elif self.engine is not None:
            self.engine.request_pause()

    def toggle_auto_capture(self) -> bool:
        """Auto-capture on/off: capture as soon as the stability light is stable (the rule of ``acquire
        --auto``, acquisition.stillness); returns the new setting."""
        self.view.auto_capture = not self.view.auto_capture
        self.view.log.append(f"auto-capture {'on' if self.view.auto_capture else 'off'}")
        self._auto_capture()
        return self.view.auto_capture

    def _auto_capture(self) -> None:
        v = self.view
        q = v.question
        armed = v.capture_when_stable == v.ticket and v.ticket > 0
        if (v.auto_capture or armed) and v.stability == STABLE and isinstance(q, Instruct) \
                and "capture" in q.choices and q.key in ("station", "target"):
            v.log.append(f"{'auto-capture' if v.auto_capture else 'capture'}: {self.where()} stable")
            self.answer("capture")

    def where(self) -> str:
        """The step the live values are taken at, in words (``station 3 (return)``, ``target 2 run 1 up``)."""
        v = self.view
        if self.info.kind == "straightness":
            if v.step is None:
                return "the datum"
            return f"station {v.step[1]}{' (return)' if v.step[0] else ''}"
        stop = self.current_stop()
        if stop is None:
            return "the end of the cycle"
        return f"target {stop.target_index} run {stop.run} {'up' if stop.direction > 0 else 'down'}"

    def current_stop(self) -> Any:
        """Positioning: the measured stop the axis goes to next (None after the last)."""
        stops = self.info.stops
        return stops[self.view.stop_index] if 0 <= self.view.stop_index < len(stops) else None

    def override(self) -> None:
        """Warm-up override (recorded in the run)."""
        if self.engine is not None:
            self.engine.request("override")

    def abort(self) -> None:
        """End the run early; its points stay on disk and it stays resumable."""
        if self.engine is not None:
            self.engine.request_abort()
        self.operator.close()
        if self.view.question is not None:
            self.answer("abort")

    # -- messages applied on the UI thread ---------------------------------------------------------
    def apply(self, message: Any) -> None:
        v = self.view
        if isinstance(message, LiveReadingArrived):
            v.reading = r = message.reading
            live = r.sensor_mean_mm if self.info.kind == "straightness" else self.info.axis_reading(r)
            if math.isfinite(live):
                v.live_history.append(live)
            self.update_live()
            self._auto_capture()
        elif isinstance(message, OperatorQuestion):
            v.question, v.ticket = message.question, message.ticket
            v.refused = ""
            q = message.question
            if isinstance(q, Prompt) and q.key == "fault":
                if v.fault_since is None:
                    v.fault_since, v.fault_attempts = time.monotonic(), 0
                v.fault_attempts += 1
            if isinstance(q, Instruct) and "station" in q.params and q.key == "station":
                v.step = (int(q.params.get("pass", 0)), int(q.params["station"]))
            self._locate_stop()
            self.update_live()
        elif isinstance(message, LogLine):
            v.log.append(message.text)
        elif isinstance(message, HeightArrived):
            v.heights[(message.pass_, message.station)] = message.height_um
        elif isinstance(message, DeviationArrived):
            add_deviation(v, message.row, message.deviation, message.label)
        elif isinstance(message, RunDocument):
            self._apply_document(message.name, message.doc)
        elif isinstance(message, RunEnded):
            v.question = None
            v.state = "failed" if message.outcome is None or message.outcome.exit_status == "fail" else "finished"

    def _apply_document(self, name: str, doc: dict[str, Any]) -> None:
        v = self.view
        if name == "start":
            v.started = True
            v.state = "running"
        elif name == "state":
            if doc["state"] in ("running", "paused"):
                if doc["state"] == "running" and v.state == "paused":
                    v.log.append(f"running again ({doc.get('reason') or 'resumed'})")
                v.state = doc["state"]
            if doc["state"] == "running":
                v.fault_since, v.fault_attempts = None, 0
        elif name == "progress" and doc.get("key") == "warmup":
            if not v.warmup and v.refused.startswith("'o'"):
                v.refused = ""  # "o before the warm-up" no longer applies once it runs
            v.warmup = dict(doc["data"])
        elif name == "event":
            live = self.live() if self.info.setup is not None else None  # (made before the row is added)
            v.points += 1
            v.rows.append(doc["data"])
            if live is not None:
                live(name, doc)
            self._locate_stop()
        elif name == "retract":
            v.points -= 1
            m = doc["match"]
            v.rows = [r for r in v.rows if any(r.get(k) != value for k, value in m.items())]
            v.heights.pop((int(m.get("pass", 0)), int(m["station"])), None)
            if self.info.setup is not None:
                self.live()(name, doc)
        elif name == "annotate" and doc.get("key") == "skipped":
            v.skipped = len(doc["value"])
            self._locate_stop()

    # -- the live values (UI thread) ------------------------------------------------------------------
    def live(self) -> _LiveValues:
        """The live estimators of this run, fed with the points on disk (a resumed run's too) on first use."""
        if self._live is None:
            self._live = _LiveValues(self.info)
            for row in self.view.rows:
                self._live("event", {"data": row})
        return self._live

    def _locate_stop(self) -> None:
        """Positioning: the measured stop the axis goes to next (the manual instruction names it; else the
        one after the points and skips so far)."""
        if self.info.kind != "positioning":
            return
        v = self.view
        q = v.question
        if isinstance(q, Instruct) and "target_index" in q.params:
            key = (int(q.params["run"]), int(q.params["direction"]), int(q.params["target_index"]))
            for i, st in enumerate(self.info.stops):
                if (st.run, st.direction, st.target_index) == key:
                    v.stop_index = i
                    return
        v.stop_index = self.info.points_before + v.points + v.skipped

    def update_live(self) -> None:
        """The big number, the distance to the target and the stability light from the newest live reading."""
        v, info = self.view, self.info
        if info.setup is None:
            return
        live = self.live()
        r = v.reading
        ifm = r.interferometer if r is not None else None
        if info.kind == "straightness":
            if v.step is None:
                live.stability.retarget(None)
                return
            pass_, k = v.step
            x_mm = k * info.step_mm
            live.stability.retarget(x_mm)
            if ifm is None:
                return
            v.offset = (ifm.position_mm - x_mm) * 1000.0
            # a height is only shown with the block at the station (|lin| within [validation] max_lin_um, the
            # check of a capture): elsewhere it would be the height of a station the block is not at
            at_station = abs(v.offset) <= live.stability.rule.near
            v.live_value = live.height_now(ifm, r.sensor_mean_mm, k, x_mm, pass_) \
                if r is not None and at_station else math.nan
            v.live_label = "surface height um (live, decoupled)"
            v.stability = live.stability.update(ifm, ifm.position_mm)
            return
        self._locate_stop()
        stop = self.current_stop()
        live.stability.retarget(None if stop is None else stop.position)
        if stop is None or ifm is None:
            return
        reading = info.axis_reading(r)
        v.offset = reading - stop.position
        v.live_value, v.live_label = live.deviation.deviation_now(ifm, reading, stop.position)
        if not abs(v.offset) <= live.stability.rule.near:  # on its way: the distance says more than a deviation
            v.live_value = math.nan
        v.stability = live.stability.update(ifm, reading)
