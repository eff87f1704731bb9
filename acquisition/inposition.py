"""Plan messages of positioning runs that talk to the controller's in-position
handshake registers (docs/modbus-map.md, registers 200-211), and their engine
handlers (registered in ``engine.EXTRA_HANDLERS``; driver errors pause the run
like any device message).

The driver has no public call for registers outside its data block yet, so the
handlers use its register map and its register read/write (``read_registers``/``write_register``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from drivers.interferometer.codec import decode_value

from .engine import EXTRA_DEVICE_MESSAGES, EXTRA_HANDLERS, RunEngine

IN_POSITION, RUNNING, DONE = 1, 2, 4


@dataclass(frozen=True)
class WaitInPosition:
    """Wait until the PLC reports a new in-position event: *in position* (b0) with a counter other
    than ``last_count``, or b0 again after it was seen clear during the wait.  Reply
    :class:`InPositionEvent`; one with ``cycle_done`` when the program has finished, one with
    ``timed_out`` after ``timeout_s``; None when an abort was requested.

    *Cycle finished* (b2) ends the wait only once it belongs to this cycle (``armed``): after the
    tool has seen *cycle running* (b1) set or b2 clear, in this wait or an earlier one (the plan
    passes the reply's ``armed`` on), so a b2 an earlier cycle left set does not end a new run."""

    last_count: int
    timeout_s: float
    poll_s: float = 0.002
    armed: bool = False


@dataclass(frozen=True)
class InPositionEvent:
    count: int
    target_index: int
    run: int
    direction: int
    cycle_done: bool = False
    armed: bool = True  # b2 may be trusted from now on
    timed_out: bool = False


@dataclass(frozen=True)
class InPositionState:
    """Registers 200-204 as read: status bits, the event fields and the counter."""

    status: int
    target_index: int
    run: int
    direction: int
    count: int

    @property
    def in_position(self) -> bool:
        return bool(self.status & IN_POSITION)

    @property
    def running(self) -> bool:
        return bool(self.status & RUNNING)

    @property
    def done(self) -> bool:
        return bool(self.status & DONE)


@dataclass(frozen=True)
class ReadInPosition:
    """Read registers 200-204 now (reply :class:`InPositionState`): before the cycle starts, the
    bits an earlier cycle left set."""


@dataclass(frozen=True)
class AcknowledgeInPosition:
    """Tell the PLC the point of in-position event ``count`` is captured (it moves on)."""

    count: int


@dataclass(frozen=True)
class ReadAngle:
    """The rotary angle captured with the last trigger (deg, relative to the datum)."""


def read_in_position(engine: RunEngine, _msg: ReadInPosition | None = None) -> InPositionState:
    ctl: Any = engine.rig.controller
    start, count = ctl.map.span("inpos_status", "inpos_count")
    status, target, run, direction, n = ctl.read_registers(start, count)
    return InPositionState(status, target, run, int(decode_value([direction], "INT16")), n)


def wait_in_position(engine: RunEngine, msg: WaitInPosition) -> InPositionEvent | None:
    deadline = time.monotonic() + msg.timeout_s
    armed = msg.armed
    seen_clear = False  # b0 seen clear in this wait: the next b0 is a new event whatever its counter
    while not engine.abort_requested:
        st = read_in_position(engine)
        armed = armed or st.running or not st.done
        if st.in_position:
            if st.count != msg.last_count or seen_clear:
                return InPositionEvent(st.count, st.target_index, st.run, st.direction, armed=True)
        else:
            seen_clear = True
            if armed and st.done and not st.running:
                return InPositionEvent(st.count, 0, 0, 0, cycle_done=True)
        if time.monotonic() > deadline:
            return InPositionEvent(st.count, 0, 0, 0, armed=armed, timed_out=True)
        with engine.idle():  # a live reader may use the controller between polls
            time.sleep(msg.poll_s)
    return None


def acknowledge(engine: RunEngine, msg: AcknowledgeInPosition) -> None:
    ctl: Any = engine.rig.controller
    address = ctl.map["inpos_ack"].address
    ctl.write_register(address, msg.count & 0xFFFF, what="acknowledge in-position")


def read_angle(engine: RunEngine, _msg: ReadAngle) -> float:
    return engine.rig.read_angle_deg()


EXTRA_HANDLERS.update({WaitInPosition: wait_in_position, AcknowledgeInPosition: acknowledge, ReadAngle: read_angle,
                       ReadInPosition: read_in_position})
EXTRA_DEVICE_MESSAGES.update({WaitInPosition, AcknowledgeInPosition, ReadAngle, ReadInPosition})
