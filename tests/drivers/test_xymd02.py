"""XY-MD02 temperature / humidity transmitter: the byte example of
protocols.md 2.4 on a raw pty, and the pymodbus-server emulator over RTU and TCP."""

from __future__ import annotations

import pytest

from drivers.environment import XYMD02
from drivers.environment.xymd02 import decode_temp_humidity
from drivers.errors import DeviceError, ProtocolError, TransportTimeout
from drivers.readings import TempHumidityReading
from mocks.serial_endpoints import PtyEndpoint
from mocks.world import Environment, Noise, World
from mocks.xymd02 import XYMD02Emulator, start_xymd02, world_source

REQUEST = bytes.fromhex("01 04 00 01 00 02 20 0b")  # FC 04, registers 1-2, device 1
REPLY = bytes.fromhex("01 04 04 00 ea 01 c8 da 76")  # 23.4 degC, 45.6 %RH


class ScriptedTransmitter:
    """A byte-level peer that answers exactly the documented request."""

    def __init__(self, reply: bytes) -> None:
        self.reply = reply
        self.requests: list[bytes] = []

    def receive(self, data: bytes) -> bytes:
        self.requests.append(data)
        return self.reply if data == REQUEST else b""


def test_reads_the_documented_frame_on_a_pty() -> None:
    peer = ScriptedTransmitter(REPLY)
    endpoint = PtyEndpoint(peer, baudrate=9600)
    dev = XYMD02.from_url(f"modbus-rtu:{endpoint.path}", timeout_s=0.5)  # 9600 8N1 by default
    try:
        r = dev.read_once()
        assert (r.temp_c, r.humidity_pct) == (23.4, 45.6) and r.ok
        assert peer.requests == [REQUEST]
    finally:
        dev.close()
        endpoint.stop()


def test_exception_reply_is_a_device_error() -> None:
    exception_2 = bytes.fromhex("01 84 02 c2 c1")  # FC 0x04 | 0x80, code 2, CRC 0xC1C2 low byte first
    endpoint = PtyEndpoint(ScriptedTransmitter(exception_2), baudrate=9600)
    dev = XYMD02.from_url(f"modbus-rtu:{endpoint.path}", timeout_s=0.5)
    try:
        with pytest.raises(DeviceError, match="illegal data address") as info:
            dev.read_once()
        assert info.value.code == 2
    finally:
        dev.close()
        endpoint.stop()


def test_wrong_device_id_gets_no_answer() -> None:
    endpoint = PtyEndpoint(ScriptedTransmitter(REPLY), baudrate=9600)
    dev = XYMD02.from_url(f"modbus-rtu:{endpoint.path}", timeout_s=0.2, device_id=2)
    try:
        with pytest.raises(TransportTimeout):
            dev.read_once()
    finally:
        dev.close()
        endpoint.stop()


@pytest.mark.parametrize(("regs", "expected"), [
    ([0x00EA, 0x01C8], (23.4, 45.6)),
    ([0xFF85, 0x0000], (-12.3, 0.0)),  # two's complement: 0xFF85 - 0x10000 = -123
    ([0x8000, 0x03E8], (-3276.8, 100.0)),
])
def test_decode_signed_temperature(regs: list[int], expected: tuple[float, float]) -> None:
    assert decode_temp_humidity(regs) == expected


def test_decode_rejects_a_short_block() -> None:
    with pytest.raises(ProtocolError, match="two 16-bit registers"):
        decode_temp_humidity([0x00EA])


@pytest.mark.parametrize("transport", ["rtu", "tcp"])
def test_emulator_serves_the_source_values(transport: str) -> None:
    values = iter([(-12.3, 45.6), (21.05, 99.94)])
    server = start_xymd02(XYMD02Emulator(lambda: next(values)), transport=transport)
    dev = XYMD02.from_url(server.url, timeout_s=0.5)
    try:
        r = dev.read_once()
        assert (r.temp_c, r.humidity_pct) == (-12.3, 45.6)
        r = dev.read_once()
        # x10 and rounded to an integer register: 210.5 -> 210 (round half to even), 999.4 -> 999
        assert (r.temp_c, r.humidity_pct) == (21.0, 99.9)
    finally:
        dev.close()
        server.stop()


def test_emulator_follows_the_world_and_read_matches_describe() -> None:
    world = World(noise=Noise.off(), environment=Environment(air_temp_c=19.84, humidity_pct=51.26,
                                                             drift_c_per_h=0.0))
    server = start_xymd02(XYMD02Emulator(world_source(world)))
    dev = XYMD02.from_url(server.url, timeout_s=0.5)
    try:
        reading, schema = dev.read(), dev.describe()
        assert reading.keys() == schema.keys() == {"temp_c", "humidity_pct"}
        assert reading["temp_c"]["value"] == 19.8 and reading["humidity_pct"]["value"] == 51.3
        assert schema["temp_c"]["units"] == "degC" and schema["humidity_pct"]["units"] == "%RH"
    finally:
        dev.close()
        server.stop()


def test_out_of_range_reading_is_not_ok() -> None:
    assert not TempHumidityReading(23.4, 110.0, 0.0).ok
    assert not TempHumidityReading(-41.0, 50.0, 0.0).ok
    assert TempHumidityReading(-40.0, 0.0, 0.0).ok
