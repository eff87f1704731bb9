"""Checks against real devices, run on demand only (marker ``hardware``).

Skipped unless a device is named::

    pytest -m hardware --sensor-url keyence-lkg:/dev/ttyUSB0 --controller-url modbus-tcp://10.0.0.5:502

The sensor needs a target inside its measuring range; the controller needs
its beam aligned.  ``guideway sim serve`` prints URLs these tests accept too,
which is how they are checked without hardware.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from acquisition.probe import parse_sensor_spec
from acquisition.rig import open_controller, open_sensor
from drivers.interferometer import InterferometerController
from drivers.sensor import DisplacementSensor

pytestmark = pytest.mark.hardware


@pytest.fixture(scope="module")
def sensor(pytestconfig: pytest.Config) -> Iterator[DisplacementSensor]:
    spec = pytestconfig.getoption("--sensor-url")
    if not spec:
        pytest.skip("no --sensor-url PROTOCOL:URL given")
    protocol, url = parse_sensor_spec(spec)
    dev = open_sensor(protocol, url, baudrate=None)  # the protocol's usual rate
    yield dev
    dev.close()


@pytest.fixture(scope="module")
def controller(pytestconfig: pytest.Config) -> Iterator[InterferometerController]:
    url = pytestconfig.getoption("--controller-url")
    if not url:
        pytest.skip("no --controller-url given")
    dev = open_controller(url)
    yield dev
    dev.close()


def test_sensor_identity(sensor: DisplacementSensor) -> None:
    info = sensor.identify()
    assert info and all(isinstance(v, str) and v for v in info.values())


def test_sensor_gives_valid_readings(sensor: DisplacementSensor) -> None:
    readings = [sensor.read_once() for _ in range(5)]
    assert all(r.ok for r in readings), [(r.status, r.raw) for r in readings]
    assert all(math.isfinite(r.value_mm) for r in readings)
    stamps = [r.timestamp_s for r in readings]
    assert stamps == sorted(stamps)
    avg = sensor.read_averaged(10)
    assert avg.ok and avg.count == 10 and avg.std_mm >= 0


def test_controller_identity_and_status(controller: InterferometerController) -> None:
    info = controller.identify()  # FC 43/14 is optional: an empty answer is allowed
    assert all(isinstance(v, str) for v in info.values())
    st = controller.read_status()
    assert st.ready and not st.busy
    assert not st.error, f"controller has error {st.error_code} latched: {st.error_text}"


def test_controller_trigger_round_trip(controller: InterferometerController) -> None:
    before = controller.read_status().sequence
    first = controller.trigger_and_read()
    second = controller.trigger_and_read()
    assert first.ok and second.ok
    # one completed measurement per trigger: the sequence counter steps by one (16-bit wrap)
    assert first.sequence == (before + 1) % 65536
    assert second.sequence == (first.sequence + 1) % 65536
    for r in (first, second):
        assert all(math.isfinite(v) for v in (r.air_temp_c, r.air_pressure_hpa, r.humidity_pct,
                                               r.material_temp_c))
