"""Strength tests of the Panasonic HL-G1 codec (issue 28): boundaries, defaults and the user-facing messages.

Wire bytes come from the frame grammar of protocols.md section 1.5; BCCs from :func:`xor_bcc`
(tests/drivers/hlg1_bcc.py, the documented XOR rule) or worked out by hand in the comments,
never from :func:`drivers.panasonic_hlg1.protocol.bcc`.
"""

from __future__ import annotations

import math
import re

import pytest

from drivers.errors import ChecksumError, DeviceError, ProtocolError
from drivers.panasonic_hlg1 import PanasonicHLG1
from drivers.panasonic_hlg1 import protocol as p
from tests.drivers.hlg1_bcc import framed, xor_bcc
from tests.protocol_fakes import ExpectedProtocol


# BCC -------------------------------------------------------------------------------------------------
def test_bcc_of_nothing_is_zero_and_of_one_byte_is_that_byte() -> None:
    # XOR over an empty sequence is the identity element 0; over one byte it is that byte ('%' = 0x25).
    assert p.bcc(b"") == b"00"
    assert p.bcc(b"%") == b"25"
    # '%' 0x25 ^ '0' 0x30 ^ '1' 0x31 ^ '#' 0x23 = 0x27; ^ 'R' 0x52 ^ 'M' 0x4D ^ 'D' 0x44 = 0x5C (the manual's 5C)
    assert p.bcc(b"%01#RMD") == b"5C"


# Request encoding: refusals name the problem ---------------------------------------------------------
@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda: p.encode_request(0, "RMD"), "station number must be 1..16, not 0"),
        (lambda: p.encode_request(17, "RMD"), "station number must be 1..16, not 17"),
        (lambda: p.encode_request(1, "rmd"), "command must be 3 upper-case letters, not 'rmd'"),
        (lambda: p.encode_request(1, "WZS", "+1\r"), "data must be printable ASCII, not '+1\\r'"),
        (lambda: p.encode_request(1, "WZS", "+0000\u00b5"), "data must be printable ASCII"),
        (lambda: p.format_setting(100_000), "setting 100000 does not fit in 5 digits"),
        (lambda: p.format_setting(-100_000), "setting -100000 does not fit in 5 digits"),
        (lambda: p.format_measured(950.0001), "value 950.0001 mm is outside +-950 mm"),
        (lambda: p.format_measured(-950.0001), "value -950.0001 mm is outside +-950 mm"),
    ],
)
def test_refused_requests_say_why(call, words: str) -> None:  # noqa: ANN001
    with pytest.raises(ValueError, match=re.escape(words)):
        call()


@pytest.mark.parametrize("value_mm", [math.inf, -math.inf, math.nan])
def test_non_finite_threshold_is_refused_with_a_value_error(value_mm: float) -> None:
    # round(inf) raised a bare OverflowError ("cannot convert float infinity to integer"), not a ValueError.
    with pytest.raises(ValueError, match="HL-G1 value .* mm is not a finite number"):
        p.format_measured(value_mm)
    link = ExpectedProtocol([])
    with pytest.raises(ValueError, match="not a finite number"):
        PanasonicHLG1(link, use_bcc=False).set_threshold_a(value_mm)
    link.assert_done()  # nothing was sent


# Setting / measured formatting at the limits ---------------------------------------------------------
@pytest.mark.parametrize(
    ("value", "data"),
    [(0, "+00000"), (1, "+00001"), (-1, "-00001"), (99_999, "+99999"), (-99_999, "-99999"), (-4095, "-04095")],
)
def test_setting_is_a_sign_and_five_digits(value: int, data: str) -> None:
    assert p.format_setting(value) == data
    assert p.encode_request(1, "WAV", data, use_bcc=False) == f"%01#WAV{data}**\r".encode()


@pytest.mark.parametrize(
    ("value_mm", "data"),
    [
        (0.0, "+0000000"),  # zero carries '+' (sign + 7 digits), not '-'
        (-0.0, "+0000000"),
        (-0.00004, "+0000000"),  # rounds to 0 counts
        (0.0001, "+0000001"),
        (-0.0001, "-0000001"),
        (950.0, "+9500000"),  # the documented limit itself is a legal value (p.4-22)
        (-950.0, "-9500000"),
    ],
)
def test_measured_is_a_sign_and_seven_digits_of_0_1_um(value_mm: float, data: str) -> None:
    assert p.format_measured(value_mm) == data


def test_threshold_zero_and_limit_on_the_wire() -> None:
    link = ExpectedProtocol([(framed("%01#WHA+0000000"), framed("%01$WHA")),
                             (framed("%01#WHA-9500000"), framed("%01$WHA"))])
    dev = PanasonicHLG1(link)
    dev.set_threshold_a(0.0)
    dev.set_threshold_a(-950.0)
    link.assert_done()


# Parsing data blocks ---------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda: p.parse_setting("+0001"), "setting must be a sign and 5 digits, got '+0001'"),
        (lambda: p.parse_measured("0123456"), "measured value must be a sign and 7 digits, got '0123456'"),
        (lambda: p.parse_measured("+9500001"), "measured value '+9500001' is outside +-9500000 (950 mm)"),
        (lambda: p.parse_measured("-9500001"), "measured value '-9500001' is outside +-9500000 (950 mm)"),
    ],
)
def test_bad_data_blocks_say_why(call, words: str) -> None:  # noqa: ANN001
    with pytest.raises(ProtocolError, match=re.escape(words)):
        call()


def test_measured_limits_parse() -> None:
    assert p.parse_measured("-9500000") == -950.0
    assert p.parse_measured("+0000001") == 0.0001
    assert p.parse_setting("-00001") == -1


# Reply decoding: every refusal with its message ------------------------------------------------------
BCC_41 = b"%01$RMD-012345641\r"  # protocols.md: "same, with real BCC"


@pytest.mark.parametrize(
    ("frame", "error", "words"),
    [
        (b"%01$RMD-012345641", ProtocolError, "reply not terminated by CR"),
        (b"%01!4**\r", ProtocolError, "reply is not a '%' frame"),  # 8 bytes: shorter than any reply
        (framed("#01$RMD-0123456"), ProtocolError, "reply is not a '%' frame"),  # right BCC, wrong header
        (b"%01$RMD-01234\xb556**\r", ProtocolError, "non-ASCII bytes in HL-G1 reply"),
        (b"%01$RMD-01234\x0156**\r", ProtocolError, "control characters in HL-G1 reply"),
        (b"%01$RMD-0123456**\r", ProtocolError, "has no BCC although the request had one"),
        (b"%01$RMD-01234564G\r", ProtocolError, "reply BCC b'4G' is not two hex digits"),
        (b"%01$RMD-0123456\xfe\xff\r", ProtocolError, "reply BCC b'\\xfe\\xff' is not two hex digits"),
        (b"%01$RMD-012345642\r", ChecksumError, "reply BCC 42 != computed 41"),
        (framed("%02$RMD-0123456"), ProtocolError, "reply from station '02', expected 01"),
        (framed("%01!4X"), ProtocolError, "malformed HL-G1 error reply"),
        (framed("%01!123"), ProtocolError, "malformed HL-G1 error reply"),
        (framed("%01$RID-0123456"), ProtocolError, "does not answer 'RMD'"),
        (framed("%01#RMD-0123456"), ProtocolError, "does not answer 'RMD'"),
    ],
)
def test_bad_replies_say_why(frame: bytes, error: type[Exception], words: str) -> None:
    with pytest.raises(error, match=re.escape(words)):
        p.decode_reply(frame, 1, "RMD")


def test_short_percent_frame_is_refused_before_being_read_as_an_error_reply() -> None:
    # Without the length check this 8-byte frame would reach the '!' branch ("malformed ... error reply").
    with pytest.raises(ProtocolError, match="is not a '%' frame"):
        p.decode_reply(b"%01!4**\r", 1, "RMD", require_bcc=False)


def test_unknown_device_error_code() -> None:
    with pytest.raises(DeviceError, match="device reported error 99 to 'RMD': unknown error code") as info:
        p.decode_reply(framed("%01!99"), 1, "RMD")
    assert info.value.code == "99" and info.value.text == "unknown error code"


# Every decoder requires a BCC by default and honours require_bcc=False ------------------------------
NO_BCC_REPLIES = [
    (lambda f, **kw: p.decode_reply(f, 1, "RMD", **kw), b"%01$RMD-0123456**\r", "-0123456"),
    (lambda f, **kw: p.decode_measured(f, 1, **kw), b"%01$RMD-0123456**\r", -12.3456),
    (lambda f, **kw: p.decode_ack(f, 1, "WZS", **kw), b"%01$WZS**\r", None),
    (lambda f, **kw: p.decode_setting(f, 1, "RSP", **kw), b"%01$RSP+00001**\r", 1),
    (lambda f, **kw: p.decode_flag(f, 1, "ROA", **kw), b"%01$ROA+00001**\r", True),
    (lambda f, **kw: p.decode_all_outputs(f, 1, **kw), b"%01$RMB+002500005670100**\r",
     p.AllOutputs(value_mm=2.5, light_intensity=567, out1=False, out2=True, out3=False, alarm=False)),
]


@pytest.mark.parametrize(("decode", "frame", "expected"), NO_BCC_REPLIES)
def test_decoders_refuse_a_missing_bcc_by_default(decode, frame: bytes, expected: object) -> None:  # noqa: ANN001
    with pytest.raises(ProtocolError, match="has no BCC although the request had one"):
        decode(frame)
    with pytest.raises(ProtocolError, match="has no BCC although the request had one"):
        decode(frame, require_bcc=True)
    assert decode(frame, require_bcc=False) == expected


@pytest.mark.parametrize(("decode", "frame", "expected"), NO_BCC_REPLIES)
def test_decoders_accept_the_real_bcc_by_default(decode, frame: bytes, expected: object) -> None:  # noqa: ANN001
    body = frame[:-3].decode()
    assert decode((body + xor_bcc(body) + "\r").encode()) == expected


def test_rmd_with_real_bcc_literal() -> None:
    assert p.decode_reply(BCC_41, 1, "RMD") == "-0123456"


# Messages of the typed decoders ----------------------------------------------------------------------
def test_ack_with_data_says_so() -> None:
    with pytest.raises(ProtocolError, match=re.escape("reply to WZS carries unexpected data '+00001'")):
        p.decode_ack(framed("%01$WZS+00001"), 1, "WZS")


def test_flag_out_of_range_says_so() -> None:
    with pytest.raises(ProtocolError, match=re.escape("HL-G1 ROA must be +00000 or +00001")):
        p.decode_flag(framed("%01$ROA+00002"), 1, "ROA")


def test_rmb_with_bad_data_says_so() -> None:
    words = "RMB data must be value(8) light(4) and 4 flags, got '+0025000'"
    with pytest.raises(ProtocolError, match=re.escape(words)):
        p.decode_all_outputs(framed("%01$RMB+0025000"), 1)
