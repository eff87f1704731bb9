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
import io
import math
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from acquisition.acquire import SimOptions, acquire
from acquisition.engine import RunEngine
from acquisition.messages import Instruct, Prompt
from acquisition.monitor import LiveMonitor, LiveReading
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

    @property
    def rotary(self) -> bool:
        return self.kind == "positioning" and self.unit == "deg"

    def axis_reading(self, reading: LiveReading | None) -> float:
        """Positioning: where the axis is by a live reading, as the plan records a capture (``reading_mm`` /
        ``reading_deg``: the datum plus the interferometer position, or plus the rotary angle); NaN without one."""
        ifm = reading.interferometer if reading is not None else None
        if ifm is None:
            return math.nan
        return self.datum + (reading.angle_deg if self.rotary else ifm.position_mm)


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
        self.operator.answer(self.view.ticket, choice)

    def pause(self) -> None:
        if self.view.question is not None and "pause" in self.view.question.choices:
            self.answer("pause")
        elif self.engine is not None:
            self.engine.request_pause()

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
        elif isinstance(message, OperatorQuestion):
            v.question, v.ticket = message.question, message.ticket
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
                v.state = doc["state"]
        elif name == "progress" and doc.get("key") == "warmup":
            v.warmup = dict(doc["data"])
        elif name == "event":
            v.points += 1
            v.rows.append(doc["data"])
        elif name == "retract":
            v.points -= 1
            m = doc["match"]
            v.rows = [r for r in v.rows if any(r.get(k) != value for k, value in m.items())]
            v.heights.pop((int(m.get("pass", 0)), int(m["station"])), None)
        elif name == "annotate" and doc.get("key") == "skipped":
            v.skipped = len(doc["value"])
