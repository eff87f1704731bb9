"""The extension point of the controller emulator (extra registers, command
hook, per-access hook), exercised through real Modbus TCP requests."""

from __future__ import annotations

import pytest
from pymodbus.constants import ExcCodes
from pymodbus.simulator import DataType, SimData

from drivers.errors import DeviceError
from drivers.modbus_link import ModbusLink
from mocks.interferometer import InterferometerEmulator, start_controller
from mocks.world import Noise, World


class Extension:
    def __init__(self) -> None:
        self.seen: list[int] = []
        self.written: list[int] = []

    def simdata(self) -> list[SimData]:
        return [SimData(200, count=2, values=0, datatype=DataType.REGISTERS, readonly=True),
                SimData(202, values=0, datatype=DataType.REGISTERS)]

    def command(self, code: int) -> ExcCodes | bool | None:
        self.seen.append(code)
        if code == 7:
            return True
        if code == 8:
            return ExcCodes.DEVICE_BUSY
        return None

    def access(self, start: int, address: int, registers: list[int], set_values: list[int] | None) -> None:
        if set_values is not None and address == 202:
            self.written.append(int(set_values[0]))
        if start <= 200 < start + len(registers):
            registers[200 - start] = len(self.seen)


def test_extra_registers_and_hooks() -> None:
    ext = Extension()
    seen = ext.seen
    emu = InterferometerEmulator(World(noise=Noise.off()), extension=ext)
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
        link.write_register(202, 42)
        assert ext.written == [42]
    finally:
        link.close()
        server.stop()


def test_identity_answers_by_read_code_as_field_devices_do() -> None:
    # Modbus application protocol 6.21: basic objects 0-2, regular 3-6; read code 4 one object
    from pymodbus.constants import ExcCodes

    from mocks.modbus_server import DeviceIdentity

    objects = {0: "V", 1: "P", 2: "R", 4: "Name", 5: "Model"}
    category, stream, basic = (DeviceIdentity(objects, a) for a in ("category", "stream", "basic"))
    assert category.answer(1, 0) == {0: "V", 1: "P", 2: "R"} and category.answer(2, 0) == {4: "Name", 5: "Model"}
    assert stream.answer(1, 0) == {0: "V", 1: "P", 2: "R"} and stream.answer(2, 0) == objects
    assert basic.answer(1, 0) == {0: "V", 1: "P", 2: "R"} and basic.answer(2, 0) == ExcCodes.ILLEGAL_VALUE
    assert category.answer(4, 5) == {5: "Model"} and category.answer(4, 3) == ExcCodes.ILLEGAL_ADDRESS
    assert stream.answer(2, 4) == {4: "Name", 5: "Model"}  # stream access from object 4 on
