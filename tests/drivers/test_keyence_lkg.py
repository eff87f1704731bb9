"""Keyence LK-G3000 codec and driver against the manual's byte examples
(protocols.md section 1.1: format p.5-5, value table p.5-6, error codes)."""

from __future__ import annotations

import math

import pytest

from drivers.errors import DeviceError, ProtocolError
from drivers.keyence_lkg import KeyenceLKG
from drivers.keyence_lkg import protocol as p
from drivers.readings import MeasurementStatus
from tests.protocol_fakes import ExpectedProtocol


@pytest.mark.parametrize(
    ("field", "value"),
    [("+01.2345", 1.2345), ("-00.0120", -0.012), ("+1234.56", 1234.56), ("-00001.2", -1.2),
     ("+0.12345", 0.12345), ("+0000000", 0.0)],
)
def test_value_table_of_the_manual(field: str, value: float) -> None:
    v, status = p.parse_value(field)
    assert status is MeasurementStatus.OK
    assert v == value


@pytest.mark.parametrize(
    ("field", "status"),
    [("+FFFFFFF", MeasurementStatus.OVER_RANGE_HIGH), ("-FFFFFFF", MeasurementStatus.OVER_RANGE_LOW),
     ("XXXXXXXX", MeasurementStatus.ALARM), ("--------", MeasurementStatus.NO_VALUE)],
)
def test_special_values(field: str, status: MeasurementStatus) -> None:
    v, st = p.parse_value(field)
    assert st is status and math.isnan(v)


@pytest.mark.parametrize("field", ["+1.2345", "01.23456", "+01.23.4", "+0A.2345", "+       ", "++1.2345", "+......."])
def test_malformed_value_fields_raise(field: str) -> None:
    with pytest.raises(ProtocolError):
        p.parse_value(field)


def test_commands_are_the_manual_bytes() -> None:
    assert p.encode_measure(1) == b"M1\r"
    assert p.encode_measure(2) == b"M2\r"
    assert p.encode_measure(0) == b"M0\r"
    assert p.encode("VR", "0") == b"VR,0\r"
    with pytest.raises(ValueError):
        p.encode_measure(3)


def test_decode_m0_two_values() -> None:
    assert p.decode_measure(b"M0,+01.2345,-00.0120\r", 0) == [
        (1.2345, MeasurementStatus.OK), (-0.012, MeasurementStatus.OK)]


@pytest.mark.parametrize(
    ("code", "text"),
    [("00", "Command error"), ("01", "Status error"), ("20", "Command length error"),
     ("21", "Parameter count error"), ("22", "Invalid parameter error"), ("88", "Timeout error"),
     ("99", "Other errors")],
)
def test_error_frames_raise_device_error(code: str, text: str) -> None:
    with pytest.raises(DeviceError) as info:
        p.decode_measure(f"ER,M1,{code}\r".encode(), 1)
    assert info.value.code == code and info.value.text == text


@pytest.mark.parametrize(
    "frame",
    [b"M1,+01.2345", b"M2,+01.2345\r", b"M1,+01.2345,+01.2345\r", b"ER,M1\r", b"ER,M1,0x\r",
     b"M1,+01.2\xff45\r", b"\r", b"M1\r", b"M1,+01.2345\n\r"],
)
def test_malformed_frames_raise_protocol_error(frame: bytes) -> None:
    with pytest.raises(ProtocolError):
        p.decode_measure(frame, 1)


def test_driver_polls_exact_bytes() -> None:
    link = ExpectedProtocol([(b"M1\r", b"M1,+01.2345\r")])
    reading = KeyenceLKG(link).read_once()
    link.assert_done()
    assert reading.ok and reading.value_mm == 1.2345 and reading.raw == "M1,+01.2345\r"


def test_driver_reads_output_2() -> None:
    link = ExpectedProtocol([(b"M2\r", b"M2,-00.0120\r")])
    assert KeyenceLKG(link, output=2).read_once().value_mm == -0.012
    link.assert_done()


def test_driver_averages_and_rejects_over_range() -> None:
    link = ExpectedProtocol([(b"M1\r", b"M1,+00.0010\r"), (b"M1\r", b"M1,+00.0030\r"),
                             (b"M1\r", b"M1,+FFFFFFF\r"), (b"M1\r", b"M1,+00.0020\r")])
    avg = KeyenceLKG(link).read_averaged(4)
    link.assert_done()
    assert avg.count == 3 and avg.rejected == 1 and not avg.ok
    assert avg.mean_mm == pytest.approx(0.002, abs=1e-15)
    assert avg.std_mm == pytest.approx(0.001, abs=1e-12)  # sample std of 1, 3, 2 um
    assert avg.statuses == (MeasurementStatus.OVER_RANGE_HIGH,)


def test_driver_raises_device_error() -> None:
    link = ExpectedProtocol([(b"M1\r", b"ER,M1,01\r")])
    with pytest.raises(DeviceError, match="Status error"):
        KeyenceLKG(link).read_once()
    link.assert_done()


def test_read_and_describe_have_the_same_keys() -> None:
    link = ExpectedProtocol([(b"M1\r", b"M1,+00.5000\r")])
    dev = KeyenceLKG(link, endpoint="loop://")
    reading, schema = dev.read(), dev.describe()
    assert reading.keys() == schema.keys() == {"sensor_mm"}
    assert reading["sensor_mm"]["value"] == 0.5 and schema["sensor_mm"]["units"] == "mm"
