"""The simulated machine axis: its error model, the cycle it runs and the
in-position registers, read over Modbus TCP with a plain pymodbus client
(addresses from docs/modbus-map.md via the register map)."""

from __future__ import annotations

import math
import struct
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest
from pymodbus.client import ModbusTcpClient

from drivers.interferometer import load_register_map
from mocks import machine_axis as ma
from mocks.interferometer import InterferometerEmulator, ModbusServerThread
from tests.waiting import wait_for


def test_addresses_follow_the_map() -> None:
    regs = {r.name: r.address for r in load_register_map().registers}
    assert (ma.REG_INPOS_STATUS, ma.REG_INPOS_TARGET, ma.REG_INPOS_RUN, ma.REG_INPOS_DIRECTION,
            ma.REG_INPOS_COUNT, ma.REG_INPOS_ACK, ma.REG_ANGLE) == (
        regs["inpos_status"], regs["inpos_target"], regs["inpos_run"], regs["inpos_direction"],
        regs["inpos_count"], regs["inpos_ack"], regs["angle_deg"])


def test_error_model_terms() -> None:
    e = ma.AxisErrors(pitch=((2.0, 400.0, 0.0),), slope_per_m=10.0, backlash=4.0, periodic=0.5,
                      periodic_period=10.0, thermal_per_m_per_h=3.0, noise=0.0)
    p = 100.0
    expected_up = 10.0 * 0.1 + 2.0 * math.sin(2 * math.pi * 100 / 400) + 0.5 * math.sin(2 * math.pi * 10) - 2.0
    assert e.deviation(p, +1, 0.0) == pytest.approx(expected_up)
    assert e.deviation(p, -1, 0.0) - e.deviation(p, +1, 0.0) == pytest.approx(4.0)  # backlash
    assert e.deviation(p, +1, 2.0) - e.deviation(p, +1, 0.0) == pytest.approx(3.0 * 0.1 * 2.0)  # thermal


STOPS = [ma.MachineStop(-5.0, 0, 1, 1), ma.MachineStop(0.0, 1, 1, 1), ma.MachineStop(100.0, 2, 1, 1),
         ma.MachineStop(105.0, 0, 1, -1), ma.MachineStop(100.0, 2, 1, -1), ma.MachineStop(0.0, 1, 1, -1)]


@contextmanager
def plc(axis: ma.MachineAxis) -> Iterator[tuple[ModbusTcpClient, Callable[[], list[int]]]]:
    """``axis`` behind the emulator on Modbus TCP: a plain pymodbus client and a reader of 200-211."""
    emu = InterferometerEmulator(axis, extension=ma.InPositionRegisters(axis))  # type: ignore[arg-type]
    server = ModbusServerThread(emu.device())
    client = ModbusTcpClient("127.0.0.1", port=server.port)
    try:
        assert client.connect()
        yield client, lambda: client.read_holding_registers(200, count=12, device_id=1).registers
    finally:
        client.close()
        server.stop()


def test_handshake_over_modbus() -> None:
    axis = ma.MachineAxis(STOPS, errors=ma.AxisErrors(noise=0.0), handshake="ack")
    with plc(axis) as (client, inpos):
        assert inpos()[:5] == [0, 0, 0, 0, 0]  # program not started
        axis.cycle_start()
        r = inpos()
        assert r[:5] == [0b011, 1, 1, 1, 1]  # in position + running, target 1, run 1, +1, count 1
        client.write_register(205, 99, device_id=1)  # a wrong acknowledge changes nothing
        assert inpos()[4] == 1 and axis.index == 1
        client.write_register(205, 1, device_id=1)
        r = inpos()
        assert r[:5] == [0b011, 2, 1, 1, 2] and axis.index == 2
        client.write_register(205, 2, device_id=1)
        r = inpos()  # the overrun stop is passed without a signal: target 2 downwards
        assert r[1:5] == [2, 1, 0xFFFF, 3]  # direction -1 as INT16
        client.write_register(205, 3, device_id=1)
        client.write_register(205, 4, device_id=1)
        assert inpos()[0] == 0b100 and axis.done  # cycle finished


def test_rotary_angle_register_holds_the_capture() -> None:
    stops = [ma.MachineStop(-2.0, 0, 1, 1), ma.MachineStop(90.0, 1, 1, 1)]
    axis = ma.MachineAxis(stops, rotary=True, errors=ma.AxisErrors(pitch=(), slope_per_m=0.0, backlash=7.2,
                                                                   periodic=0.0, thermal_per_m_per_h=0.0,
                                                                   noise=0.0), handshake="ack")
    ext = ma.InPositionRegisters(axis)
    axis.cycle_start()
    axis.capture()
    regs = [0] * 212
    ext.access(0, 200, regs, None)
    angle = struct.unpack(">d", b"".join(w.to_bytes(2, "big") for w in regs[208:212]))[0]
    assert angle == pytest.approx(90.0 - 3.6 / 3600.0)  # stops short by half the backlash (arcsec)


def test_bits_left_by_an_earlier_cycle_until_the_program_starts() -> None:
    # docs/modbus-map.md: b1 set at program start (b0/b2 of the earlier cycle cleared), b2 at its end
    axis = ma.MachineAxis(STOPS, errors=ma.AxisErrors(noise=0.0), handshake="ack", bits_left_set=True,
                          program_start_s=0.2)
    with plc(axis) as (client, inpos):
        # in position (b0) at the earlier cycle's last stop (target 1, run 1, -), counter 57; finished (b2)
        assert inpos()[:5] == [ma.IP_IN_POSITION | ma.IP_DONE, 1, 1, 0xFFFF, 57]
        client.write_register(205, 57, device_id=1)  # acknowledging the stale event does not start anything
        assert inpos()[0] == ma.IP_IN_POSITION | ma.IP_DONE and axis.index == -1
        axis.cycle_start()
        assert inpos()[0] == ma.IP_IN_POSITION | ma.IP_DONE  # Cycle Start pressed, the program not started yet
        wait_for(lambda: inpos()[0] & ma.IP_RUNNING, timeout_s=5, what="the program to start")
        assert inpos()[:5] == [ma.IP_IN_POSITION | ma.IP_RUNNING, 1, 1, 1, 58]  # target 1, run 1, +: new event
