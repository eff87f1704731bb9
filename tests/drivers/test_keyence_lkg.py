"""Keyence LK-G3000/LK-G5000 codec and driver against the manual's byte examples
(protocols.md section 1.1: format p.5-5, value table p.5-6, error codes; the
command table of 1.1 and the LK-G5000 driver examples of 1.2)."""

from __future__ import annotations

import math

import pytest

from drivers.errors import DeviceError, ProtocolError, TransportTimeout
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


ERROR_CODES = [("00", "Command error"), ("01", "Status error"), ("20", "Command length error"),
               ("21", "Parameter count error"), ("22", "Invalid parameter error"), ("88", "Timeout error"),
               ("99", "Other errors")]


# Every documented request, as the bytes of protocols.md 1.1/1.2 -------------------------------------
@pytest.mark.parametrize(
    ("encoded", "wire"),
    [
        (p.encode_measure_ms(1), b"MS,01\r"),  # Qt LK-G5000 driver
        (p.encode_measure_ms(2), b"MS,02\r"),  # rlab script "readdist"
        (p.encode_setup_mode(), b"Q0\r"),
        (p.encode_measure_mode(), b"R0\r"),
        (p.encode_reset(0), b"VR,0\r"),
        (p.encode_reset(2), b"VR,2\r"),
        (p.encode_write_offset(1, 12345), b"SW,OF,01,+012345\r"),  # setting format example +012345
        (p.encode_write_offset(2, -12345), b"SW,OF,02,-012345\r"),
        (p.encode_read_offset(1), b"SR,OF,01\r"),
        (p.encode_write_head_mode(1, 2), b"SW,HB,01,2\r"),
        (p.encode_read_head_mode(2), b"SR,HB,02\r"),
    ],
)
def test_requests_are_the_documented_bytes(encoded: bytes, wire: bytes) -> None:
    assert encoded == wire


@pytest.mark.parametrize(
    "call",
    [lambda: p.encode_measure_ms(0), lambda: p.encode_measure_ms(100), lambda: p.encode_reset(3),
     lambda: p.encode_write_offset(1, 1_000_000), lambda: p.encode_read_offset(3),
     lambda: p.encode_write_head_mode(1, 100), lambda: p.encode("M1\r")],
)
def test_out_of_range_requests_are_refused_before_sending(call) -> None:  # noqa: ANN001
    with pytest.raises(ValueError):
        call()


def test_ms_reply_of_the_lkg5000_example() -> None:
    # rlab script: readcode = ["MS,01,+000.260"]
    assert p.decode_measure_ms(b"MS,01,+000.260\r", 1) == (0.26, MeasurementStatus.OK)
    with pytest.raises(ProtocolError):
        p.decode_measure_ms(b"MS,02,+000.260\r", 1)  # answers another output


def test_setting_replies() -> None:
    assert p.decode_read_offset(b"SR,OF,01,+01.2345\r", 1) == (1.2345, 4)
    assert p.decode_read_offset(b"SR,OF,02,-0.12345\r", 2) == (-0.12345, 5)
    assert p.decode_read_head_mode(b"SR,HB,01,3\r", 1) == 3
    p.decode_ack(b"SW,OF\r", "SW,OF")
    p.decode_ack(b"vr\r", "VR")  # replies may come in lower case too
    with pytest.raises(ProtocolError):
        p.decode_ack(b"SW,HB\r", "SW,OF")
    with pytest.raises(ProtocolError):
        p.decode_read_offset(b"SR,OF,01,XXXXXXXX\r", 1)


@pytest.mark.parametrize(("code", "text"), ERROR_CODES)
@pytest.mark.parametrize(
    ("command", "decode"),
    [("MS", lambda f: p.decode_measure_ms(f, 1)), ("Q0", lambda f: p.decode_ack(f, "Q0")),
     ("R0", lambda f: p.decode_ack(f, "R0")), ("VR", lambda f: p.decode_ack(f, "VR")),
     ("SW", lambda f: p.decode_ack(f, "SW,OF")), ("SR", lambda f: p.decode_read_offset(f, 1)),
     ("SR", lambda f: p.decode_read_head_mode(f, 1))],
)
def test_every_error_code_for_every_command(command: str, decode, code: str, text: str) -> None:  # noqa: ANN001
    with pytest.raises(DeviceError) as info:
        decode(f"ER,{command},{code}\r".encode())
    assert (info.value.code, info.value.text, info.value.command) == (code, text, command)


# Driver conversations ------------------------------------------------------------------------------
def test_driver_lkg5000_polls_ms() -> None:
    link = ExpectedProtocol([(b"MS,02\r", b"MS,02,+000.260\r")])
    reading = KeyenceLKG(link, output=2, series="LK-G5000").read_once()
    link.assert_done()
    assert reading.ok and reading.value_mm == 0.26


def test_driver_reads_both_outputs() -> None:
    link = ExpectedProtocol([(b"M0\r", b"M0,+01.2345,-00.0120\r")])
    r1, r2 = KeyenceLKG(link).read_both()
    link.assert_done()
    assert (r1.value_mm, r2.value_mm) == (1.2345, -0.012)


def test_driver_mode_and_reset_commands() -> None:
    link = ExpectedProtocol([(b"Q0\r", b"Q0\r"), (b"R0\r", b"R0\r"), (b"VR,0\r", b"VR\r"),
                             (b"VR,1\r", b"VR\r")])
    dev = KeyenceLKG(link)
    dev.enter_setup_mode()
    dev.enter_measure_mode()
    dev.reset()
    dev.reset(1)
    link.assert_done()


def test_driver_set_offset_learns_the_decimal_position() -> None:
    # 0.12345 mm shown with 5 decimals is 12345 counts of the last digit: "+012345".
    link = ExpectedProtocol([(b"SR,OF,01\r", b"SR,OF,01,+0.00000\r"), (b"Q0\r", b"Q0\r"),
                             (b"SW,OF,01,+012345\r", b"SW,OF\r"), (b"R0\r", b"R0\r"),
                             (b"SR,OF,01\r", b"SR,OF,01,+0.12345\r")])
    dev = KeyenceLKG(link)
    dev.set_offset(0.12345)
    assert dev.offset() == 0.12345
    link.assert_done()


def test_driver_returns_to_measure_mode_when_a_setting_is_refused() -> None:
    link = ExpectedProtocol([(b"Q0\r", b"Q0\r"), (b"SW,HB,02,7\r", b"ER,SW,22\r"), (b"R0\r", b"R0\r")])
    with pytest.raises(DeviceError) as info:
        KeyenceLKG(link).set_head_mode(2, 7)
    link.assert_done()
    assert info.value.code == "22" and info.value.text == "Invalid parameter error"


def test_driver_head_mode() -> None:
    link = ExpectedProtocol([(b"SR,HB,01\r", b"SR,HB,01,3\r")])
    assert KeyenceLKG(link).head_mode(1) == 3
    link.assert_done()


def test_driver_refuses_bad_configuration() -> None:
    with pytest.raises(ValueError):
        KeyenceLKG(ExpectedProtocol([]), output=3)
    with pytest.raises(ValueError):
        KeyenceLKG(ExpectedProtocol([]), series="LK-G9")
    assert KeyenceLKG(ExpectedProtocol([]), output=12, series="LK-G5000").output == 12


def test_driver_discards_stale_input_after_a_failure_only() -> None:
    link = ExpectedProtocol([(b"M1\r", b"M1,+01.2\xff45\r"), (b"M1\r", b"M1,+01.2345\r"),
                             (b"M1\r", b"ER,M1,01\r"), (b"M1\r", b"M1,+01.2345\r")])
    dev = KeyenceLKG(link)
    discards = []
    link.discard_input = lambda: discards.append(1)  # type: ignore[method-assign]
    with pytest.raises(ProtocolError):
        dev.read_once()
    assert dev.read_once().value_mm == 1.2345 and len(discards) == 1
    with pytest.raises(DeviceError):
        dev.read_once()  # a well-formed error keeps the line in step
    dev.read_once()
    assert len(discards) == 1
    link.assert_done()


def test_driver_timeout_is_typed() -> None:
    link = ExpectedProtocol([(b"M1\r", None)])
    with pytest.raises(TransportTimeout):
        KeyenceLKG(link).read_once()
    link.assert_done()
