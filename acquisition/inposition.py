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
    """Wait until the PLC reports the axis in position at a target with a counter other than
    ``last_count``; reply :class:`InPositionEvent`, or None after ``timeout_s`` (or when the
    program has finished, or an abort was requested)."""

    last_count: int
    timeout_s: float
    poll_s: float = 0.002


@dataclass(frozen=True)
class InPositionEvent:
    count: int
    target_index: int
    run: int
    direction: int
    cycle_done: bool = False


@dataclass(frozen=True)
class AcknowledgeInPosition:
    """Tell the PLC the point of in-position event ``count`` is captured (it moves on)."""

    count: int


@dataclass(frozen=True)
class ReadAngle:
    """The rotary angle captured with the last trigger (deg, relative to the datum)."""


def _read_inpos(engine: RunEngine) -> InPositionEvent | None:
    ctl: Any = engine.rig.controller
    start, count = ctl.map.span("inpos_status", "inpos_count")
    status, target, run, direction, n = ctl.read_registers(start, count)
    d = int(decode_value([direction], "INT16"))
    if status & IN_POSITION:
        return InPositionEvent(n, target, run, d)
    if status & DONE:
        return InPositionEvent(n, 0, 0, 0, cycle_done=True)
    return None


def wait_in_position(engine: RunEngine, msg: WaitInPosition) -> InPositionEvent | None:
    deadline = time.monotonic() + msg.timeout_s
    while not engine.abort_requested:
        ev = _read_inpos(engine)
        if ev is not None and (ev.cycle_done or ev.count != msg.last_count):
            return ev
        if time.monotonic() > deadline:
            return None
        with engine.idle():  # a live reader may use the controller between polls
            time.sleep(msg.poll_s)
    return None


def acknowledge(engine: RunEngine, msg: AcknowledgeInPosition) -> None:
    ctl: Any = engine.rig.controller
    address = ctl.map["inpos_ack"].address
    ctl.write_register(address, msg.count & 0xFFFF, what="acknowledge in-position")


def read_angle(engine: RunEngine, _msg: ReadAngle) -> float:
    ctl: Any = engine.rig.controller
    reg = ctl.map["angle_deg"]
    return decode_value(ctl.read_registers(reg.address, reg.count), reg.type, ctl.word_order)


EXTRA_HANDLERS.update({WaitInPosition: wait_in_position, AcknowledgeInPosition: acknowledge, ReadAngle: read_angle})
EXTRA_DEVICE_MESSAGES.update({WaitInPosition, AcknowledgeInPosition, ReadAngle})
