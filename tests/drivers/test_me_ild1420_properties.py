"""Property tests of the ILD1420 decoders: random and mutated byte streams give
typed errors only, and no value is ever made from a broken frame."""

from __future__ import annotations

import contextlib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.errors import DriverError
from drivers.me_ild1420 import ILD1420
from drivers.me_ild1420 import protocol as p
from tests.drivers.ild1420_vectors import GETINFO_REPLY, ExpectedStream, frame

SETTINGS = settings(max_examples=200, deadline=None)


def naive_frames(data: bytes) -> list[int]:
    """Left-to-right scan: three bytes with flags 00, 01, 1x form a value; else skip one byte."""
    out, i = [], 0
    while i + 2 < len(data):
        a, b, c = data[i], data[i + 1], data[i + 2]
        if a >> 6 == 0 and b >> 6 == 1 and c >> 6 >= 2:
            out.append((a & 63) | (b & 63) << 6 | (c & 63) << 12)
            i += 3
        else:
            i += 1
    return out


def chunked(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({min(c, len(data)) for c in cuts})
    edges = [0, *points, len(data)]
    return [data[a:b] for a, b in zip(edges, edges[1:], strict=False)]


@SETTINGS
@given(st.binary(max_size=300), st.lists(st.integers(0, 300), max_size=6))
def test_random_bytes_decode_only_flag_valid_triples(data: bytes, cuts: list[int]) -> None:
    dec = p.FrameDecoder()
    got: list[int] = []
    for chunk in chunked(data, cuts):
        raw, _ = dec.feed(chunk)
        got += raw.tolist()
    dec.flush()
    assert got == naive_frames(data)
    assert dec.frames_ok * 3 + dec.bytes_discarded == len(data)


# Damage that breaks the flag sequence (detectable without a checksum), per frame:
# (name, function of the frame's 3 bytes -> damaged bytes, frames lost)
MUTATIONS = [
    ("drop L", lambda f: f[1:], 1),
    ("drop M", lambda f: f[:1] + f[2:], 1),
    ("drop H", lambda f: f[:2], 1),
    ("H-flag byte after L", lambda f: f[:1] + b"\xd5" + f[1:], 1),
    ("M-flag byte after L", lambda f: f[:1] + b"\x6a" + f[1:], 1),
    ("M-flag byte after M", lambda f: f[:2] + b"\x55" + f[2:], 1),
    ("L-flag byte after M", lambda f: f[:2] + b"\x2a" + f[2:], 1),
    ("bit 7 of L set", lambda f: bytes([f[0] | 0x80]) + f[1:], 1),
    ("bit 6 of L set", lambda f: bytes([f[0] | 0x40]) + f[1:], 1),
    ("bit 7 of M set", lambda f: f[:1] + bytes([f[1] | 0x80]) + f[2:], 1),
    ("bit 6 of M cleared", lambda f: f[:1] + bytes([f[1] & 0xBF]) + f[2:], 1),
    ("bit 7 of H cleared", lambda f: f[:2] + bytes([f[2] & 0x7F]), 1),
    ("stray byte after the frame", lambda f: f + b"\xaa", 0),
]


@st.composite
def damaged_streams(draw):
    values = draw(st.lists(st.integers(0, (1 << 18) - 1), min_size=1, max_size=40))
    damaged: dict[int, int] = {}
    for k in range(len(values)):
        if k - 1 not in damaged and draw(st.integers(0, 3)) == 0:  # isolated damage
            damaged[k] = draw(st.integers(0, len(MUTATIONS) - 1))
    cuts = draw(st.lists(st.integers(0, 200), max_size=6))
    return values, damaged, cuts


@SETTINGS
@given(damaged_streams())
def test_damaged_frames_are_never_decoded_and_counted_exactly(case) -> None:
    values, damaged, cuts = case
    wire = b"".join(MUTATIONS[damaged[k]][1](frame(v)) if k in damaged else frame(v)
                    for k, v in enumerate(values))
    dec = p.FrameDecoder()
    got: list[int] = []
    for chunk in chunked(wire, cuts):
        raw, _ = dec.feed(chunk)
        got += raw.tolist()
    dec.flush()
    survivors = [v for k, v in enumerate(values) if k not in damaged or MUTATIONS[damaged[k]][2] == 0]
    assert got == survivors
    assert dec.frames_lost == sum(MUTATIONS[m][2] for m in damaged.values())
    assert dec.resyncs == len(damaged)


REPLIES = [GETINFO_REPLY, b"OUTPUT RS422\r\n->", b"\r\n->", b"E104 Timeout\r\n->", b"MEASRATE 2\r\n->"]


@SETTINGS
@given(st.sampled_from(REPLIES), st.data())
def test_mutated_replies_raise_only_typed_errors(reply: bytes, data) -> None:
    i = data.draw(st.integers(0, len(reply) - 1))
    kind = data.draw(st.sampled_from(["flip", "drop", "insert", "truncate"]))
    byte = data.draw(st.integers(0, 255))
    if kind == "flip":
        wire = reply[:i] + bytes([reply[i] ^ (1 << (byte % 8))]) + reply[i + 1:]
    elif kind == "drop":
        wire = reply[:i] + reply[i + 1:]
    elif kind == "insert":
        wire = reply[:i] + bytes([byte]) + reply[i:]
    else:
        wire = reply[:i]
    for command, decoder in [(b"GETINFO\r", p.decode_getinfo), (b"OUTPUT\r", p.decode_output),
                             (b"MEASRATE\r", p.decode_measrate), (b"OUTPUT NONE\r", None)]:
        with contextlib.suppress(DriverError):
            parsed = p.parse_reply(wire, command)
            if decoder is None:
                p.expect_no_lines(parsed, "OUTPUT")
            else:
                decoder(parsed)
    if kind == "flip" and byte % 8 == 7:  # bit 7 set in an ASCII reply: never accepted
        try:
            p.parse_reply(wire, b"GETINFO\r")
        except DriverError:
            pass
        else:
            raise AssertionError(f"accepted a reply with a corrupt byte: {wire!r}")


@SETTINGS
@given(st.binary(max_size=200))
def test_driver_on_random_bytes_raises_only_driver_errors(noise: bytes) -> None:
    for reply in (noise, noise + b"->", noise + b"\r\n->"):
        dev = ILD1420(ExpectedStream([(b"GETINFO\r", reply)]), timeout_s=0.01)
        with contextlib.suppress(DriverError):
            assert "model" in dev.identify()
        dev = ILD1420(ExpectedStream([(None, reply)]), timeout_s=0.01)
        try:
            reading = dev.read_once()
        except DriverError:
            continue
        assert int(reading.raw) in naive_frames(reply)


@pytest.mark.soak
@settings(max_examples=20000, deadline=None)
@given(damaged_streams())
def test_damaged_frames_soak(case) -> None:
    test_damaged_frames_are_never_decoded_and_counted_exactly.hypothesis.inner_test(case)
