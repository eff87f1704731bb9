"""The ILD1420 emulator against protocols.md section 1.6, and the real driver
against the emulator in-process, over TCP loopback and over a real pty at
921.6 kBd with the value stream running (including broken frames)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from acquisition.rig import SENSOR_DRIVERS, open_sensor
from drivers.errors import DeviceError, ProtocolError, TransportTimeout
from drivers.me_ild1420 import ILD1420
from drivers.readings import MeasurementStatus
from drivers.transport import open_serial
from mocks.faults import FaultPlan
from mocks.me_ild1420 import ILD1420Emulator, StreamPacer
from mocks.serial_endpoints import PtyEndpoint, TcpEndpoint
from tests.drivers.ild1420_vectors import GETINFO_REPLY, frame, mm
from tests.waiting import wait_for


def counts(x_mm: float, mr: float, offset: float = 0.01) -> int:
    """Count the manual's formula gives for ``x_mm``: digital = (x / MR + offset) * 65520 / 1.02."""
    return round((x_mm / mr + offset) * 65520 / 1.02)


class Source:
    def __init__(self, value: float | None = 5.0) -> None:
        self.value = value

    def __call__(self, _out: int) -> float | None:
        return self.value


class Ramp:
    """Frame k (counted from the first call) measures 1.0 + 0.002 k mm: the value names the frame."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, _out: int) -> float:
        v = 1.0 + 0.002 * (self.calls % 3000)
        self.calls += 1
        return v


def frame_index(value_mm: float) -> int:
    return round((value_mm - 1.0) / 0.002)


# -- emulator alone ------------------------------------------------------------------------

def test_command_replies() -> None:
    emu = ILD1420Emulator(Source(), output="NONE", reject_code=321)
    assert emu.receive(b"GETINFO\r") == GETINFO_REPLY  # the manual's example, byte for byte
    assert emu.receive(b"OUTPUT\r") == b"OUTPUT NONE\r\n->"
    assert emu.receive(b"OUTPUT RS422\r") == b"\r\n->"
    assert emu.output == "RS422"
    assert emu.receive(b"output analog\r\n") == b"\r\n->"  # CR LF accepted, case-insensitive
    assert emu.receive(b"OUTPUT\r") == b"OUTPUT ANALOG\r\n->"
    assert emu.receive(b"OUTPUT USB\r").startswith(b"E321 ")
    assert emu.receive(b"NOSUCH\r").startswith(b"E321 ")
    assert emu.receive(b"MEASRATE 4\r") == b"\r\n->" and emu.measrate_khz == 4.0
    assert emu.receive(b"MEASRATE 8\r").startswith(b"E321 ")
    assert emu.receive(b"MEASRATE\r") == b"MEASRATE 4\r\n->"
    assert emu.receive(b"ECHO ON\r") == b"\r\n->"
    assert emu.receive(b"OUTPUT\r") == b"OUTPUT\r\nOUTPUT ANALOG\r\n->"
    assert emu.receive(b"OUTPUT NONE\r") == b"OUTPUT NONE\r\n->"
    assert emu.receive(b"OUT") == b""  # partial command: nothing yet
    assert emu.receive(b"PUT\rECHO OFF\r") == b"OUTPUT\r\nOUTPUT NONE\r\n->ECHO OFF\r\n->"


def test_mastering_replies() -> None:
    src = Source(None)
    emu = ILD1420Emulator(src, measuring_range_mm=10.0)
    assert emu.receive(b"MASTERMV MASTER 1\r") == b"E104 Timeout\r\n->"  # no value to master
    src.value = 5.0
    assert emu.receive(b"MASTERMV MASTER 20.5\r").startswith(b"E")  # above 2 x MR
    assert emu.receive(b"MASTERMV\r") == b"MASTERMV NONE\r\n->"
    assert emu.receive(b"MASTERMV MASTER 1.25\r") == b"\r\n->"
    assert emu.receive(b"MASTERMV\r") == b"MASTERMV MASTER 1.250000\r\n->"
    assert emu.receive(b"MASTERMV NONE\r") == b"\r\n->"


def test_stream_frames_follow_the_manual() -> None:
    src = Source(5.0)
    emu = ILD1420Emulator(src, measuring_range_mm=10.0, output="NONE")
    assert emu.stream_bytes(3) == b""  # output NONE: silent
    emu.receive(b"OUTPUT RS422\r")
    assert emu.stream_bytes(2) == frame(counts(5.0, 10.0)) * 2
    src.value = 10.05  # in the end-of-range reserve: still a count
    assert emu.stream_bytes(1) == frame(counts(10.05, 10.0))
    src.value = 10.6  # beyond what 16 bits code
    assert emu.stream_bytes(1) == frame((1 << 18) - 1)
    src.value = None  # no target
    assert emu.stream_bytes(1) == frame((1 << 18) - 1)
    src.value = 5.0
    emu.receive(b"MASTERMV MASTER 1\r")
    src.value = 5.2  # 0.2 mm further than at mastering: reads 1.2 mm with offset 0.51
    assert emu.stream_bytes(1) == frame(counts(1.2, 10.0, 0.51))
    assert emu.frames_sent == 6


def test_stream_faults_break_the_chosen_frame() -> None:
    emu = ILD1420Emulator(Source(5.0), measuring_range_mm=10.0)
    f = frame(counts(5.0, 10.0))
    emu.schedule_stream_fault(1, "drop", position=0)
    emu.schedule_stream_fault(3, "garbage", position=1)
    assert emu.stream_bytes(5) == f + f[1:] + f + f[:2] + b"\x7f" + f[2:] + f
    assert emu.frames_broken == 2
    with pytest.raises(ValueError):
        emu.schedule_stream_fault(1, "explode")


# -- driver against the emulator in-process ------------------------------------------------

class InProcessLink:
    """Emulator in the same thread; each read delivers the reply bytes plus a few stream frames."""

    def __init__(self, emu: ILD1420Emulator, frames_per_read: int = 7) -> None:
        self.emu = emu
        self.frames_per_read = frames_per_read
        self._pending = bytearray()

    def write(self, data: bytes) -> None:
        self._pending += self.emu.receive(data)

    def read_some(self, max_bytes: int, timeout_s: float) -> bytes:
        self._pending += self.emu.stream_bytes(self.frames_per_read)
        data = bytes(self._pending[:max_bytes])
        del self._pending[:max_bytes]
        return data

    def discard_input(self) -> None:
        self._pending.clear()

    def close(self) -> None:
        pass


def test_driver_in_process() -> None:
    src = Source(5.0)
    emu = ILD1420Emulator(src, measuring_range_mm=25.0, serial="99")
    dev = ILD1420(InProcessLink(emu), measuring_range_mm=10.0)  # type: ignore[arg-type]
    info = dev.identify()  # streaming while identifying
    assert info["serial"] == "99" and dev.measuring_range_mm == 25.0
    reading = dev.read_once()
    assert reading.ok and reading.value_mm == pytest.approx(mm(counts(5.0, 25.0), 25.0), abs=1e-12)
    assert abs(reading.value_mm - 5.0) < 25.0 * 1.02 / 65520  # within one count of the truth
    dev.master(0.0)
    src.value = 5.5
    assert dev.read_once().value_mm == pytest.approx(0.5, abs=25.0 * 1.02 / 65520)
    dev.unmaster()
    dev.start_stream()
    emu.schedule_stream_fault(emu.frames_sent + 10, "drop", position=2)
    block = dev.read_stream(30)
    assert block.frames_ok == 30 and block.frames_lost == 1 and block.resyncs == 1
    assert all(s is MeasurementStatus.OK for s in block.statuses)
    assert block.values_mm.tolist() == pytest.approx([5.5] * 30, abs=25.0 * 1.02 / 65520)
    dev.stop_stream()
    assert emu.output == "NONE"
    assert dev.get_output() == "NONE"


@pytest.mark.parametrize(
    ("spec", "error"),
    [("sensor:garbage@2x1", ProtocolError), ("sensor:drop@2x1", TransportTimeout),
     ("sensor:error@2x1", DeviceError), ("sensor:error@2x1=202", DeviceError),
     ("sensor:corrupt@2x1", ProtocolError)],
)
def test_reply_faults_give_typed_errors(spec: str, error: type[Exception]) -> None:
    emu = ILD1420Emulator(Source(), faults=FaultPlan.parse(spec))
    dev = ILD1420(InProcessLink(emu), timeout_s=0.05)  # type: ignore[arg-type]
    dev.set_output("NONE")  # request 1; from now on replies must be pure ASCII
    with pytest.raises(error) as info:
        dev.identify()  # request 2: the fault
    if spec.endswith("=202"):
        assert info.value.code == 202 and info.value.text == "Access denied"  # type: ignore[attr-defined]
    assert dev.identify()["model"] == "ILD1420-10"  # request 3: the driver recovers


# -- over real transports -------------------------------------------------------------------

def test_driver_over_tcp_loopback() -> None:
    emu = ILD1420Emulator(Source(3.0), output="NONE", measuring_range_mm=50.0)
    endpoint = TcpEndpoint(emu)
    dev = ILD1420(open_serial(endpoint.url), endpoint=endpoint.url)
    try:
        assert dev.identify()["model"] == "ILD1420-50" and dev.measuring_range_mm == 50.0
        assert dev.get_output() == "NONE"
        dev.set_measrate_khz(1)
        assert dev.get_measrate_khz() == 1.0
        dev.master(2.0)
        assert emu.master_mm == 2.0
        dev.unmaster()
        with pytest.raises(TransportTimeout):
            dev.read_once()  # output NONE: no frames
    finally:
        dev.close()
        endpoint.stop()


def test_late_reply_over_tcp_times_out() -> None:
    emu = ILD1420Emulator(Source(), output="NONE", faults=FaultPlan.parse("sensor:delay@1x1=0.3"))
    endpoint = TcpEndpoint(emu)
    link = open_serial(endpoint.url)
    dev = ILD1420(link, timeout_s=0.1)
    try:
        with pytest.raises(TransportTimeout):
            dev.identify()
        wait_for(lambda: link.port.in_waiting > 0, timeout_s=5, what="the late reply")
        dev.set_output("NONE")  # the late reply is flushed before the next command
        assert dev.get_output() == "NONE"
    finally:
        dev.close()
        endpoint.stop()


@pytest.fixture
def pty_sensor() -> Iterator[tuple[ILD1420Emulator, Ramp | Source, str]]:
    holder: dict[str, object] = {}

    def make(source, **kw):
        emu = ILD1420Emulator(source, measuring_range_mm=10.0, **kw)
        endpoint = PtyEndpoint(emu, baudrate=921600)
        pacer = StreamPacer(emu, endpoint.write_unsolicited).start()
        holder.update(emu=emu, endpoint=endpoint, pacer=pacer)
        return emu, endpoint.path

    yield make
    for key in ("pacer", "endpoint"):
        if key in holder:
            holder[key].stop()  # type: ignore[attr-defined]


def test_driver_over_pty_while_streaming(pty_sensor) -> None:
    src = Source(4.0)
    emu, path = pty_sensor(src)  # output RS422 from power-up: frames flow before the driver asks
    dev = ILD1420.from_url(path, measuring_range_mm=10.0, timeout_s=2.0)  # generous: loaded CI
    try:
        assert dev.identify()["model"] == "ILD1420-10"
        reading = dev.read_once()
        assert reading.ok and abs(reading.value_mm - 4.0) < 10.0 * 1.02 / 65520
        src.value = None
        wait_for(lambda: math.isnan(dev.read_once().value_mm), timeout_s=5, what="no-target value")
        assert dev.read_once().status is MeasurementStatus.ALARM
    finally:
        dev.close()


def test_stream_over_pty_resyncs_and_counts_broken_frames(pty_sensor) -> None:
    ramp = Ramp()
    emu, path = pty_sensor(ramp, output="NONE", measrate_khz=4.0)
    broken = {60: ("drop", 0), 160: ("drop", 1), 260: ("drop", 2), 360: ("garbage", 1), 460: ("garbage", 0)}
    for k, (kind, pos) in broken.items():
        emu.schedule_stream_fault(k, kind, position=pos, byte=0xFF if pos == 0 else 0x7F)
    dev = ILD1420.from_url(path, measuring_range_mm=10.0, timeout_s=2.0)  # generous: loaded CI
    try:
        dev.start_stream()  # frames are numbered from here: output was NONE
        blocks = [dev.read_stream(100) for _ in range(6)]
        assert all(b.frames_ok == 100 for b in blocks)
        blocks.append(dev.stop_stream())
    finally:
        dev.close()
    assert emu.output == "NONE" and emu.frames_broken == len(broken)
    indices = [frame_index(v) for b in blocks for v in b.values_mm.tolist()]
    assert indices == [k for k in range(emu.frames_sent) if k not in broken]
    assert sum(b.frames_lost for b in blocks) == len(broken)
    assert sum(b.resyncs for b in blocks) == len(broken)


def test_mastering_while_streaming_over_pty(pty_sensor) -> None:
    src = Source(6.0)
    emu, path = pty_sensor(src, output="NONE")
    dev = ILD1420.from_url(path, measuring_range_mm=10.0, timeout_s=2.0)  # generous: loaded CI
    try:
        dev.start_stream()
        assert dev.read_stream(20).values_mm.tolist() == pytest.approx([6.0] * 20, abs=2e-4)
        dev.master(2.0)
        src.value = 6.3
        values: list[float] = []
        while not values or abs(values[-1] - 2.3) > 1e-3:
            assert len(values) < 20000, "the moved surface never showed up"
            values += dev.read_stream(50).values_mm.tolist()
        # in order: values read before mastering (6.0 mm, left over from the first block),
        # mastered values before the move (2.0 mm) and after it (2.3 mm)
        levels = [min((6.0, 2.0, 2.3), key=lambda level, v=v: abs(v - level)) for v in values]
        assert values == pytest.approx(levels, abs=2e-4)
        assert levels == sorted(levels, key=[6.0, 2.0, 2.3].index) and levels[-1] == 2.3
        dev.stop_stream()
    finally:
        dev.close()


def test_registered_for_the_rig(pty_sensor) -> None:
    assert SENSOR_DRIVERS["me-ild1420"] is ILD1420
    _emu, path = pty_sensor(Source(2.5), output="NONE")
    dev = open_sensor("me-ild1420", path)
    try:
        assert dev.protocol == "me-ild1420" and dev.identify()["serial"] == "15030002"
    finally:
        dev.close()


def test_serial_link_read_some_returns_what_arrived() -> None:
    link = open_serial("loop://")
    try:
        link.write(b"abc")
        wait_for(lambda: link.port.in_waiting == 3, timeout_s=5, what="loopback bytes")
        assert link.read_some(2, 1.0) == b"ab"
        assert link.read_some(10, 1.0) == b"c"
        assert link.read_some(10, 0.01) == b""  # silence is not an error
    finally:
        link.close()


def test_pacer_makes_no_frames_while_the_line_is_not_ready() -> None:
    emu = ILD1420Emulator(Source(4.0), measrate_khz=1.0)
    written: list[bytes] = []
    ready = [False]
    asked = [0]

    def line_ready() -> bool:
        asked[0] += 1
        return ready[0]

    with StreamPacer(emu, written.append, ready=line_ready):
        wait_for(lambda: asked[0] >= 3, timeout_s=5, what="three pacer intervals")
        assert emu.frames_sent == 0 and not written
        ready[0] = True
        wait_for(lambda: emu.frames_sent >= 5, timeout_s=5, what="frames once the line is ready")
    assert sum(len(b) for b in written) == 3 * emu.frames_sent  # every frame made was written, whole
