"""XY-MD02 temperature / humidity transmitter emulator on pymodbus's own
server (SimDevice), written from protocols.md 2.6 independently of ``drivers``.

Registers 1 (temperature x 10, signed) and 2 (RH x 10) are refreshed from
``source()`` on every read; register 0x0101 holds the device address.  One
shared register block answers function codes 3 and 4 alike (several XY-MD02
clones do), so only the addresses of the map exist; anything else answers
exception 2.
The baud-rate register (0x0102) is not emulated: its codes differ between clones.
"""

from __future__ import annotations

from collections.abc import Callable

from pymodbus.constants import ExcCodes
from pymodbus.simulator import DataType, SimData, SimDevice

from .modbus_server import ModbusServerThread
from .world import World

IR_TEMPERATURE, IR_HUMIDITY = 1, 2
HR_ADDRESS = 0x0101

TempHumiditySource = Callable[[], tuple[float, float]]


def world_source(world: World) -> TempHumiditySource:
    """Air temperature (degC) and humidity (%RH) of the simulated world."""

    def source() -> tuple[float, float]:
        air_c, _pressure, rh, _material = world.environment_now()
        return air_c, rh

    return source


class XYMD02Emulator:
    """Register behaviour of the transmitter; plug :meth:`device` into a server."""

    def __init__(self, source: TempHumiditySource, *, device_id: int = 1) -> None:
        self.source = source
        self.device_id = device_id
        self.reads = 0

    def device(self) -> SimDevice:
        return SimDevice(id=self.device_id, simdata=[
            SimData(IR_TEMPERATURE, count=2, values=0, datatype=DataType.REGISTERS, readonly=True),
            SimData(HR_ADDRESS, values=self.device_id, datatype=DataType.REGISTERS),
        ], action=self.action)

    async def action(
        self,
        function_code: int,
        start_address: int,
        address: int,
        count: int,
        current_registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> ExcCodes | None:
        """pymodbus SimDevice hook: sample the source before the measurement registers are read."""
        if set_values is None and address <= IR_HUMIDITY and address + count > IR_TEMPERATURE:
            self.reads += 1
            temp_c, rh_pct = self.source()
            current_registers[IR_TEMPERATURE - start_address] = round(temp_c * 10) & 0xFFFF
            current_registers[IR_HUMIDITY - start_address] = max(0, min(1000, round(rh_pct * 10)))
        return None


def start_xymd02(emulator: XYMD02Emulator, *, transport: str = "rtu", baudrate: int = 9600) -> ModbusServerThread:
    """Serve the transmitter over Modbus RTU (pty bridge, default) or TCP; ``.url`` is its endpoint."""
    return ModbusServerThread(emulator.device(), transport=transport, baudrate=baudrate, parity="N")
