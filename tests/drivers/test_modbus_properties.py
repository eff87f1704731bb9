"""Property tests of the Modbus decoding paths.

* Random register blocks through the controller codec: only typed errors, and
  a non-finite value is never returned unflagged (``InterferometerReading.ok``).
* Random and mutated RTU reply bytes answered by a raw pty peer to the real
  driver path (pymodbus's RTU framer in ``ModbusSerialClient``): the outcome
  is a decoded status or a :class:`DriverError`, never anything else.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivers.environment.xymd02 import decode_temp_humidity
from drivers.errors import DriverError, ProtocolError
from drivers.interferometer import InterferometerController, load_register_map
from drivers.interferometer.codec import decode_block, decode_status
from drivers.interferometer.controller import CHANNELS, ENVIRONMENT
from drivers.modbus_link import rtu_crc
from drivers.readings import ControllerStatus, InterferometerReading
from mocks.serial_endpoints import PtyEndpoint

REGMAP = load_register_map()
DATA_START, DATA_COUNT = REGMAP.span("position_mm", "material_temp_c")
reg16 = st.integers(0, 0xFFFF)


@settings(max_examples=100, deadline=None)
@given(regs=st.lists(reg16, min_size=DATA_COUNT, max_size=DATA_COUNT),
       word_order=st.sampled_from(["ABCD", "CDAB"]),
       status=reg16, seq=reg16, err=reg16)
def test_random_data_block_decodes_and_non_finite_is_flagged(
    regs: list[int], word_order: str, status: int, seq: int, err: int
) -> None:
    values = decode_block(regs, DATA_START, CHANNELS + ENVIRONMENT, REGMAP, word_order)
    reading = InterferometerReading(**values, sequence=seq, status=decode_status(status, seq, err, REGMAP),
                                    timestamp_s=0.0)
    if not all(math.isfinite(v) for v in values.values()):
        assert not reading.ok


@settings(max_examples=100, deadline=None)
@given(regs=st.lists(st.integers(-70000, 140000), max_size=40), start=st.integers(90, 110),
       word_order=st.sampled_from(["ABCD", "CDAB"]))
def test_malformed_blocks_raise_only_protocol_errors(regs: list[int], start: int, word_order: str) -> None:
    try:
        values = decode_block(regs, start, CHANNELS + ENVIRONMENT, REGMAP, word_order)
    except ProtocolError:
        return
    assert values.keys() == set(CHANNELS + ENVIRONMENT)
    assert all(0 <= r <= 0xFFFF for r in regs)


@settings(max_examples=100, deadline=None)
@given(status=reg16, seq=reg16, err=reg16)
def test_status_word_flags_follow_the_bits(status: int, seq: int, err: int) -> None:
    s = decode_status(status, seq, err, REGMAP)
    assert (s.ready, s.busy, s.data_valid, s.error, s.beam_ok) == tuple(bool(status & m) for m in (1, 2, 4, 8, 16))
    assert (s.sequence, s.error_code, s.raw_status) == (seq, err, status)
    assert bool(s.error_text) == (err != 0)


@settings(max_examples=100, deadline=None)
@given(t=reg16, rh=reg16)
def test_xymd02_decoding_is_total_on_16_bit_registers(t: int, rh: int) -> None:
    temp_c, rh_pct = decode_temp_humidity([t, rh])
    signed = t - 65536 if t >= 32768 else t
    assert round(temp_c * 10) == signed and round(rh_pct * 10) == rh


# -- fuzzed RTU replies through the driver -----------------------------------------------------
REQUEST = bytes.fromhex("01 03 00 01 00 03") + rtu_crc(bytes.fromhex("01 03 00 01 00 03")).to_bytes(2, "little")
GOOD_BODY = bytes.fromhex("01 03 06 00 15 00 07 00 00")  # status ready|data valid|beam OK, sequence 7


def with_crc(body: bytes) -> bytes:
    return body + rtu_crc(body).to_bytes(2, "little")


class FuzzPeer:
    """Answers every request with whatever the test put in :attr:`reply`."""

    def __init__(self) -> None:
        self.reply = b""

    def receive(self, data: bytes) -> bytes:
        return self.reply


@st.composite
def rtu_replies(draw: st.DrawFn) -> bytes:
    good = with_crc(GOOD_BODY)
    kind = draw(st.sampled_from(["random", "flip", "truncate", "body+crc", "extend"]))
    if kind == "random":
        return draw(st.binary(max_size=40))
    if kind == "flip":
        frame = bytearray(good)
        for pos in draw(st.lists(st.integers(0, len(frame) - 1), min_size=1, max_size=3)):
            frame[pos] ^= 1 << draw(st.integers(0, 7))
        return bytes(frame)
    if kind == "truncate":
        return good[: draw(st.integers(0, len(good) - 1))]
    if kind == "extend":
        return good + draw(st.binary(min_size=1, max_size=10))
    # A valid CRC around a mutated body: the framer accepts it, the PDU decoder must cope.
    body = bytes([1, draw(st.sampled_from([3, 0x83, 4, 6, 0x2B, draw(st.integers(0, 255))]))])
    return with_crc(body + draw(st.binary(max_size=12)))


@pytest.fixture(scope="module")
def fuzz_link() -> Iterator[tuple[FuzzPeer, InterferometerController]]:
    peer = FuzzPeer()
    endpoint = PtyEndpoint(peer, baudrate=115200)
    ctl = InterferometerController.from_url(f"modbus-rtu:{endpoint.path}?baud=115200&parity=N", timeout_s=0.03)
    yield peer, ctl
    ctl.close()
    endpoint.stop()


def check_fuzzed_reply(peer: FuzzPeer, ctl: InterferometerController, reply: bytes) -> None:
    peer.reply = reply
    try:
        status = ctl.read_status()
    except DriverError:
        return
    assert isinstance(status, ControllerStatus)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(reply=rtu_replies())
def test_fuzzed_rtu_replies_surface_only_as_typed_errors(fuzz_link, reply: bytes) -> None:
    check_fuzzed_reply(*fuzz_link, reply)


def test_fuzz_peer_answers_the_good_frame(fuzz_link) -> None:
    peer, ctl = fuzz_link
    peer.reply = with_crc(GOOD_BODY)
    status = ctl.read_status()
    assert (status.ready, status.data_valid, status.beam_ok, status.sequence) == (True, True, True, 7)


@pytest.mark.soak
@settings(max_examples=3000, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(reply=rtu_replies())
def test_fuzzed_rtu_replies_soak(fuzz_link, reply: bytes) -> None:
    check_fuzzed_reply(*fuzz_link, reply)
