"""Each sensor driver against its emulator over each transport: in-process
(:class:`EmulatorLink`), TCP loopback (``socket://127.0.0.1:PORT``) and a real
pty opened by path through ``open_serial``; and each sensor fault of a
:class:`FaultPlan` gives its typed error, after which the next request works."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import pytest

from acquisition.rig import open_sensor
from drivers.errors import ChecksumError, DeviceError, DriverError, ProtocolError, TransportTimeout
from drivers.keyence_lkg import KeyenceLKG
from drivers.panasonic_hlg1 import PanasonicHLG1
from drivers.sensor import DisplacementSensor
from drivers.transport import SerialLink, open_serial
from mocks.faults import FaultPlan
from mocks.keyence_lkg import KeyenceLKGEmulator
from mocks.panasonic_hlg1 import PanasonicHLG1Emulator
from mocks.serial_endpoints import PtyEndpoint, TcpEndpoint
from tests.protocol_fakes import EmulatorLink
from tests.waiting import wait_for

TIMEOUT_S = 0.3  # driver reply timeout in these tests; the delay fault is longer


class Source:
    """The displacement the emulator sees, in mm, settable by the test."""

    def __init__(self, value: float | None) -> None:
        self.value = value

    def __call__(self, _output: int) -> float | None:
        return self.value


@dataclass(frozen=True)
class Sensor:
    emulator: Callable[[Source, FaultPlan], Any]
    driver: Callable[[Any, str], DisplacementSensor]
    error_arg: str  # device error code the ``error`` fault sends
    error_text: str  # the manual's text for it
    corrupt_error: type[DriverError]


SENSORS = {
    "lkg3000": Sensor(
        lambda src, plan: KeyenceLKGEmulator(src, decimals=5, faults=plan),
        lambda link, url: KeyenceLKG(link, endpoint=url, timeout_s=TIMEOUT_S),
        "22", "Invalid parameter error", ProtocolError,
    ),
    "lkg5000": Sensor(
        lambda src, plan: KeyenceLKGEmulator(src, decimals=5, faults=plan),
        lambda link, url: KeyenceLKG(link, series="LK-G5000", output=2, endpoint=url, timeout_s=TIMEOUT_S),
        "01", "Status error", ProtocolError,
    ),
    "hlg1": Sensor(
        lambda src, plan: PanasonicHLG1Emulator(src, station=5, faults=plan),
        lambda link, url: PanasonicHLG1(link, station=5, endpoint=url, timeout_s=TIMEOUT_S),
        "04", "BCC error", ChecksumError,
    ),
    "hlg1-no-bcc": Sensor(
        lambda src, plan: PanasonicHLG1Emulator(src, faults=plan),
        lambda link, url: PanasonicHLG1(link, use_bcc=False, endpoint=url, timeout_s=TIMEOUT_S),
        "33", "Buffering condition error 3", ChecksumError,
    ),
}
TRANSPORTS = ["in-process", "tcp", "pty"]


@contextmanager
def connected(sensor: str, transport: str, faults: str = "") -> Iterator[tuple[DisplacementSensor, Source, Any]]:
    spec = SENSORS[sensor]
    src = Source(0.25)
    emulator = spec.emulator(src, FaultPlan.parse(faults))
    endpoint: PtyEndpoint | TcpEndpoint | None = None
    if transport == "in-process":
        link: Any = EmulatorLink(emulator)
        url = "in-process"
    else:
        endpoint = TcpEndpoint(emulator) if transport == "tcp" else PtyEndpoint(emulator, baudrate=115200)
        url = endpoint.url if isinstance(endpoint, TcpEndpoint) else endpoint.path
        link = open_serial(url)
    dev = spec.driver(link, url)
    try:
        yield dev, src, link
    finally:
        dev.close()
        if endpoint is not None:
            endpoint.stop()


@pytest.mark.parametrize("transport", TRANSPORTS)
@pytest.mark.parametrize("sensor", sorted(SENSORS))
def test_driver_reads_its_emulator(sensor: str, transport: str) -> None:
    with connected(sensor, transport) as (dev, src, _link):
        first = dev.read_once()
        assert first.ok and first.value_mm == 0.25
        src.value = -1.2345
        avg = dev.read_averaged(3)
        assert avg.ok and avg.count == 3 and avg.mean_mm == pytest.approx(-1.2345, abs=1e-12)
        src.value = None
        assert not dev.read_once().ok


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_keyence_settings_round_trip(transport: str) -> None:
    with connected("lkg3000", transport) as (dev, src, _link):
        assert isinstance(dev, KeyenceLKG)
        dev.set_offset(0.1)
        assert dev.offset() == 0.1
        assert dev.read_once().value_mm == 0.15  # emulator: source - offset
        dev.set_head_mode(2, 3)
        assert dev.head_mode(2) == 3
        dev.reset()
        assert dev.offset() == 0.0 and dev.read_once().value_mm == 0.25
        r1, r2 = dev.read_both()
        assert r1.value_mm == r2.value_mm == 0.25


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_hlg1_commands_round_trip(transport: str) -> None:
    with connected("hlg1", transport) as (dev, src, _link):
        assert isinstance(dev, PanasonicHLG1)
        dev.zero_set()
        assert dev.read_once().value_mm == 0.0
        src.value = 0.3
        assert dev.read_value().value_mm == 0.05
        dev.zero_set(False)
        assert dev.read_once().value_mm == 0.3
        assert dev.light_intensity() == 567 and not dev.alarm()
        dev.laser(False)
        assert dev.alarm() and dev.read_once().status.value == "alarm"
        dev.laser(True)
        dev.set_averaging_code(4)
        dev.set_threshold_a(5.5)
        dev.reset()
        assert dev.sampling_cycle_code() == 1
        assert not dev.judgement_output(2)


# Every kind for every sensor in-process; over TCP and the pty (pyserial's socket close alone
# costs 0.3 s) one configuration per protocol, with the kinds that leave bytes in flight.  An
# in-process emulator answers synchronously, so a delay cannot time out there.
KINDS = ("drop", "garbage", "corrupt", "error")
FAULT_CASES = [(s, "in-process", k) for s in sorted(SENSORS) for k in KINDS] + [
    (s, t, k) for s in ("lkg3000", "hlg1") for t in ("tcp", "pty") for k in ("delay", "garbage", "corrupt")]


@pytest.mark.parametrize(("sensor", "transport", "kind"), FAULT_CASES)
def test_fault_gives_typed_error_then_recovers(sensor: str, transport: str, kind: str) -> None:
    spec = SENSORS[sensor]
    arg = {"error": f"={spec.error_arg}", "delay": f"={TIMEOUT_S * 2.5}"}.get(kind, "")
    with connected(sensor, transport, f"sensor:{kind}@2x1{arg}") as (dev, src, link):
        assert dev.read_once().value_mm == 0.25
        expected: type[DriverError] = {
            "drop": TransportTimeout, "delay": TransportTimeout, "garbage": ProtocolError,
            "corrupt": spec.corrupt_error, "error": DeviceError,
        }[kind]
        with pytest.raises(expected) as info:
            dev.read_once()
        if kind == "error":
            assert isinstance(info.value, DeviceError)
            assert info.value.code == spec.error_arg and info.value.text.startswith(spec.error_text)
        if kind == "delay":
            assert isinstance(link, SerialLink)
            wait_for(lambda: link.port.in_waiting > 0, timeout_s=10, what="the late reply")
        src.value = -0.5  # the stale reply (if any) still says 0.25
        after = dev.read_once()
        assert after.ok and after.value_mm == -0.5


def test_open_sensor_by_protocol_name() -> None:
    endpoint = TcpEndpoint(PanasonicHLG1Emulator(Source(1.5)))
    try:
        dev = open_sensor("panasonic-hlg1", endpoint.url)
        try:
            assert isinstance(dev, PanasonicHLG1) and dev.read_once().value_mm == 1.5
            assert dev.describe()["sensor_mm"]["source"] == f"panasonic-hlg1:{endpoint.url}"
        finally:
            dev.close()
    finally:
        endpoint.stop()
