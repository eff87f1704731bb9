"""Extension points of the controller emulator (extra registers, command and
sync hooks), exercised through a real Modbus TCP request."""

from __future__ import annotations

import pytest
from pymodbus.constants import ExcCodes
from pymodbus.simulator import DataType, SimData

from drivers.errors import DeviceError
from drivers.modbus_link import ModbusLink
from mocks.interferometer import InterferometerEmulator, start_controller
from mocks.world import Noise, World


def test_extra_registers_and_hooks() -> None:
    seen: list[int] = []

    def on_command(code: int) -> ExcCodes | bool | None:
        seen.append(code)
        if code == 7:
            return True
        if code == 8:
            return ExcCodes.DEVICE_BUSY
        return None

    def on_sync(start: int, regs: list[int]) -> None:
        regs[200 - start] = len(seen)

    emu = InterferometerEmulator(World(noise=Noise.off()), extra_simdata=[
        SimData(200, count=2, values=0, datatype=DataType.REGISTERS, readonly=True)],
        on_command=on_command, on_sync=on_sync)
    server = start_controller(emu)
    link = ModbusLink(server.url, timeout_s=0.5)
    try:
        link.write_register(0, 7)  # handled by the hook: accepted, no built-in meaning
        with pytest.raises(DeviceError) as info:
            link.write_register(0, 8)
        assert info.value.code == 6
        link.write_register(0, 1)  # not the hook's: the built-in trigger runs
        assert seen == [7, 8, 1]
        assert link.read_holding(200, 2) == [3, 0]
        assert link.read_holding(2, 1) == [1]  # sequence counter: one completed trigger
    finally:
        link.close()
        server.stop()
