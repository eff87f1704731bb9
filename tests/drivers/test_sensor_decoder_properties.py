"""Property tests of the sensor decoders: random and mutated byte streams
raise only typed :class:`DriverError` subclasses and never yield a value
that the frame does not carry.

HL-G1 frames carry a BCC, so any one-byte change of a BCC-checked frame must
raise (the only harmless change is the letter case of a hex BCC digit).  LK-G
frames carry no checksum: a digit changed on the wire is a different valid
frame, so there the property is differential - the decoder returns exactly
what an independent reading of the (mutated) frame says, or raises when that
reading rejects it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from decimal import Decimal
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.errors import DriverError
from drivers.keyence_lkg import protocol as lkg
from drivers.panasonic_hlg1 import protocol as hlg
from drivers.readings import MeasurementStatus
from tests.drivers.hlg1_bcc import xor_bcc

EXAMPLES = settings(max_examples=200, deadline=None)

LKG_DECODERS: dict[str, Callable[[bytes], Any]] = {
    "M0": lambda f: lkg.decode_measure(f, 0),
    "M1": lambda f: lkg.decode_measure(f, 1),
    "M2": lambda f: lkg.decode_measure(f, 2),
    "MS": lambda f: lkg.decode_measure_ms(f, 1),
    "Q0": lambda f: lkg.decode_ack(f, "Q0"),
    "SW,OF": lambda f: lkg.decode_ack(f, "SW,OF"),
    "SR,OF": lambda f: lkg.decode_read_offset(f, 1),
    "SR,HB": lambda f: lkg.decode_read_head_mode(f, 1),
}
HLG_DECODERS: dict[str, Callable[[bytes, bool], Any]] = {
    "reply": lambda f, b: hlg.decode_reply(f, 1, "RMD", require_bcc=b),
    "RMD": lambda f, b: hlg.decode_measured(f, 1, require_bcc=b),
    "RID": lambda f, b: hlg.decode_setting(f, 1, "RID", require_bcc=b),
    "ROA": lambda f, b: hlg.decode_flag(f, 1, "ROA", require_bcc=b),
    "RMB": lambda f, b: hlg.decode_all_outputs(f, 1, require_bcc=b),
    "WZS": lambda f, b: hlg.decode_ack(f, 1, "WZS", require_bcc=b),
}


def outcome(decode: Callable[[], Any]) -> tuple[str, Any]:
    """("value", v) or ("error", type); any non-DriverError propagates and fails the test."""
    try:
        return "value", decode()
    except DriverError as exc:
        return "error", type(exc)


# Random streams -------------------------------------------------------------------------------------
lkg_like = st.text(alphabet="MSQRVEOFHBW0129.,+-X\r\n", max_size=30).map(lambda t: (t + "\r").encode())
hlg_like = st.builds(
    lambda st_, kind, cmd, data, check: f"%{st_}{kind}{cmd}{data}{check}\r".encode("latin-1"),
    st.sampled_from(["01", "02", "1A", "0", ""]),
    st.sampled_from(["$", "!", "#", "%"]),
    st.sampled_from(["RMD", "RID", "ROA", "RMB", "WZS", "04", "", "RM"]),
    st.text(alphabet="+-0123456789 *\xff", max_size=24),
    st.sampled_from(["**", "5C", "zz", "", "0"]),
)


@EXAMPLES
@given(frame=st.one_of(st.binary(max_size=40), lkg_like), name=st.sampled_from(sorted(LKG_DECODERS)))
def test_lkg_decoders_raise_only_typed_errors(frame: bytes, name: str) -> None:
    outcome(lambda: LKG_DECODERS[name](frame))


@EXAMPLES
@given(field=st.text(max_size=10))
def test_lkg_value_field_raises_only_typed_errors(field: str) -> None:
    outcome(lambda: lkg.parse_value(field))


@EXAMPLES
@given(frame=st.one_of(st.binary(max_size=40), hlg_like), name=st.sampled_from(sorted(HLG_DECODERS)),
       require_bcc=st.booleans())
def test_hlg_decoders_raise_only_typed_errors(frame: bytes, name: str, require_bcc: bool) -> None:
    outcome(lambda: HLG_DECODERS[name](frame, require_bcc))


@EXAMPLES
@given(frame=hlg_like)
def test_hlg_random_frame_with_its_right_bcc_still_checks_structure(frame: bytes) -> None:
    body = frame[:-1].decode("latin-1").rstrip("*")
    outcome(lambda: hlg.decode_all_outputs((body + xor_bcc(body) + "\r").encode("latin-1"), 1))


# One-byte mutations of valid HL-G1 frames -----------------------------------------------------------
@st.composite
def hlg_valid(draw: st.DrawFn) -> tuple[bytes, str, Any]:
    """A valid BCC-checked reply from station 1 and the value it carries (computed here)."""
    kind = draw(st.sampled_from(["RMD", "RMB", "RID"]))
    counts = draw(st.integers(-9_500_000, 9_500_000))
    sign = "-" if counts < 0 else "+"
    value = f"{sign}{abs(counts):07d}"
    mm = float(Decimal(counts) / Decimal(10_000))
    if kind == "RMD":
        data, expected = value, mm
    elif kind == "RID":
        light = draw(st.integers(0, 4095))
        data, expected = f"+{light:05d}", light
    else:
        light = draw(st.integers(0, 4095))
        flags = draw(st.lists(st.booleans(), min_size=4, max_size=4))
        data = value + f"{light:04d}" + "".join("1" if f else "0" for f in flags)
        expected = hlg.AllOutputs(mm, light, *flags)
    body = f"%01${kind}{data}"
    return (body + xor_bcc(body) + "\r").encode(), kind, expected


@EXAMPLES
@given(valid=hlg_valid(), position=st.integers(min_value=0), new=st.integers(0, 255))
def test_hlg_one_byte_mutation_never_yields_a_wrong_value(valid: tuple[bytes, str, Any], position: int,
                                                          new: int) -> None:
    frame, kind, expected = valid
    assert HLG_DECODERS[kind](frame, True) == expected  # the unmutated frame decodes to its value
    i = position % len(frame)
    if new == frame[i]:
        new ^= 0x01
    mutated = frame[:i] + bytes([new]) + frame[i + 1:]
    for require_bcc in (True, False):
        result = outcome(lambda b=require_bcc: HLG_DECODERS[kind](mutated, b))
        if result[0] == "value":
            bcc_case_only = i in (len(frame) - 3, len(frame) - 2) and chr(new).upper() == chr(frame[i]).upper()
            assert bcc_case_only and result[1] == expected


# One-byte mutations of LK-G frames: differential against an independent reading ---------------------
SPECIAL = {"+FFFFFFF": MeasurementStatus.OVER_RANGE_HIGH, "-FFFFFFF": MeasurementStatus.OVER_RANGE_LOW,
           "XXXXXXXX": MeasurementStatus.ALARM, "--------": MeasurementStatus.NO_VALUE}


def read_m1(frame: bytes) -> tuple[float, MeasurementStatus] | None:
    """What an ``M1`` reply says by the manual's format, or None if it is not one."""
    if not frame.endswith(b"\r") or any(b < 0x20 or b > 0x7E for b in frame[:-1]):
        return None
    parts = frame[:-1].decode().split(",")
    if len(parts) != 2 or parts[0].upper() != "M1" or len(parts[1]) != 8:
        return None
    field = parts[1]
    if field.upper() in SPECIAL:
        return math.nan, SPECIAL[field.upper()]
    body = field[1:]
    if field[0] not in "+-" or set(body) - set("0123456789.") or body.count(".") > 1 or body == ".":
        return None
    return float(Decimal(field)), MeasurementStatus.OK


@st.composite
def lkg_valid(draw: st.DrawFn) -> bytes:
    if draw(st.booleans()):
        field = draw(st.sampled_from(sorted(SPECIAL)))
    else:
        decimals = draw(st.integers(0, 6))
        digits = draw(st.text(alphabet="0123456789", min_size=7 if decimals == 0 else 6,
                              max_size=7 if decimals == 0 else 6))
        body = digits if decimals == 0 else digits[: 6 - decimals] + "." + digits[6 - decimals:]
        field = draw(st.sampled_from("+-")) + body
    return f"M1,{field}\r".encode()


@EXAMPLES
@given(frame=lkg_valid(), position=st.integers(min_value=0), new=st.integers(0, 255))
def test_lkg_one_byte_mutation_decodes_to_what_the_frame_says(frame: bytes, position: int, new: int) -> None:
    i = position % len(frame)
    mutated = frame[:i] + bytes([new]) + frame[i + 1:]
    said = read_m1(mutated)
    result = outcome(lambda: lkg.decode_measure(mutated, 1))
    if said is None:
        assert result[0] == "error"
    else:
        assert result[0] == "value"
        ((value, status),) = result[1]
        assert status is said[1]
        assert (math.isnan(value) and math.isnan(said[0])) or value == said[0]


def test_the_reference_reading_agrees_with_the_manual_table() -> None:
    assert read_m1(b"M1,+01.2345\r") == (1.2345, MeasurementStatus.OK)
    assert read_m1(b"M1,-00001.2\r") == (-1.2, MeasurementStatus.OK)
    assert read_m1(b"M1,+1234.56\r") == (1234.56, MeasurementStatus.OK)
    assert read_m1(b"M1,+01.2345,\r") is None
    assert read_m1(b"M1,+0000000\r") == (0.0, MeasurementStatus.OK)
    assert read_m1(b"M1,+..12345\r") is None
