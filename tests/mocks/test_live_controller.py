"""The simulated live-compensation controller against docs/compensation.md ("Live compensation
interface", controller rules), over Modbus TCP with a plain pymodbus client (not the tool's driver)."""

from __future__ import annotations

import struct
from collections.abc import Iterator

import pytest
from pymodbus.client import ModbusTcpClient

from mocks.live_controller import LiveOffsetController, start_live_controller


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def f32(value: float) -> list[int]:
    raw = struct.pack(">f", value)
    return [int.from_bytes(raw[:2], "big"), int.from_bytes(raw[2:], "big")]


def as_f32(words: list[int]) -> float:
    return struct.unpack(">f", b"".join(w.to_bytes(2, "big") for w in words))[0]


@pytest.fixture
def served() -> Iterator[tuple[LiveOffsetController, ModbusTcpClient, Clock]]:
    clock = Clock()
    ctl = LiveOffsetController(rotary=False, timeout_ms=500, clock=clock, settle_s=0.0)
    srv = start_live_controller(ctl)
    client = ModbusTcpClient("127.0.0.1", port=srv.port, timeout=2)
    assert client.connect()
    yield ctl, client, clock
    client.close()
    srv.stop()


def read(client: ModbusTcpClient) -> list[int]:
    rr = client.read_holding_registers(0, count=17, device_id=1)
    assert not rr.isError()
    return list(rr.registers)


def test_offset_applied_while_enabled_and_the_heartbeat_is_fresh(served) -> None:  # noqa: ANN001
    ctl, client, clock = served
    regs = read(client)
    assert regs[0] == 1 and regs[16] == 500 and regs[2] == 0  # version, T in ms, no motion yet
    assert not client.write_registers(9, [1, 0, 25, *f32(2.5)], device_id=1).isError()
    assert ctl.applied() == 0.0  # not enabled
    assert not client.write_register(8, 1, device_id=1).isError()
    assert ctl.applied() == 2.5
    regs = read(client)
    assert regs[1] & 1 and not regs[1] & 2 and as_f32(regs[14:16]) == 2.5
    clock.t += 0.4
    client.write_registers(9, [2, 0, 25, *f32(2.5)], device_id=1)  # the heartbeat moves: fresh again
    clock.t += 0.4
    assert ctl.applied() == 2.5
    # stale: 9 unchanged for more than T -> offset 0, b1 set, latched
    clock.t += 0.2
    assert ctl.applied() == 0.0
    regs = read(client)
    assert regs[1] & 2 and not regs[1] & 1 and as_f32(regs[14:16]) == 0.0
    client.write_registers(9, [3, 0, 25, *f32(2.5)], device_id=1)
    assert ctl.applied() == 0.0  # a heartbeat alone does not resume
    client.write_register(8, 1, device_id=1)  # enable written 1 again: resumes
    assert ctl.applied() == 2.5
    client.write_register(8, 0, device_id=1)  # the off switch
    assert ctl.applied() == 0.0


def test_controller_registers_are_read_only(served) -> None:  # noqa: ANN001
    _, client, _ = served
    for address in (0, 1, 2, 3, 4, 14, 16):
        rr = client.write_register(address, 1, device_id=1)
        assert rr.isError() and rr.exception_code == 2, address
    assert client.write_registers(12, [0, 0, 0], device_id=1).isError()  # 12-14 reaches into 14


def test_position_direction_and_sample(served) -> None:  # noqa: ANN001
    ctl, client, _ = served
    ctl.move_to(100.0)
    regs = read(client)
    assert regs[2] == 1 and regs[3] == 1
    assert struct.unpack(">d", b"".join(w.to_bytes(2, "big") for w in regs[4:8]))[0] == 100.0
    ctl.move_to(100.0)  # at rest: direction kept
    assert read(client)[2] == 1
    ctl.move_to(40.0)
    regs = read(client)
    assert regs[2] == 0xFFFF and regs[3] == 3  # -1


def test_move_to_waits_for_the_answer_to_its_sample() -> None:
    ctl = LiveOffsetController(rotary=True, settle_s=0.0)
    ctl._write(8, [1])
    ctl._write(9, [1, 0, 0, *f32(-3.6)])  # an answer to sample 0, not to the move's sample
    assert ctl.move_to(10.0) == pytest.approx(-3.6 / 3600.0)  # settle_s 0: takes what is applied
    assert ctl.lags_s == type(ctl.lags_s)()  # no answer to sample 1 yet
    ctl._write(9, [2, 1, 0, *f32(-3.6)])
    assert len(ctl.lags_s) == 1


def test_reversal_error_makes_the_up_and_down_curves_cross() -> None:
    from mocks.machine_axis import AxisErrors

    ax = AxisErrors(pitch=(), slope_per_m=0.0, backlash=0.0, periodic=0.0, thermal_per_m_per_h=0.0,
                    reversal=((6.0, 360.0, 0.0),))
    for p, split in ((90.0, 6.0), (270.0, -6.0), (0.0, 0.0), (30.0, 3.0)):  # e_up - e_down = 6 sin(p)
        assert ax.deviation(p, 1, 0.0) - ax.deviation(p, -1, 0.0) == pytest.approx(split, abs=1e-12)
