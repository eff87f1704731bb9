"""The simulated controller side of the live-compensation interface (docs/compensation.md, "Live
compensation interface"), written from that page and never importing ``drivers``: pymodbus's own
server (SimDevice/SimData) with registers 0-16, and the controller's rules:

* the applied offset is register 12 (FLOAT32, um or arcsec) while enable (8) = 1, the heartbeat (9)
  is fresh and the axis is referenced, else 0;
* stale heartbeat: register 9 unchanged for ``timeout_ms`` → offset dropped to 0, status b1 set,
  latched until enable is written 1 again;
* the controller publishes the commanded position (without the offset) and the direction of the
  commanded motion (kept at rest, 0 before the first motion) with a sample counter (3); the
  compensator echoes the sample it answered (10), which gives the lag of the offset behind the motion.

:class:`LiveOffsetController` is also the compensation stage of the simulated machine axis
(``MachineAxis.compensator``): :meth:`move_to` publishes the new command, waits for the
compensator's answer to it and returns the offset (mm or deg) the controller adds to the command.
"""

from __future__ import annotations

import collections
import struct
import threading
import time
from collections.abc import Callable

from pymodbus.constants import ExcCodes
from pymodbus.simulator import DataType, SimData, SimDevice

from .faults import FaultPlan
from .modbus_server import ModbusServerThread

# registers (docs/compensation.md), holding, 0-based
VERSION, STATUS, DIRECTION, SAMPLE, POSITION = 0, 1, 2, 3, 4
ENABLE, HEARTBEAT, ECHO, COUNTS, OFFSET, APPLIED, TIMEOUT = 8, 9, 10, 11, 12, 14, 16
SIZE = 17
WRITABLE = range(ENABLE, APPLIED)  # 8-13: what the compensator (or an operator: 8) may write
APPLIED_BIT, STALE_BIT, REFERENCED_BIT = 1, 2, 4


def _words(fmt: str, value: float, word_order: str) -> list[int]:
    raw = struct.pack(fmt, value)
    words = [int.from_bytes(raw[i:i + 2], "big") for i in range(0, len(raw), 2)]
    return words[::-1] if word_order == "CDAB" else words


def _float32(words: list[int], word_order: str) -> float:
    ordered = words[::-1] if word_order == "CDAB" else words
    return float(struct.unpack(">f", b"".join(w.to_bytes(2, "big") for w in ordered))[0])


class LiveOffsetController:
    """Register-level behaviour of a controller with a live external offset."""

    def __init__(self, *, rotary: bool, start: float = 0.0, timeout_ms: int = 500, word_order: str = "ABCD",
                 settle_s: float = 1.0, clock: Callable[[], float] = time.monotonic,
                 faults: FaultPlan | None = None) -> None:
        if word_order not in ("ABCD", "CDAB"):
            raise ValueError(f"word order must be ABCD or CDAB, not {word_order!r}")
        self.rotary = rotary
        self.word_order = word_order
        self.timeout_s = timeout_ms / 1000.0
        self.settle_s = settle_s
        self._clock = clock
        self._cond = threading.Condition()
        self.position = start
        self.direction = 0
        self.sample = 0
        self.referenced = True
        self._regs = [0] * SIZE
        self._regs[TIMEOUT] = timeout_ms
        self._hb_at = clock()
        self._stale = False
        self._published: dict[int, float] = {}  # sample -> time it was published
        self.lags_s: collections.deque[float] = collections.deque(maxlen=100_000)  # publish -> echo written
        self.writes = 0
        self._steady = False  # the last two answers were to the same sample with the same offset
        self.faults = faults  # ``live:close@N`` entries (mocks/faults.py): the N-th request closes the link
        self.close_link: Callable[[], None] = lambda: None  # set by start_live_controller: its wire fault

    # -- the controller's rules ------------------------------------------------------------------
    @property
    def enabled(self) -> bool:
        return self._regs[ENABLE] == 1

    def _check_stale(self) -> None:
        if self.enabled and not self._stale and self._clock() - self._hb_at > self.timeout_s:
            self._stale = True

    def applied(self) -> float:
        """The offset applied now (um or arcsec)."""
        with self._cond:
            self._check_stale()
            if not (self.enabled and self.referenced) or self._stale:
                return 0.0
            return _float32(self._regs[OFFSET:OFFSET + 2], self.word_order)

    @property
    def stale(self) -> bool:
        with self._cond:
            self._check_stale()
            return self._stale

    def publish(self, position: float) -> int:
        """The controller's new commanded position (mm or deg, without the offset): direction from the
        motion (kept at rest), a new sample; returns its counter."""
        with self._cond:
            if position != self.position:
                self.direction = 1 if position > self.position else -1
            self.position = position
            self.sample = (self.sample + 1) & 0xFFFF
            self._published[self.sample] = self._clock()
            if len(self._published) > 1000:
                self._published.pop(next(iter(self._published)))
            return self.sample

    def move_to(self, commanded: float) -> float:
        """Compensation stage of the simulated axis: publish ``commanded``, wait (at most ``settle_s``)
        until the compensator answered this sample with a settled offset (two answers alike: a jump
        limit may ramp it over several cycles, as it would while a real axis travels), return the offset
        added to the command (mm or deg)."""
        sample = self.publish(commanded)
        deadline = self._clock() + self.settle_s
        with self._cond:
            self._steady = False
            while not (self._regs[ECHO] == sample and self._steady) and not self._stale:
                left = deadline - self._clock()
                if left <= 0:
                    break
                self._cond.wait(min(left, 0.05))
                self._check_stale()
        return self.applied() / (3600.0 if self.rotary else 1000.0)

    def _write(self, address: int, values: list[int]) -> None:
        now = self._clock()
        with self._cond:
            before = (self._regs[ECHO], self._regs[OFFSET], self._regs[OFFSET + 1])
            for i, v in enumerate(values):
                reg = address + i
                if reg == HEARTBEAT and v != self._regs[HEARTBEAT]:
                    self._hb_at = now
                if reg == ENABLE and v == 1:  # (re-)enabling clears a stale latch and restarts the watch
                    self._stale = False
                    self._hb_at = now
                self._regs[reg] = int(v)
            if address <= ECHO < address + len(values):
                self._steady = before == (self._regs[ECHO], self._regs[OFFSET], self._regs[OFFSET + 1])
                self.writes += 1
                t = self._published.pop(self._regs[ECHO], None)
                if t is not None:
                    self.lags_s.append(now - t)
            self._cond.notify_all()

    def registers(self) -> list[int]:
        """All 17 registers as a client reads them now."""
        applied = self.applied()
        with self._cond:
            regs = list(self._regs)
            regs[VERSION] = 1
            regs[STATUS] = (APPLIED_BIT if self.enabled and not self._stale and self.referenced else 0) | (
                STALE_BIT if self._stale else 0) | (REFERENCED_BIT if self.referenced else 0)
            regs[DIRECTION] = self.direction & 0xFFFF
            regs[SAMPLE] = self.sample
            regs[POSITION:POSITION + 4] = _words(">d", self.position, self.word_order)
            regs[APPLIED:APPLIED + 2] = _words(">f", applied, self.word_order)
        return regs

    # -- pymodbus ------------------------------------------------------------------------------
    def device(self, device_id: int = 1) -> SimDevice:
        return SimDevice(id=device_id, simdata=[SimData(0, count=SIZE, values=0, datatype=DataType.REGISTERS)],
                         action=self.action)

    async def action(self, function_code: int, start_address: int, address: int, count: int,
                     current_registers: list[int], set_values: list[int] | list[bool] | None) -> ExcCodes | None:
        """pymodbus SimDevice hook, before each access is served: writes only to 8-13."""
        _ = function_code
        fault = self.faults.next_request("live") if self.faults is not None else None
        if fault is not None and fault.kind == "close":
            self.close_link()  # this request is not answered: the connection closes instead
            return None
        if set_values is not None:
            if address < WRITABLE.start or address + len(set_values) > WRITABLE.stop:
                return ExcCodes.ILLEGAL_ADDRESS  # the controller's registers are read-only
            self._write(address, [int(v) for v in set_values])
        regs = self.registers()
        current_registers[:] = regs[start_address:start_address + len(current_registers)]
        if set_values is not None:  # pymodbus stores the written values after this hook
            set_values[:] = regs[address:address + len(set_values)]
        return None


def start_live_controller(controller: LiveOffsetController, *, device_id: int = 1, port: int = 0
                          ) -> ModbusServerThread:
    """Serve ``controller`` over Modbus TCP on 127.0.0.1 (``port`` 0 = ephemeral); ``.url``, ``.stop()``."""
    server = ModbusServerThread(controller.device(device_id), port=port)
    controller.close_link = lambda: server.wire_faults.arm("close")
    return server
