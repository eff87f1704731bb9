"""The run engine: executes a plan's messages with an explicit state machine.

States and the transitions allowed between them::

    idle -> running
    running -> paused | stopping | aborting | failed
    paused -> running | stopping | aborting | failed
    stopping | aborting | failed -> idle

*stop* is the normal end (exit status ``success``), *abort* the operator
ending early (``abort``, data kept), *fail* a fault that could not be
recovered (``fail``).  Cleanup (closing the plan, the stop document) always
runs.  Records go to subscribers as ``(name, document)`` pairs: ``start``,
``event`` (one per record) and ``stop``.
"""

from __future__ import annotations

import enum
import threading
import time
import uuid
from collections.abc import Callable, Generator
from dataclasses import dataclass
from typing import Any

from drivers.errors import DriverError, with_context

from .errors import UserError
from .messages import (
    CloseRun,
    Instruct,
    Log,
    Message,
    OpenRun,
    Prompt,
    ReadSensor,
    Record,
    TriggerInterferometer,
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


@dataclass(frozen=True)
class RunOutcome:
    """How a run ended."""

    exit_status: str  # "success" | "abort" | "fail"
    reason: str
    num_events: int
    uid: str


class RunEngine:
    """Runs plans against a :class:`~acquisition.rig.Rig` with an injected operator."""

    def __init__(self, rig: Rig, operator: Operator, subscribers: tuple[Subscriber, ...] = ()) -> None:
        self.rig = rig
        self.operator = operator
        self._subscribers: list[Subscriber] = list(subscribers)
        self.state = RunState.IDLE
        self.state_log: list[RunState] = [RunState.IDLE]
        self._abort_requested = threading.Event()
        self._num_events = 0
        self._uid = ""
        self._started = False

    # -- state machine ----------------------------------------------------------------------
    def _transition(self, new: RunState) -> None:
        if new not in TRANSITIONS[self.state]:
            raise IllegalTransition(f"{self.state.value} -> {new.value}")
        self.state = new
        self.state_log.append(new)

    def subscribe(self, subscriber: Subscriber) -> None:
        self._subscribers.append(subscriber)

    def request_abort(self) -> None:
        """Ask the running plan to end early (thread-safe); data are kept."""
        self._abort_requested.set()

    def _emit(self, name: str, doc: dict[str, Any]) -> None:
        for sub in self._subscribers:
            sub(name, doc)

    # -- execution ---------------------------------------------------------------------------
    def _open_run(self, msg: OpenRun) -> float:
        self._uid = uuid.uuid4().hex
        now = time.time()
        self._emit("start", {"uid": self._uid, "time": now, "kind": msg.kind, **msg.metadata})
        self._started = True
        return now

    def _ask(self, msg: Instruct | Prompt) -> str:
        answer = self.operator.instruct(msg) if isinstance(msg, Instruct) else self.operator.prompt(msg)
        if answer == "abort":
            raise _AbortRun("operator aborted")
        return answer

    def _read_sensor(self, msg: ReadSensor) -> Any:
        sensor = self.rig.sensor
        if sensor is None:
            raise UserError("this workflow needs a displacement sensor but the rig has none")
        try:
            return sensor.read_averaged(msg.samples)
        except DriverError as exc:
            label = f"displacement sensor ({getattr(sensor, 'protocol', '?')} on {getattr(sensor, 'endpoint', '?')})"
            raise with_context(exc, label, "; check the cable, baud rate and protocol setting") from exc

    def _record(self, msg: Record) -> None:
        self._num_events += 1
        self._emit("event", {"uid": self._uid, "seq_num": self._num_events, "time": time.time(),
                             "stream": msg.stream, "data": dict(msg.data)})

    def _close_run(self, msg: CloseRun) -> None:
        raise _CloseRun(msg.reason)

    def _handlers(self) -> dict[type, Callable[[Any], Any]]:
        return {
            OpenRun: self._open_run,
            Instruct: self._ask,
            Prompt: self._ask,
            ZeroInterferometer: lambda _m: self.rig.controller.zero(),
            TriggerInterferometer: lambda _m: self.rig.controller.trigger_and_read(),
            ReadSensor: self._read_sensor,
            Record: self._record,
            Log: self.operator.log,
            CloseRun: self._close_run,
        }

    def _execute(self, msg: Message) -> Any:
        handler = self._handlers().get(type(msg))
        if handler is not None:
            return handler(msg)
        extra = EXTRA_HANDLERS.get(type(msg))
        if extra is not None:
            return extra(self, msg)
        raise TypeError(f"unknown plan message {msg!r}")

    def run(self, plan: Plan) -> RunOutcome:
        """Execute ``plan`` to its end; return how it ended."""
        self._transition(RunState.RUNNING)
        self._abort_requested.clear()
        self._num_events = 0
        self._started = False
        reason = ""
        reply: Any = None
        end_state = RunState.STOPPING
        try:
            while True:
                if self._abort_requested.is_set():
                    raise _AbortRun("abort requested")
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
        self._transition(end_state)
        try:
            plan.close()
        finally:
            status = EXIT_STATUS[end_state]
            if self._started:
                self._emit("stop", {"uid": self._uid, "time": time.time(), "exit_status": status,
                                    "reason": reason, "num_events": self._num_events})
            self._transition(RunState.IDLE)
        return RunOutcome(status, reason, self._num_events, self._uid)
