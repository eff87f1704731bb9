"""The LK-G emulator against the manual's formats, and the real driver against
the emulator over each transport (in-process, TCP loopback, real pty)."""

from __future__ import annotations

import pytest

from drivers.keyence_lkg import KeyenceLKG
from drivers.transport import open_serial
from mocks.keyence_lkg import KeyenceLKGEmulator, format_value
from mocks.serial_endpoints import PtyEndpoint, TcpEndpoint


@pytest.mark.parametrize(
    ("value", "decimals", "field"),
    [(1.2345, 4, "+01.2345"), (-0.012, 4, "-00.0120"), (1234.56, 2, "+1234.56"), (-1.2, 1, "-00001.2"),
     (12345.0, 4, "+FFFFFFF"), (-12345.0, 4, "-FFFFFFF"), (None, 4, "XXXXXXXX")],
)
def test_value_format_matches_manual_table(value: float | None, decimals: int, field: str) -> None:
    assert format_value(value, decimals) == field


def test_emulator_state_machine() -> None:
    values = {1: 1.2345, 2: -0.012}
    emu = KeyenceLKGEmulator(lambda out: values[out], decimals=4, range_mm=10)
    assert emu.receive(b"M1\r") == b"M1,+01.2345\r"
    assert emu.receive(b"m0\r") == b"M0,+01.2345,-00.0120\r"  # commands are case-insensitive
    assert emu.receive(b"Q0\r") == b"Q0\r"
    assert emu.receive(b"M1\r") == b"ER,M1,01\r"  # status error in set-up mode
    assert emu.receive(b"R0\r") == b"R0\r"
    assert emu.receive(b"XX\r") == b"ER,XX,00\r"
    assert emu.receive(b"M1,5\r") == b"ER,M1,21\r"
    assert emu.receive(b"M") == b""  # partial command: nothing yet
    assert emu.receive(b"2\rM1\r") == b"M2,-00.0120\rM1,+01.2345\r"
    values[1] = 12.0
    assert emu.receive(b"M1\r") == b"M1,+FFFFFFF\r"


class _Source:
    def __init__(self) -> None:
        self.value = 0.25

    def __call__(self, _out: int) -> float:
        return self.value


def test_driver_in_process() -> None:
    src = _Source()
    emu = KeyenceLKGEmulator(src, decimals=5)

    class Link:  # minimal in-process transport
        buf = b""

        def write(self, data: bytes) -> None:
            self.buf += emu.receive(data)

        def read_until(self, term: bytes, timeout_s: float) -> bytes:
            i = self.buf.index(term) + 1
            frame, self.buf = self.buf[:i], self.buf[i:]
            return frame

        def close(self) -> None:
            pass

    dev = KeyenceLKG(Link())  # type: ignore[arg-type]
    assert dev.read_once().value_mm == 0.25


@pytest.mark.parametrize("transport", ["tcp", "pty"])
def test_driver_over_real_transport(transport: str) -> None:
    src = _Source()
    emu = KeyenceLKGEmulator(src, decimals=5)
    endpoint = TcpEndpoint(emu) if transport == "tcp" else PtyEndpoint(emu, baudrate=115200)
    url = endpoint.url if transport == "tcp" else endpoint.path
    dev = KeyenceLKG(open_serial(url), endpoint=url)
    try:
        assert dev.read_once().value_mm == 0.25
        src.value = -0.01234
        avg = dev.read_averaged(3)
        assert avg.ok and avg.count == 3 and avg.mean_mm == pytest.approx(-0.01234, abs=1e-12)
        assert avg.std_mm == 0.0
    finally:
        dev.close()
        endpoint.stop()
