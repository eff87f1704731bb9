"""The controller side of the live-compensation interface for LinuxCNC: a HAL user-space component that
serves registers 0-16 (docs/compensation.md, "Live compensation interface") over Modbus TCP and drives the
axis's external offset.  It is the path mb2hal cannot take (mb2hal is a Modbus master and carries 16-bit
registers only, so it cannot hand over the FLOAT64 commanded position).

    loadusr -Wn guideway-live python3 -m drivers.live_compensation.linuxcnc_component --axis C --port 1502

Pins (component ``guideway-live``): ``pos-cmd`` float in (connect ``axis.L.pos-cmd``: reported without the
applied offsets), ``homed`` bit in (``motion.is-all-homed``: external offsets are honoured after homing),
``eoffset-counts`` s32 out (to ``axis.L.eoffset-counts``, with ``axis.L.eoffset-scale`` = one count:
0.1 um = 1e-4 mm or 0.01 arcsec in deg), ``active`` bit out (the offset is applied).  The controller
rules are those of the page: the offset is applied while enable = 1, the heartbeat is fresh (changed within
``--timeout-ms``) and the axis is homed; a stale heartbeat drops it to 0, latched until enable is written 1
again.  The counts go to 0 when it is dropped, so LinuxCNC takes the offset back to 0 at the acceleration
``[AXIS_L] OFFSET_AV_RATIO`` reserves.
"""

from __future__ import annotations

import argparse
import asyncio
import math
import threading
import time
from collections.abc import Callable
from typing import Any

from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from .codec import (
    COUNT_ARCSEC,
    COUNT_UM,
    READ_COUNT,
    REG_APPLIED,
    REG_DIRECTION,
    REG_ENABLE,
    REG_HEARTBEAT,
    REG_OFFSET,
    REG_POSITION,
    REG_SAMPLE,
    REG_STATUS,
    REG_TIMEOUT_MS,
    REG_VERSION,
    ST_APPLIED,
    ST_REFERENCED,
    ST_STALE,
    VERSION,
    float32_words,
    float64_words,
    words_float32,
)


class InterfaceServerState:
    """Registers 0-16 and the controller rules, independent of HAL and of the transport."""

    def __init__(self, *, rotary: bool, timeout_ms: int = 500, word_order: str = "ABCD",
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.rotary = rotary
        self.word_order = word_order
        self.timeout_s = timeout_ms / 1000.0
        self._clock = clock
        self._lock = threading.Lock()
        self.regs = [0] * READ_COUNT
        self.regs[REG_VERSION], self.regs[REG_TIMEOUT_MS] = VERSION, timeout_ms
        self.position = math.nan
        self.direction = 0
        self.homed = False
        self._hb_at = clock()
        self._stale = False

    def update(self, position: float, homed: bool) -> None:
        """The servo side: the commanded position (mm or deg, without the offset) and whether homed."""
        with self._lock:
            self.homed = homed
            if position == self.position:
                return
            if not math.isnan(self.position):
                self.direction = 1 if position > self.position else -1
            self.position = position
            self.regs[REG_SAMPLE] = (self.regs[REG_SAMPLE] + 1) & 0xFFFF

    def write(self, address: int, values: list[int]) -> bool:
        """A client's write; False if it touches a controller register (answered with exception 2)."""
        if address < REG_ENABLE or address + len(values) > REG_APPLIED:
            return False
        now = self._clock()
        with self._lock:
            for i, v in enumerate(values):
                reg = address + i
                if reg == REG_HEARTBEAT and v != self.regs[REG_HEARTBEAT]:
                    self._hb_at = now
                if reg == REG_ENABLE and v == 1:
                    self._stale, self._hb_at = False, now
                self.regs[reg] = int(v)
        return True

    def applied(self) -> float:
        """The offset applied now (um or arcsec): 0 unless enabled, fresh and homed."""
        with self._lock:
            enabled = self.regs[REG_ENABLE] == 1
            if enabled and not self._stale and self._clock() - self._hb_at > self.timeout_s:
                self._stale = True
            if not (enabled and self.homed) or self._stale:
                return 0.0
            return words_float32(self.regs[REG_OFFSET:REG_OFFSET + 2], self.word_order)

    def counts(self) -> int:
        """``eoffset-counts``: the applied offset in counts of 0.1 um / 0.01 arcsec."""
        return round(self.applied() / (COUNT_ARCSEC if self.rotary else COUNT_UM))

    def registers(self) -> list[int]:
        applied = self.applied()
        with self._lock:
            regs = list(self.regs)
            on = regs[REG_ENABLE] == 1 and not self._stale and self.homed
            regs[REG_STATUS] = (ST_APPLIED if on else 0) | (ST_STALE if self._stale else 0) | (
                ST_REFERENCED if self.homed else 0)
            regs[REG_DIRECTION] = self.direction & 0xFFFF
            regs[REG_POSITION:REG_POSITION + 4] = float64_words(0.0 if math.isnan(self.position) else self.position,
                                                                self.word_order)
            regs[REG_APPLIED:REG_APPLIED + 2] = float32_words(applied, self.word_order)
        return regs

    def device(self, device_id: int = 1) -> SimDevice:
        async def action(function_code: int, start_address: int, address: int, count: int,
                         current: list[int], set_values: list[int] | list[bool] | None) -> ExcCodes | None:
            _ = function_code, count
            if set_values is not None and not self.write(address, [int(v) for v in set_values]):
                return ExcCodes.ILLEGAL_ADDRESS
            regs = self.registers()
            current[:] = regs[start_address:start_address + len(current)]
            if set_values is not None:
                set_values[:] = regs[address:address + len(set_values)]
            return None

        return SimDevice(id=device_id, simdata=[SimData(0, count=READ_COUNT, values=0, datatype=DataType.REGISTERS)],
                         action=action)


def serve(state: InterfaceServerState, host: str, port: int,
          device_id: int = 1) -> tuple[Any, asyncio.AbstractEventLoop]:
    """Serve ``state`` over Modbus TCP in a background thread; returns the server and its loop."""
    loop = asyncio.new_event_loop()
    ready = threading.Event()
    holder: dict[str, Any] = {}

    def run() -> None:
        asyncio.set_event_loop(loop)

        async def start() -> None:
            server = ModbusTcpServer(state.device(device_id), address=(host, port))
            await server.serve_forever(background=True)
            holder["server"] = server

        loop.run_until_complete(start())
        ready.set()
        loop.run_forever()
        pending = asyncio.all_tasks(loop)  # requests still running when the server stopped
        for task in pending:
            task.cancel()
        loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))
        loop.close()

    thread = threading.Thread(target=run, name="guideway-live-modbus", daemon=True)
    thread.start()
    if not ready.wait(10):
        raise RuntimeError("the live-compensation Modbus server did not start")
    holder["server"].thread = thread
    return holder["server"], loop


def run_component(hal: Any, args: argparse.Namespace, *, period_s: float = 0.001,
                  stop: threading.Event | None = None, on_ready: Callable[[int], None] | None = None) -> None:
    """The HAL component's loop (``hal``: LinuxCNC's module, or a stand-in in the tests); ``on_ready``
    gets the TCP port served."""
    comp = hal.component(args.name)
    comp.newpin("pos-cmd", hal.HAL_FLOAT, hal.HAL_IN)
    comp.newpin("homed", hal.HAL_BIT, hal.HAL_IN)
    comp.newpin("eoffset-counts", hal.HAL_S32, hal.HAL_OUT)
    comp.newpin("active", hal.HAL_BIT, hal.HAL_OUT)
    state = InterfaceServerState(rotary=args.axis.upper() in "ABC", timeout_ms=args.timeout_ms,
                                 word_order=args.word_order)
    server, loop = serve(state, args.host, args.port, args.device_id)
    comp.ready()
    if on_ready is not None:
        on_ready(server.transport.sockets[0].getsockname()[1])
    stop = stop or threading.Event()
    try:
        while not stop.is_set():
            state.update(float(comp["pos-cmd"]), bool(comp["homed"]))
            counts = state.counts()
            comp["eoffset-counts"] = counts
            comp["active"] = state.applied() != 0.0
            stop.wait(period_s)
    except KeyboardInterrupt:
        pass
    finally:
        comp["eoffset-counts"] = 0
        asyncio.run_coroutine_threadsafe(server.shutdown(), loop).result(timeout=5)
        loop.call_soon_threadsafe(loop.stop)
        server.thread.join(timeout=5)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="guideway-live", description=__doc__.splitlines()[0])
    p.add_argument("--axis", required=True, help="axis letter (A B C rotary: counts of 0.01 arcsec; else 0.1 um)")
    p.add_argument("--name", default="guideway-live", help="HAL component name")
    p.add_argument("--host", default="0.0.0.0", help="address to serve on (default all)")
    p.add_argument("--port", type=int, default=502)
    p.add_argument("--device-id", type=int, default=1)
    p.add_argument("--timeout-ms", type=int, default=500, help="stale-heartbeat time T (default 500)")
    p.add_argument("--word-order", choices=("ABCD", "CDAB"), default="ABCD")
    return p


if __name__ == "__main__":  # pragma: no cover - runs inside LinuxCNC
    import hal as linuxcnc_hal  # type: ignore[import-not-found]

    run_component(linuxcnc_hal, parser().parse_args())
