"""Modbus RTU end to end: pymodbus's serial server with the RTU framer on one
end of a raw pty bridge, the driver on the other (``modbus-rtu:/dev/pts/N``);
and the URL / serial-settings / CRC pieces of drivers/modbus_link.py."""

from __future__ import annotations

import contextlib
import os
import struct
import time

import pytest

from acquisition.rig import open_rig
from acquisition.simulated.rig import start_simulated_rig
from drivers.errors import ConnectionLost
from drivers.interferometer import InterferometerController
from drivers.modbus_link import ModbusLink, SerialSettings, parse_rtu_settings, rtu_crc
from mocks.interferometer import InterferometerEmulator, start_controller
from mocks.pty_bridge import PtyBridge
from mocks.world import Noise, World
from tests.waiting import wait_for


def test_crc_matches_the_byte_examples_of_protocols_md() -> None:
    # protocols.md 2.4: the last two bytes are the CRC, low byte first.
    for frame in ("11 03 00 00 00 06 c7 58", "01 04 00 01 00 02 20 0b", "01 04 04 00 ea 01 c8 da 76",
                  "01 83 02 c0 f1"):
        raw = bytes.fromhex(frame)
        assert rtu_crc(raw[:-2]) == raw[-2] | raw[-1] << 8


def test_rtu_defaults_to_8e1_at_19200_and_takes_url_options() -> None:
    link = ModbusLink("modbus-rtu:/dev/ttyUSB0", rtu_default=SerialSettings())
    params = link.client.comm_params
    assert (params.baudrate, params.parity, params.stopbits, params.bytesize) == (19200, "E", 1, 8)
    assert link.serial is not None and link.serial.bits_per_char == 11
    link = ModbusLink("modbus-rtu:/dev/ttyUSB0?baud=115200&parity=n&stopbits=2")
    params = link.client.comm_params
    assert (params.baudrate, params.parity, params.stopbits) == (115200, "N", 2)
    assert link.serial is not None and link.serial.bits_per_char == 11  # 1 start + 8 data + 2 stop


@pytest.mark.parametrize(("query", "message"), [
    ("baud=12345", "baud 12345"), ("parity=X", "parity 'X'"), ("stopbits=3", "stopbits 3"),
    ("speed=9600", "unknown Modbus RTU option"), ("baud=fast", "must be integers"),
])
def test_bad_rtu_options_are_named(query: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        parse_rtu_settings(query, SerialSettings())


def test_missing_serial_port_is_connection_lost() -> None:
    with pytest.raises(ConnectionLost, match="cannot connect to controller"):
        InterferometerController.from_url("modbus-rtu:/dev/does-not-exist?parity=N", timeout_s=0.2)


def _read_into(fd: int, buf: bytearray) -> int:
    with contextlib.suppress(BlockingIOError):
        buf.extend(os.read(fd, 256))
    return len(buf)


def test_pty_bridge_delivers_both_ways_no_faster_than_the_line() -> None:
    bridge = PtyBridge(baudrate=9600, bits_per_char=10)
    fds = [os.open(p, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK) for p in bridge.paths]
    try:
        got = bytearray()
        request = bytes(range(96))  # 96 bytes x 10 bits at 9600 baud = 0.1 s on the wire
        t0 = time.monotonic()
        os.write(fds[0], request)
        wait_for(lambda: _read_into(fds[1], got) >= 96, timeout_s=5, what="a->b")
        assert time.monotonic() - t0 >= 0.099
        assert bytes(got) == request
        got.clear()
        os.write(fds[1], b"reply")
        wait_for(lambda: _read_into(fds[0], got) >= 5, timeout_s=5, what="b->a")
        assert bytes(got) == b"reply"
    finally:
        for fd in fds:
            os.close(fd)
        bridge.close()


@pytest.mark.parametrize("word_order", ["ABCD", "CDAB"])
def test_trigger_handshake_over_rtu(word_order: str) -> None:
    world = World(noise=Noise.off(), seed=3)
    server = start_controller(InterferometerEmulator(world, word_order=word_order, measure_time_s=0.01),
                              transport="rtu", baudrate=115200)
    assert server.url.startswith("modbus-rtu:/dev/")
    ctl = InterferometerController.from_url(server.url, word_order=word_order, timeout_s=0.5)
    try:
        world.place_block(0)
        st = ctl.zero()
        world.place_block(3)
        truth = world.capture()
        r = ctl.trigger_and_read()
        assert r.ok and r.sequence == st.sequence + 1
        assert r.position_mm == truth.position_mm
        assert r.pitch_urad == struct.unpack(">f", struct.pack(">f", truth.pitch_urad))[0]
        assert ctl.identify()["model"] == "SIM-6DOF-IFM"
    finally:
        ctl.close()
        server.stop()


def test_simulated_rig_offers_an_rtu_controller() -> None:
    sim = start_simulated_rig(seed=2, noise=False, controller="rtu")
    try:
        assert sim.controller_url.startswith("modbus-rtu:")
        rig = open_rig(sim.sensor_protocol, sim.sensor_url, sim.controller_url)
        try:
            rig.controller.zero()
            assert rig.controller.trigger_and_read().ok
        finally:
            rig.close()
    finally:
        sim.close()
