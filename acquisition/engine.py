"""The run engine: executes a plan's messages with an explicit state machine.

States and the transitions allowed between them::

    idle -> running
    running -> paused | stopping | aborting | failed
    paused -> running | stopping | aborting | failed
    stopping | aborting | failed -> idle

*stop* is the normal end (exit status ``success``), *abort* the operator
ending early (``abort``, data kept), *fail* a fault that could not be
recovered (``fail``), or a guard (``RunEngine.guards``) that stopped the run before
a capture.  Cleanup (closing the plan, the stop document) always
runs.

Pausing: the operator answers ``"pause"`` to any question, or another thread
calls :meth:`RunEngine.request_pause`; at the next message the engine enters
*paused* and asks the operator to resume or abort.  A driver error while a
device message runs also pauses the run: the operator is told what failed,
fixes it and answers ``"retry"`` (the engine reconnects the rig and repeats the
message) or ``"abort"`` (the run fails with the fault as its reason).

A controller error that stays latched (the error flag, e.g. after a beam
interruption: docs/modbus-map.md) is recovered first without asking: the
engine clears it (command 5), checks that the beam is OK again and repeats the
message, once per message; if the error cannot be cleared (the beam is still
interrupted) the run pauses as above, and ``"retry"`` clears it again.

Records go to subscribers as ``(name, document)`` pairs: ``start``, ``event``
(one per record), ``annotate`` (run metadata), ``retract`` (a point withdrawn
for a redo), ``state`` (every state change), ``progress`` (a plan's progress
report for the display) and ``stop``.

The engine holds the rig (``Rig.claim``) for the whole run except while it
waits (an operator question, a ``Wait``, the pause between in-position polls):
then a live reader (:mod:`acquisition.monitor`) may read the same devices.
"""

from __future__ import annotations

import contextlib
import enum
import threading
import time
import uuid
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass
from typing import Any

from drivers.errors import DeviceError, DriverError, with_context
from saved_runs.errors import UserError

from .messages import (
    DEVICE_MESSAGES,
    Annotate,
    CloseRun,
    Instruct,
    Log,
    Message,
    OpenRun,
    Progress,
    Prompt,
    ReadSensor,
    Record,
    Requested,
    Retract,
    Stillness,
    TriggerInterferometer,
    Wait,
    ZeroInterferometer,
)
from .operators import Operator
from .rig import Rig

Subscriber = Callable[[str, dict[str, Any]], None]
Plan = Generator[Message, Any, Any]


class RunState(enum.Enum):
    IDLE = "idle"
    RUNNING = "running"
    PAUSED = "paused"
    STOPPING = "stopping"
    ABORTING = "aborting"
    FAILED = "failed"


TRANSITIONS: dict[RunState, frozenset[RunState]] = {
    RunState.IDLE: frozenset({RunState.RUNNING}),
    RunState.RUNNING: frozenset({RunState.PAUSED, RunState.STOPPING, RunState.ABORTING, RunState.FAILED}),
    RunState.PAUSED: frozenset({RunState.RUNNING, RunState.STOPPING, RunState.ABORTING, RunState.FAILED}),
    RunState.STOPPING: frozenset({RunState.IDLE}),
    RunState.ABORTING: frozenset({RunState.IDLE}),
    RunState.FAILED: frozenset({RunState.IDLE}),
}

# Handlers for message types defined outside acquisition.messages (e.g. positioning
# workflows): ``EXTRA_HANDLERS[MsgType] = fn(engine, msg) -> reply``.
EXTRA_HANDLERS: dict[type, Callable[[RunEngine, Any], Any]] = {}
# Extra message types that talk to a device (a driver error pauses the run, see above).
EXTRA_DEVICE_MESSAGES: set[type] = set()

EXIT_STATUS = {RunState.STOPPING: "success", RunState.ABORTING: "abort", RunState.FAILED: "fail"}


class IllegalTransition(RuntimeError):
    """A state change the transition table does not allow."""


class _CloseRun(Exception):
    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class _AbortRun(Exception):
    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class _FailRun(Exception):
    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class RunOutcome:
    """How a run ended."""

    exit_status: str  # "success" | "abort" | "fail"
    reason: str
    num_events: int
    uid: str


class RunEngine:
    """Runs plans against a :class:`~acquisition.rig.Rig` with an injected operator.

    ``request_pause`` and ``request_abort`` may be called from any thread (a UI).
    """

    def __init__(self, rig: Rig, operator: Operator, subscribers: tuple[Subscriber, ...] = ()) -> None:
        self.rig = rig
        self.operator = operator
        self._subscribers: list[Subscriber] = list(subscribers)
        self.state = RunState.IDLE
        self.state_log: list[RunState] = [RunState.IDLE]
        self._abort_requested = threading.Event()
        self._pause_requested = threading.Event()
        self._wake = threading.Event()  # ends a Wait early: an abort or an operator request
        self._requests: set[str] = set()  # operator requests (request()), read by Requested messages
        self._request_lock = threading.Lock()
        self._num_events = 0
        self._uid = ""
        self._started = False
        self.faults: list[str] = []  # device faults met (and recovered or not) in the last run
        self.faults_at_open: list[str] = []  # met while the devices were opened (listed first in ``faults``)
        # checked before every capture (TriggerInterferometer; any thread may change their answer): a non-empty
        # answer ends the run as failed with it as the reason, before the capture starts (live compensation
        # lost: no point is captured uncompensated).  Not before the rest of a capture (ReadAngle, ReadSensor):
        # a point whose capture began is recorded whole
        self.guards: list[Callable[[], str]] = []
        self._handlers: dict[type, Callable[[Any], Any]] = {
            OpenRun: self._open_run,
            Instruct: self._ask,
            Prompt: self._ask,
            ZeroInterferometer: lambda _m: self.rig.controller.zero(),
            TriggerInterferometer: lambda _m: self.rig.trigger_and_read(),
            ReadSensor: self._read_sensor,
            Wait: self._wait,
            Annotate: lambda m: self._emit("annotate", {"uid": self._uid, "key": m.key, "value": m.value}),
            Retract: self._retract,
            Record: self._record,
            Log: lambda m: self.operator.log(m),
            Progress: lambda m: self._emit("progress", {"uid": self._uid, "key": m.key, "data": dict(m.data)}),
            Requested: self._requested,
            Stillness: self._stillness,
            CloseRun: self._close_run,
        }

    # -- state machine ----------------------------------------------------------------------
    def _transition(self, new: RunState, reason: str = "") -> None:
        if new not in TRANSITIONS[self.state]:
            raise IllegalTransition(f"{self.state.value} -> {new.value}")
        self.state = new
        self.state_log.append(new)
        self._emit("state", {"uid": self._uid, "state": new.value, "reason": reason})

    def subscribe(self, subscriber: Subscriber) -> None:
        self._subscribers.append(subscriber)

    def request_abort(self) -> None:
        """Ask the running plan to end early (thread-safe); data are kept."""
        self._abort_requested.set()
        self._wake.set()

    @property
    def abort_requested(self) -> bool:
        """True once an abort was requested (long-running handlers check it)."""
        return self._abort_requested.is_set()

    def request_pause(self) -> None:
        """Pause at the next message (thread-safe); the operator is then asked to resume or abort."""
        self._pause_requested.set()

    def request(self, key: str) -> None:
        """The operator asks for ``key`` (thread-safe; e.g. ``"override"`` of a warm-up): the plan's next
        ``Requested(key)`` answers True.  A ``Wait`` in progress ends early so the plan sees it soon."""
        with self._request_lock:
            self._requests.add(key)
        self._wake.set()

    def _requested(self, msg: Requested) -> bool:
        with self._request_lock:
            if msg.key in self._requests:
                self._requests.discard(msg.key)
                return True
            return False

    @contextlib.contextmanager
    def idle(self) -> Iterator[None]:
        """The engine waits: the rig is free for a live reader until the block ends (thread of the run)."""
        self.rig.release()
        try:
            yield
        finally:
            self.rig.claim()

    def _emit(self, name: str, doc: dict[str, Any]) -> None:
        for sub in self._subscribers:
            sub(name, doc)

    # -- pausing ------------------------------------------------------------------------------
    def _pause(self, reason: str) -> None:
        """Paused until the operator resumes; abort from the pause ends the run early."""
        self._pause_requested.clear()
        self._transition(RunState.PAUSED, reason)
        self.operator.log(Log(f"paused: {reason}"))
        with self.idle():
            answer = self.operator.prompt(
                Prompt(f"Run paused ({reason}). Resume the run, or abort it (data are kept)?",
                       ("resume", "abort"), key="pause"))
        if answer == "abort" or self._abort_requested.is_set():
            raise _AbortRun(f"operator aborted while paused ({reason})")
        self._transition(RunState.RUNNING, "resumed")

    def _clear_latched(self) -> str:
        """Clear a latched controller error (if any) and check the beam: "" when the controller is
        ready, else why not (the fault to report)."""
        try:
            _, problem = self.rig.clear_latched_error()
        except DriverError as exc:
            return f"clearing the controller error failed: {exc}"
        return problem

    def _recover_latched(self, exc: DriverError) -> bool:
        """A controller message failed with the controller's error flag set: clear it, check the
        beam.  True when the message can be repeated (the fault is recorded either way)."""
        if not isinstance(exc, DeviceError):
            return False
        try:
            latched, problem = self.rig.clear_latched_error()
        except DriverError:
            return False  # the controller does not answer: the ordinary fault pause handles it
        if not latched:
            return False  # not a latched error (a Modbus exception, ...)
        self._note_fault(str(exc))
        if problem:
            self._device_fault(problem, latched=True)  # returns once the operator's retry cleared it
        else:
            self.operator.log(Log(f"controller fault: {exc}; error cleared, beam OK: repeating the step"))
        return True

    def _device_fault(self, exc: Exception | str, *, latched: bool = False) -> None:
        """A device message failed: pause until the operator has fixed it and the rig reconnects
        (and, after a latched controller error, the error is cleared with the beam OK)."""
        fault = str(exc)
        self._note_fault(fault)
        self._transition(RunState.PAUSED, fault)
        while True:
            self.operator.log(Log(f"device fault: {fault}"))
            with self.idle():
                answer = self.operator.prompt(Prompt(
                    f"Device fault: {fault}. Check the device, its cable and power, then retry "
                    f"(the tool reconnects and repeats the step), or abort the run.",
                    ("retry", "abort"), key="fault", fault=fault))
            if answer == "abort" or self._abort_requested.is_set():
                raise _FailRun(fault)
            try:
                self.rig.reconnect()
            except (DriverError, UserError) as again:
                fault = f"reconnection failed: {again}"
                self._note_fault(fault)
                continue
            if latched and (problem := self._clear_latched()):
                fault = problem
                self._note_fault(fault)
                continue
            self.operator.log(Log("devices reconnected; repeating the step"))
            self._transition(RunState.RUNNING, "device fault cleared")
            return

    def _note_fault(self, fault: str) -> None:
        """Keep the fault, and put the list in the run's metadata (run.json ``faults``)."""
        self.faults.append(fault)
        if self._started:
            self._emit("annotate", {"uid": self._uid, "key": "faults", "value": list(self.faults)})

    # -- execution ---------------------------------------------------------------------------
    def _open_run(self, msg: OpenRun) -> float:
        self._uid = msg.resume_uid or uuid.uuid4().hex
        now = time.time()
        doc = {"uid": self._uid, "time": now, "kind": msg.kind, **msg.metadata}
        if msg.resume_uid:
            doc["resume"] = True
        self._emit("start", doc)
        self._started = True
        return now

    def _ask(self, msg: Instruct | Prompt) -> str:
        while True:
            with self.idle():
                answer = self.operator.instruct(msg) if isinstance(msg, Instruct) else self.operator.prompt(msg)
            if answer == "pause":
                self._pause("operator")
                continue
            if answer == "abort":
                fault = getattr(msg, "fault", "")
                if fault:
                    raise _FailRun(fault)
                raise _AbortRun("operator aborted")
            if answer not in msg.choices:
                raise UserError(f"operator answered {answer!r}; expected one of {', '.join(msg.choices)}")
            return answer

    def _stillness(self, _msg: Stillness) -> str | None:
        """The operator's judgement of stillness (``Operator.stillness``; None for one that has none)."""
        judge = getattr(self.operator, "stillness", None)
        return judge() if judge is not None else None

    def _read_sensor(self, msg: ReadSensor) -> Any:
        sensor = self.rig.sensor
        if sensor is None:
            raise UserError("this workflow needs a displacement sensor but the rig has none")
        try:
            return sensor.read_averaged(msg.samples)
        except DriverError as exc:
            label = f"displacement sensor ({getattr(sensor, 'protocol', '?')} on {getattr(sensor, 'endpoint', '?')})"
            raise with_context(exc, label, "; check the cable, baud rate and protocol setting") from exc

    def _wait(self, msg: Wait) -> float:
        t0 = time.monotonic()
        if msg.seconds > 0:
            with self.idle():
                self._wake.wait(msg.seconds)  # an abort or operator request ends the wait early
        self._wake.clear()
        return time.monotonic() - t0

    def _record(self, msg: Record) -> None:
        self._num_events += 1
        self._emit("event", {"uid": self._uid, "seq_num": self._num_events, "time": time.time(),
                             "stream": msg.stream, "data": dict(msg.data)})

    def _retract(self, msg: Retract) -> None:
        self._num_events -= 1
        self._emit("retract", {"uid": self._uid, "stream": msg.stream, "match": dict(msg.match)})

    def _close_run(self, msg: CloseRun) -> None:
        raise _CloseRun(msg.reason)

    def _execute(self, msg: Message) -> Any:
        kind = type(msg)
        handler = self._handlers.get(kind)
        extra = None if handler is not None else EXTRA_HANDLERS.get(kind)
        if handler is None and extra is None:
            raise TypeError(f"unknown plan message {msg!r}")
        if kind not in DEVICE_MESSAGES and kind not in EXTRA_DEVICE_MESSAGES:
            return handler(msg) if handler is not None else extra(self, msg)  # type: ignore[misc]
        if kind is TriggerInterferometer:
            for guard in self.guards:
                if why := guard():
                    raise _FailRun(why)
        recovered = kind is ReadSensor  # latched-error recovery: controller messages, once per message
        while True:
            try:
                return handler(msg) if handler is not None else extra(self, msg)  # type: ignore[misc]
            except DriverError as exc:
                if not recovered and self._recover_latched(exc):
                    recovered = True
                    continue
                self._device_fault(exc, latched=kind is not ReadSensor and isinstance(exc, DeviceError))

    def run(self, plan: Plan) -> RunOutcome:
        """Execute ``plan`` to its end; return how it ended."""
        self.rig.claim()
        try:
            return self._run(plan)
        finally:
            self.rig.release()

    def _run(self, plan: Plan) -> RunOutcome:
        self._transition(RunState.RUNNING)
        self._abort_requested.clear()
        self._pause_requested.clear()
        self._wake.clear()
        self._requests.clear()
        self._num_events = 0
        self._started = False
        self.faults = list(self.faults_at_open)
        reason = ""
        reply: Any = None
        end_state = RunState.STOPPING
        try:
            while True:
                if self._abort_requested.is_set():
                    raise _AbortRun("abort requested")
                if self._pause_requested.is_set():
                    self._pause("pause requested")
                try:
                    msg = plan.send(reply)
                except StopIteration:
                    break
                try:
                    reply = self._execute(msg)
                except _CloseRun as close:
                    reason = close.reason
                    break
        except _AbortRun as exc:
            end_state, reason = RunState.ABORTING, exc.reason
        except _FailRun as exc:
            end_state, reason = RunState.FAILED, exc.reason
        except (DriverError, UserError) as exc:
            end_state, reason = RunState.FAILED, str(exc)
        except KeyboardInterrupt:
            end_state, reason = RunState.ABORTING, "interrupted (Ctrl-C)"
        except Exception as exc:  # an unexpected bug: record the failure, then re-raise
            end_state, reason = RunState.FAILED, f"internal error: {exc!r}"
            self._finish(plan, end_state, reason)
            raise
        return self._finish(plan, end_state, reason)

    def _finish(self, plan: Plan, end_state: RunState, reason: str) -> RunOutcome:
        self._transition(end_state, reason)
        try:
            plan.close()
        finally:
            status = EXIT_STATUS[end_state]
            if self._started:
                self._emit("stop", {"uid": self._uid, "time": time.time(), "exit_status": status,
                                    "reason": reason, "num_events": self._num_events})
            self._transition(RunState.IDLE)
        return RunOutcome(status, reason, self._num_events, self._uid)
