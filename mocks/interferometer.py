"""Interferometer controller emulator: pymodbus's own server (SimDevice/SimData)
with the register map of docs/modbus-map.md, written independently of
``drivers`` (own addresses, own float encoding with ``struct``).

Behaviour is a small state machine advanced on every Modbus access: a trigger
sets *busy*; once ``measure_time_s`` has passed (checked at the next access)
the capture is taken from the :class:`~mocks.world.World`, the data registers
are filled, the sequence counter increments and *busy* clears.  The command
register reads 0 again as soon as a command is accepted.

Extension point (for more registers, e.g. the positioning axis of
:mod:`mocks.machine_axis`): an ``extension`` object (:class:`EmulatorExtension`)
adds SimData blocks, sees every command code before the built-in ones and
fills / reacts to its registers on every access.  :func:`start_controller` serves the emulator over Modbus TCP or
RTU (pty) and returns the running server (``.url``, ``.stop()``).

Beam and errors, as on the real controller: while the beam is interrupted
(``World.beam_blocked``, or a ``beam-loss`` fault) *beam OK* is clear and
error 1 is set at once and stays latched until *clear error* (command 5); a
measurement that completes with the error set fails (no *data valid*), and a
trigger or zero is ignored while it is set.  Clearing while the beam is still
interrupted latches the error again.

Controller faults (:mod:`mocks.faults`): ``freeze-seq``, ``beam-loss``,
``exception``, ``delay``, ``slow`` act on the register level here; ``drop``,
``corrupt`` and ``close`` act on the reply frame (:class:`~mocks.modbus_server.WireFaults`).
``slow=S``: a measurement triggered while the fault is active takes S seconds
(``measure_time_s`` otherwise).

Identity (function 43/14): :func:`identity` with ``identity_access`` (see
:class:`~mocks.modbus_server.DeviceIdentity`; default ``category``: the basic read
code gives vendor, product code and revision, the regular one product and model).
"""

from __future__ import annotations

import asyncio
import struct
import time
from collections.abc import Callable
from typing import Protocol

from pymodbus import FramerType
from pymodbus.constants import ExcCodes
from pymodbus.pdu.device import ModbusDeviceIdentification
from pymodbus.simulator import DataType, SimData, SimDevice

from .faults import FaultPlan
from .modbus_server import WIRE_KINDS, DeviceIdentity, ModbusServerThread, WireFaults
from .world import World

__all__ = ["DeviceIdentity", "InterferometerEmulator", "ModbusServerThread", "float_registers", "identity",
           "start_controller"]



class EmulatorExtension(Protocol):
    """Extra registers and behaviour plugged into :class:`InterferometerEmulator`."""

    def simdata(self) -> list[SimData]:
        """The extra SimData blocks of the device."""

    def command(self, code: int) -> ExcCodes | bool | None:
        """A command code, before the built-in ones: True = handled here, an ExcCodes = answer
        that exception, None/False = not mine."""

    def access(self, start: int, address: int, registers: list[int], set_values: list[int] | None) -> None:
        """Every access, after the built-in registers are up to date: fill / react in place."""


# Register addresses (docs/modbus-map.md, version 1), holding registers, 0-based.
REG_COMMAND, REG_STATUS, REG_SEQUENCE, REG_ERROR = 0, 1, 2, 3
REG_POSITION = 100  # FLOAT64, 4 registers
REG_CHANNELS = 104  # 5 x FLOAT32: stry um, strz um, pitch urad, yaw urad, roll urad
REG_ENV = 120  # 4 x FLOAT32: air temp C, pressure hPa, humidity %RH, material temp C
DATA_END = 128

CMD_TRIGGER, CMD_ZERO, CMD_CLEAR = 1, 4, 5
SLOW_DEFAULT_S = 2.5  # a ``slow`` fault without an argument: seconds per measurement
ST_READY, ST_BUSY, ST_VALID, ST_ERROR, ST_BEAM = 1, 2, 4, 8, 16
ERR_BEAM, ERR_BUSY = 1, 5


def float_registers(value: float, fmt: str, word_order: str) -> list[int]:
    """Registers of a big-endian IEEE float (``fmt`` '>f' or '>d') in the given word order."""
    raw = struct.pack(fmt, value)
    words = [int.from_bytes(raw[i : i + 2], "big") for i in range(0, len(raw), 2)]
    if word_order == "CDAB":
        words.reverse()
    elif word_order != "ABCD":
        raise ValueError(f"unsupported word order {word_order}")
    return words


class InterferometerEmulator:
    """Register-level behaviour of the controller; plug :meth:`action` into a SimDevice."""

    def __init__(
        self,
        world: World,
        *,
        word_order: str = "ABCD",
        measure_time_s: float = 0.0,
        clock: Callable[[], float] = time.monotonic,
        faults: FaultPlan | None = None,
        extension: EmulatorExtension | None = None,
        identity_access: str = "category",
    ) -> None:
        self.world = world
        self.extension = extension
        self.faults = faults or FaultPlan()
        self.wire_faults = WireFaults()
        self.identity = DeviceIdentity.from_pymodbus(identity(), identity_access)
        self._frozen = False
        self._beam_fault = False
        self._slow_s: float | None = None
        self.word_order = word_order
        self.measure_time_s = measure_time_s
        self._clock = clock
        self.sequence = 0
        self.error_code = 0
        self.status = ST_READY | ST_BEAM
        self._pending: tuple[int, float] | None = None
        self._data = [0] * (DATA_END - REG_POSITION)

    def device(self, device_id: int = 1) -> SimDevice:
        """The SimDevice that serves this controller's registers."""
        return SimDevice(
            id=device_id,
            simdata=[
                SimData(REG_COMMAND, values=0, datatype=DataType.REGISTERS),
                SimData(REG_STATUS, count=3, values=0, datatype=DataType.REGISTERS, readonly=True),
                SimData(REG_POSITION, count=DATA_END - REG_POSITION, values=0,
                        datatype=DataType.REGISTERS, readonly=True),
                *(self.extension.simdata() if self.extension is not None else []),
            ],
            action=self.action,
        )

    # -- state machine -------------------------------------------------------------------
    def _beam_ok(self) -> bool:
        return not (self.world.beam_blocked or self._beam_fault)

    def _check_beam(self) -> None:
        """*beam OK* follows the beam; an interruption latches error 1 at once."""
        if self._beam_ok():
            self.status |= ST_BEAM
        else:
            self.error_code = ERR_BEAM
            self.status = (self.status | ST_ERROR) & ~ST_BEAM

    def _complete(self, kind: int) -> None:
        w = self.world
        self._check_beam()
        if self.status & ST_ERROR:  # the measurement failed (error latched meanwhile)
            self.status = (self.status | ST_READY) & ~(ST_BUSY | ST_VALID)
        else:
            if kind == CMD_ZERO:
                w.set_datum()
            c = w.capture()
            env = w.environment_now()
            regs = float_registers(c.position_mm, ">d", self.word_order)
            for v in (c.stry_um, c.strz_um, c.pitch_urad, c.yaw_urad, c.roll_urad):
                regs += float_registers(v, ">f", self.word_order)
            regs += [0] * (REG_ENV - REG_CHANNELS - 10)
            for v in env:
                regs += float_registers(v, ">f", self.word_order)
            self._data = regs
            self.status = ST_READY | ST_VALID | ST_BEAM
        if not self._frozen:
            self.sequence = (self.sequence + 1) & 0xFFFF

    def _advance(self) -> None:
        if self._pending is not None and self._clock() >= self._pending[1]:
            kind = self._pending[0]
            self._pending = None
            self._complete(kind)

    def _command(self, cmd: int) -> ExcCodes | None:
        if cmd == 0:
            return None
        if self.extension is not None:
            handled = self.extension.command(cmd)
            if isinstance(handled, ExcCodes):
                return handled
            if handled:
                return None
        if cmd in (CMD_TRIGGER, CMD_ZERO):
            if self._pending is not None:
                return ExcCodes.DEVICE_BUSY
            if self.status & ST_ERROR:
                return None  # the error stays latched until cleared
            self.status = (self.status | ST_BUSY) & ~ST_VALID
            took = self.measure_time_s if self._slow_s is None else self._slow_s
            self._pending = (cmd, self._clock() + took)
            self._advance()
            return None
        if cmd == CMD_CLEAR:
            self.error_code = 0
            self.status &= ~ST_ERROR
            self._check_beam()  # still interrupted: latched again
            return None
        return ExcCodes.ILLEGAL_VALUE

    def _sync(self, start: int, regs: list[int]) -> None:
        regs[REG_STATUS - start] = self.status
        regs[REG_SEQUENCE - start] = self.sequence
        regs[REG_ERROR - start] = self.error_code
        regs[REG_POSITION - start : DATA_END - start] = self._data

    async def action(
        self,
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        current_registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> ExcCodes | None:
        """pymodbus SimDevice hook: runs before each access is served."""
        fault = self.faults.next_request("controller")
        self._frozen = fault is not None and fault.kind == "freeze-seq"
        self._beam_fault = fault is not None and fault.kind == "beam-loss"
        self._slow_s = float(fault.arg or SLOW_DEFAULT_S) if fault is not None and fault.kind == "slow" else None
        self._check_beam()
        if fault is not None and fault.kind == "exception":
            return ExcCodes(int(fault.arg or 4))
        if fault is not None and fault.kind == "delay":
            await asyncio.sleep(float(fault.arg or 1.0))
        if fault is not None and fault.kind in WIRE_KINDS:
            self.wire_faults.arm(fault.kind)
        self._advance()
        result = None
        if set_values is not None and address == REG_COMMAND:
            result = self._command(int(set_values[0]))
            set_values[0] = 0  # self-clearing command register
        self._sync(start_address, current_registers)
        if self.extension is not None:
            self.extension.access(start_address, address, current_registers, set_values)
        return result


def identity() -> ModbusDeviceIdentification:
    return ModbusDeviceIdentification(
        info_name={
            "VendorName": "guideway-sim",
            "ProductCode": "SIM-6DOF",
            "MajorMinorRevision": "1.0",
            "ProductName": "Simulated 6-DOF interferometer controller",
            "ModelName": "SIM-6DOF-IFM",
        }
    )


def start_controller(
    emulator: InterferometerEmulator,
    *,
    transport: str = "tcp",
    device_id: int = 1,
    baudrate: int = 115200,
    port: int = 0,
    framer: FramerType | None = None,
) -> ModbusServerThread:
    """Serve ``emulator`` over Modbus TCP (127.0.0.1) or RTU (pty bridge) at unit id ``device_id``
    (only there) and return the running server.

    Its ``url`` is what the driver opens (``modbus-tcp://...`` or ``modbus-rtu:/dev/pts/N?...``, with
    ``device_id=`` when it is not 1).  ``framer=FramerType.RTU`` with ``transport="tcp"``: RTU frames
    over TCP (``modbus-rtu:socket://...``).
    """
    return ModbusServerThread(emulator.device(device_id), transport=transport, baudrate=baudrate, port=port,
                              framer=framer, identity=emulator.identity, wire_faults=emulator.wire_faults)
