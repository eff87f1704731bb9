"""Keyence LK-G codec: the cases a mutation run found unchecked (issue 28).

Expected bytes are written out from protocols.md 1.1/1.2: a setting is "one character
and six-digit numerical value" without a decimal point (``+012345``); the LK-G5000
request is ``MS,<2-digit OUT no>``; a reply repeats its header and carries exactly the
documented fields.
"""

from __future__ import annotations

import pytest

from drivers.errors import ProtocolError
from drivers.keyence_lkg import KeyenceLKG
from drivers.keyence_lkg import protocol as p
from drivers.readings import MeasurementStatus
from tests.protocol_fakes import ExpectedProtocol


@pytest.mark.parametrize(
    ("counts", "field"),
    [(-123, "-000123"), (-1, "-000001"), (0, "+000000"), (1, "+000001"), (999_999, "+999999"),
     (-999_999, "-999999")],
)
def test_setting_sign_and_six_digits(counts: int, field: str) -> None:
    assert p.format_setting(counts) == field
    assert p.encode_write_offset(1, counts) == b"SW,OF,01," + field.encode() + b"\r"


@pytest.mark.parametrize("counts", [1_000_000, -1_000_000])
def test_setting_of_seven_digits_refused(counts: int) -> None:
    with pytest.raises(ValueError, match="6 digits"):
        p.format_setting(counts)


@pytest.mark.parametrize("output", [1, 2, 3, 9, 10, 42, 99])
def test_lkg5000_outputs_1_to_99(output: int) -> None:
    wire = f"MS,{output // 10}{output % 10}\r".encode()  # two digits, written out
    assert p.encode_measure_ms(output) == wire
    reply = wire[:-1] + b",+000.260\r"
    assert p.decode_measure_ms(reply, output) == (0.26, MeasurementStatus.OK)


@pytest.mark.parametrize("output", [-1, 0, 100])
def test_lkg5000_outputs_outside_1_to_99_refused(output: int) -> None:
    with pytest.raises(ValueError, match="1..99"):
        p.encode_measure_ms(output)


@pytest.mark.parametrize("output", [0, 3])
def test_lkg3000_settings_name_outputs_1_and_2_only(output: int) -> None:
    for call in (p.encode_read_offset, p.encode_read_head_mode):
        with pytest.raises(ValueError, match="1..2"):
            call(output)


@pytest.mark.parametrize(
    ("field", "value", "decimals"),
    [("+0000123", 123.0, 0), ("-0000123", -123.0, 0), ("+12345.6", 12345.6, 1), ("+01.2345", 1.2345, 4),
     ("+.123456", 0.123456, 6), ("+000123.", 123.0, 0)],
)
def test_decimals_of_a_field(field: str, value: float, decimals: int) -> None:
    assert p.parse_value(field) == (value, MeasurementStatus.OK)
    assert p.decimals_of(field) == decimals
    assert p.decode_read_offset(f"SR,OF,01,{field}\r".encode(), 1) == (value, decimals)


def test_offset_without_a_decimal_point_is_written_in_units() -> None:
    """An offset shown without a decimal point: 5 mm is 5 counts, not 50."""
    link = ExpectedProtocol([(b"SR,OF,02\r", b"SR,OF,02,+0000000\r"), (b"Q0\r", b"Q0\r"),
                             (b"SW,OF,02,-000005\r", b"SW,OF\r"), (b"R0\r", b"R0\r")])
    KeyenceLKG(link, output=2).set_offset(-5.0)
    link.assert_done()


def test_negative_offset_keeps_its_sign_on_the_wire() -> None:
    # -0.0123 mm shown with 4 decimals is -123 counts of the last digit
    link = ExpectedProtocol([(b"SR,OF,01\r", b"SR,OF,01,-00.0001\r"), (b"Q0\r", b"Q0\r"),
                             (b"SW,OF,01,-000123\r", b"SW,OF\r"), (b"R0\r", b"R0\r")])
    KeyenceLKG(link).set_offset(-0.0123)
    link.assert_done()


@pytest.mark.parametrize("frame", [b"SR,HB,01,5,6\r", b"SR,HB,01\r", b"SR,HB,01,\r", b"SR,HB,01,123\r",
                                   b"SR,HB,01,+5\r", b"SR,HB,02,5\r"])
def test_head_mode_reply_needs_exactly_one_function_number(frame: bytes) -> None:
    with pytest.raises(ProtocolError):
        p.decode_read_head_mode(frame, 1)


@pytest.mark.parametrize(("frame", "fn"), [(b"SR,HB,01,0\r", 0), (b"SR,HB,01,7\r", 7), (b"SR,HB,01,99\r", 99)])
def test_head_mode_reply(frame: bytes, fn: int) -> None:
    assert p.decode_read_head_mode(frame, 1) == fn


@pytest.mark.parametrize("frame", [b"SR,OF,01,+01.2345,+01.2345\r", b"SR,OF,01\r", b"MS,01\r",
                                   b"MS,01,+000.260,+000.260\r", b"M1,+01.2345,+01.2345\r", b"SW,OF,01\r"])
def test_replies_with_a_wrong_field_count_refused(frame: bytes) -> None:
    decode = {b"SR": lambda f: p.decode_read_offset(f, 1), b"MS": lambda f: p.decode_measure_ms(f, 1),
              b"M1": lambda f: p.decode_measure(f, 1), b"SW": lambda f: p.decode_ack(f, "SW,OF")}[frame[:2]]
    with pytest.raises(ProtocolError):
        decode(frame)


@pytest.mark.parametrize("function", [-1, 100])
def test_head_mode_outside_0_to_99_refused(function: int) -> None:
    with pytest.raises(ValueError, match="0..99"):
        p.encode_write_head_mode(1, function)


def test_head_mode_bounds_accepted() -> None:
    assert p.encode_write_head_mode(2, 0) == b"SW,HB,02,0\r"
    assert p.encode_write_head_mode(1, 99) == b"SW,HB,01,99\r"
