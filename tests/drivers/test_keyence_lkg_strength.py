"""Keyence LK-G codec: the cases a mutation run found unchecked (issue 28).

Expected bytes are written out from protocols.md 1.1/1.2: a setting is "one character
and six-digit numerical value" without a decimal point (``+012345``); the LK-G5000
request is ``MS,<2-digit OUT no>``; a reply repeats its header and carries exactly the
documented fields.
"""

from __future__ import annotations

import pytest

from drivers.errors import DeviceError, ProtocolError
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


# Refusals name the problem (issue 28): the key words of each message are part of the contract --------
@pytest.mark.parametrize(
    ("call", "words"),
    [(lambda: p.encode("M1\r"), "not a valid LK-G command"), (lambda: p.encode("M\u00b51"), "not a valid LK-G command"),
     (lambda: p.encode_measure(3), r"must be 0 \(both\), 1 or 2, not 3"),
     (lambda: p.encode_reset(-1), r"reset output must be 0 \(both\), 1 or 2, not -1")],
)
def test_refused_requests_say_why(call, words: str) -> None:  # noqa: ANN001
    with pytest.raises(ValueError, match=words):
        call()


@pytest.mark.parametrize(
    ("field", "words"),
    [("+1.2345", "must be 8 characters"), ("+01.23456", "must be 8 characters"),
     ("+0A.2345", "malformed LK-G value field"), ("+01.23.4", "malformed LK-G value field"),
     ("+.......", "malformed LK-G value field"), ("01.23456", "malformed LK-G value field")],
)
def test_bad_value_fields_say_why(field: str, words: str) -> None:
    with pytest.raises(ProtocolError, match=words):
        p.parse_value(field)


@pytest.mark.parametrize(
    ("frame", "decode", "words"),
    [(b"M1,+01.2345", lambda f: p.decode_measure(f, 1), "not terminated by CR"),
     (b"M1,+01.2\xff45\r", lambda f: p.decode_measure(f, 1), "non-ASCII"),
     # one CR inside the frame (no LF) and one LF inside (no CR) are each a stray line break
     (b"M1,+01.2345\r\r", lambda f: p.decode_measure(f, 1), "stray line break"),
     (b"Q0\r\r", lambda f: p.decode_ack(f, "Q0"), "stray line break"),
     (b"M1,+01.2345\n\r", lambda f: p.decode_measure(f, 1), "stray line break"),
     (b"R0\n\r", lambda f: p.decode_ack(f, "R0"), "stray line break"),
     (b"ER,M1\r", lambda f: p.decode_measure(f, 1), "malformed LK-G error reply"),
     (b"ER,M2,00\r", lambda f: p.decode_measure(f, 1), "malformed LK-G error reply"),
     (b"M2,+01.2345\r", lambda f: p.decode_measure(f, 1), "does not answer 'M1'"),
     (b"M1\r", lambda f: p.decode_measure(f, 1), r"M1 reply needs 1 value"),
     (b"M0,+01.2345\r", lambda f: p.decode_measure(f, 0), r"M0 reply needs 2 value"),
     (b"MS,01\r", lambda f: p.decode_measure_ms(f, 1), "MS reply needs one value"),
     (b"SW,OF,01\r", lambda f: p.decode_ack(f, "SW,OF"), "'SW,OF' has unexpected fields"),
     (b"SR,OF,01\r", lambda f: p.decode_read_offset(f, 1), "SR,OF reply needs one value"),
     (b"SR,OF,01,--------\r", lambda f: p.decode_read_offset(f, 1), "offset is not a number"),
     (b"SR,HB,01,+5\r", lambda f: p.decode_read_head_mode(f, 1), "needs one function number")],
)
def test_bad_replies_say_why(frame: bytes, decode, words: str) -> None:  # noqa: ANN001
    with pytest.raises(ProtocolError, match=words):
        decode(frame)


def test_error_code_outside_the_manual_list_is_reported_as_unknown() -> None:
    """The manual lists 00/01/20/21/22/88/99; another two-digit code is still the device's error."""
    with pytest.raises(DeviceError) as info:
        p.decode_measure(b"ER,M1,42\r", 1)
    assert (info.value.code, info.value.text, info.value.command) == ("42", "unknown error code", "M1")
    assert "error 42" in str(info.value)
