"""Micro-Epsilon optoNCDT 1420 codec and driver against protocols.md section 1.6
(manual §8.2 binary format, A3.1 reply format, A3.3.2 GETINFO example, A3.4.6.2
MASTERMV, A3.5.1 OUTPUT).  Expected values are computed here from the manual's
bit table and scaling formula, never taken from the implementation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivers.errors import DeviceError, DriverError, ProtocolError, TransportTimeout
from drivers.me_ild1420 import ILD1420
from drivers.me_ild1420 import protocol as p
from drivers.readings import MeasurementStatus
from tests.drivers.ild1420_vectors import GETINFO_LINES, GETINFO_REPLY, ExpectedStream, frame, mm

# -- golden bytes: commands ----------------------------------------------------------------

@pytest.mark.parametrize(
    ("encode", "wire"),
    [
        (lambda: p.encode_getinfo(), b"GETINFO\r"),
        (lambda: p.encode_output(), b"OUTPUT\r"),
        (lambda: p.encode_output("NONE"), b"OUTPUT NONE\r"),
        (lambda: p.encode_output("rs422"), b"OUTPUT RS422\r"),
        (lambda: p.encode_output("ANALOG"), b"OUTPUT ANALOG\r"),
        (lambda: p.encode_echo(True), b"ECHO ON\r"),
        (lambda: p.encode_echo(False), b"ECHO OFF\r"),
        (lambda: p.encode_master(0.0, 10.0), b"MASTERMV MASTER 0.000000\r"),
        (lambda: p.encode_master(12.3456789, 10.0), b"MASTERMV MASTER 12.345679\r"),  # six decimals
        (lambda: p.encode_master_none(), b"MASTERMV NONE\r"),
        (lambda: p.encode_measrate(), b"MEASRATE\r"),
        (lambda: p.encode_measrate(2.0), b"MEASRATE 2\r"),
        (lambda: p.encode_measrate(0.25), b"MEASRATE 0.25\r"),
        (lambda: p.encode_command("PASSWD", "old pw", "x"), b'PASSWD "old pw" x\r'),  # spaces -> quotes
    ],
)
def test_commands_are_the_manual_bytes(encode, wire: bytes) -> None:
    # Encoded inside the test, not at collection, so that mutation testing sees the encoder's mutants.
    assert encode() == wire


@pytest.mark.parametrize(
    "bad",
    [lambda: p.encode_output("USB"), lambda: p.encode_master(-0.001, 10.0),
     lambda: p.encode_master(20.001, 10.0), lambda: p.encode_measrate(4.5), lambda: p.encode_measrate(0),
     lambda: p.encode_command("getinfo"), lambda: p.encode_command("X", 'a"b'),
     lambda: p.encode_command("X", "\r")],
)
def test_invalid_commands_are_refused_before_sending(bad) -> None:
    with pytest.raises(ValueError):
        bad()


# -- golden bytes: replies -----------------------------------------------------------------

def test_getinfo_example_of_the_manual() -> None:
    info = p.decode_getinfo(p.parse_reply(GETINFO_REPLY, b"GETINFO\r"))
    assert info["Name"] == "ILD1420-10" and info["Serial"] == "15030002"
    assert info["Measuring range"] == "10.00mm" and info["Boot-version"] == "001.000"
    assert p.parse_measuring_range_mm(info["Measuring range"]) == 10.0


def test_echo_line_is_skipped() -> None:
    reply = p.parse_reply(b"GETINFO\r\n" + GETINFO_REPLY, b"GETINFO\r")
    assert reply.lines == tuple(GETINFO_LINES)
    assert p.parse_reply(b"OUTPUT NONE\r\n->", b"OUTPUT NONE\r").lines == ()  # echo of a set command
    assert p.parse_reply(b"OUTPUT\r\nOUTPUT RS422\r\n->", b"OUTPUT\r").lines == ("OUTPUT RS422",)


def test_read_reply_can_be_sent_back_as_command() -> None:
    # "The reply can be used again as command for the parameter setting without changes."
    reply = p.parse_reply(b"OUTPUT ANALOG\r\n->", b"OUTPUT\r")
    assert p.decode_output(reply) == "ANALOG"
    assert (reply.lines[0] + "\r").encode() == p.encode_output("ANALOG")


def test_set_command_answers_with_a_return_and_the_prompt() -> None:
    reply = p.parse_reply(b"\r\n->", b"OUTPUT NONE\r")
    assert reply.lines == () and reply.warnings == ()
    p.expect_no_lines(reply, "OUTPUT")


@pytest.mark.parametrize(
    ("wire", "code", "text"),
    [(b"E104 Timeout\r\n->", 104, "Timeout"),  # MASTERMV without a value within 2 s
     (b"E202 Access denied\r\n->", 202, "Access denied"),
     (b"E104\r\n->", 104, "Timeout"),  # no message: the documented text
     (b"MASTERMV MASTER 1.0\r\nE104 Timeout\r\n->", 104, "Timeout")],  # after the echo
)
def test_error_replies_raise_device_error(wire: bytes, code: int, text: str) -> None:
    with pytest.raises(DeviceError) as info:
        p.parse_reply(wire, b"MASTERMV MASTER 1.0\r")
    assert info.value.code == code and info.value.text == text and info.value.command == "MASTERMV"


def test_warning_does_not_refuse_the_command() -> None:
    reply = p.parse_reply(b"W123 Value rounded\r\n->", b"MEASRATE 2\r")
    assert reply.lines == () and reply.warnings == ("W123 Value rounded",)


@pytest.mark.parametrize(
    "wire",
    [b"OUTPUT NONE\r\n", b"OUTPUT NONE->", b"OUTPUT\xc1NONE\r\n->", b"OUT\rPUT NONE\r\n->", b"->",
     b"OUTPUT NONE\n\r\n->"],
)
def test_malformed_replies_raise_protocol_error(wire: bytes) -> None:
    with pytest.raises(ProtocolError):
        p.parse_reply(wire, b"OUTPUT\r")


@pytest.mark.parametrize(
    ("lines", "decoder"),
    [(("OUTPUT USB",), p.decode_output), (("MEASRATE 9",), p.decode_measrate),
     (("MEASRATE x",), p.decode_measrate), (("OUTPUT NONE", "OUTPUT NONE"), p.decode_output),
     (("ECHO ON",), p.decode_output), (("Serial 1",), p.decode_getinfo), (("Serial: 1",), p.decode_getinfo)],
)
def test_unexpected_reply_content_raises_protocol_error(lines, decoder) -> None:
    with pytest.raises(ProtocolError):
        decoder(p.Reply(lines))


# -- binary frames --------------------------------------------------------------------------

def test_byte_example_32768_is_25_006_mm_on_a_50_mm_sensor() -> None:
    wire = bytes([0x00, 0x40, 0x88])  # protocols.md: raw 32768, first value
    assert frame(32768) == wire
    raw, first = p.FrameDecoder().feed(wire)
    assert raw.tolist() == [32768] and first.tolist() == [True]
    values, codes = p.decode_values(raw, 50.0)
    assert values[0] == pytest.approx(25.006, abs=5e-4)
    assert values[0] == pytest.approx(mm(32768, 50.0), abs=1e-12)


@pytest.mark.parametrize(
    ("raw", "status"),
    [(0, MeasurementStatus.OVER_RANGE_LOW), (642, MeasurementStatus.OVER_RANGE_LOW),
     (643, MeasurementStatus.OK), (32768, MeasurementStatus.OK), (64876, MeasurementStatus.OK),
     (64877, MeasurementStatus.OVER_RANGE_HIGH), (65519, MeasurementStatus.OVER_RANGE_HIGH),
     (65520, MeasurementStatus.ALARM), ((1 << 18) - 1, MeasurementStatus.ALARM)],
)
def test_value_bands(raw: int, status: MeasurementStatus) -> None:
    got, first = p.FrameDecoder().feed(frame(raw))
    assert got.tolist() == [raw]
    values, codes = p.decode_values(got, 10.0)
    assert p.STATUS_BY_CODE[int(codes[0])] is status
    if status is MeasurementStatus.OK:
        assert values[0] == pytest.approx(mm(raw, 10.0), abs=1e-12)
    else:
        assert math.isnan(values[0])


def test_range_ends_map_to_zero_and_full_scale() -> None:
    values, _ = p.decode_values(np.array([643, 64876]), 25.0)
    assert values[0] == pytest.approx(0.0, abs=25 * 1e-4)
    assert values[1] == pytest.approx(25.0, abs=25 * 1e-4)


def test_mastered_scaling_uses_offset_0_51_and_no_reserve_bands() -> None:
    raw = np.array([0, 32111, 65519])
    values, codes = p.decode_values(raw, 10.0, mastered=True)
    assert codes.tolist() == [0, 0, 0]
    assert values.tolist() == pytest.approx([mm(int(r), 10.0, 0.51) for r in raw], abs=1e-12)


def test_first_and_additional_values_of_a_block() -> None:
    raw, first = p.FrameDecoder().feed(frame(100) + frame(200, first=False) + frame(300, first=False))
    assert raw.tolist() == [100, 200, 300] and first.tolist() == [True, False, False]


def _decode_all(chunks: list[bytes]) -> tuple[list[int], p.FrameDecoder]:
    dec = p.FrameDecoder()
    out: list[int] = []
    for c in chunks:
        raw, _ = dec.feed(c)
        out += raw.tolist()
    dec.flush()
    return out, dec


VALUES = [1000 + 37 * k for k in range(10)]


def _stream_with(k: int, broken: bytes) -> bytes:
    return b"".join(broken if i == k else frame(v) for i, v in enumerate(VALUES))


@pytest.mark.parametrize(
    ("broken", "lost", "discarded"),
    [(frame(VALUES[4])[1:], 1, 2),  # L dropped
     (frame(VALUES[4])[:1] + frame(VALUES[4])[2:], 1, 2),  # M dropped
     (frame(VALUES[4])[:2], 1, 2),  # H dropped
     (frame(VALUES[4])[:1] + b"\xff" + frame(VALUES[4])[1:], 1, 4),  # H-flagged byte after L
     (frame(VALUES[4])[:2] + b"\x7f" + frame(VALUES[4])[2:], 1, 4),  # M-flagged byte after M
     (frame(VALUES[4]) + b"\xff", 0, 1),  # stray byte between frames
     (frame(VALUES[4]) + b"\x3f", 0, 1)],  # stray L-flagged byte between frames
)
def test_decoder_resyncs_and_counts_the_lost_frame(broken: bytes, lost: int, discarded: int) -> None:
    wire = _stream_with(4, broken)
    expected = VALUES if lost == 0 else VALUES[:4] + VALUES[5:]
    for chunks in ([wire], [wire[i:i + 1] for i in range(len(wire))], [wire[:13], wire[13:]]):
        values, dec = _decode_all(chunks)
        assert values == expected
        assert (dec.frames_ok, dec.frames_lost, dec.resyncs, dec.bytes_discarded) == (
            len(expected), lost, 1, discarded)


def test_decoder_starting_mid_frame_drops_the_tail() -> None:
    wire = frame(5000)[1:] + frame(6000) + frame(7000)
    values, dec = _decode_all([wire])
    assert values == [6000, 7000] and dec.bytes_discarded == 2


def test_ascii_between_frames_is_not_a_value() -> None:
    wire = frame(5000) + b"MEASRATE 2\r\n->" + frame(6000)
    values, _ = _decode_all([wire])
    assert values == [5000, 6000]
    frames, text = p.separate(wire)
    assert frames == frame(5000) + frame(6000) and text == b"MEASRATE 2\r\n->"


# -- driver with the exact conversation -----------------------------------------------------

def test_identify_sends_getinfo_and_adopts_the_range() -> None:
    link = ExpectedStream([(b"GETINFO\r", GETINFO_REPLY)])
    dev = ILD1420(link, measuring_range_mm=50.0)
    info = dev.identify()
    link.assert_done()
    assert info["model"] == "ILD1420-10" and info["serial"] == "15030002"
    assert dev.measuring_range_mm == 10.0


def test_identify_while_the_sensor_streams() -> None:
    # The input is flushed mid-frame: the reply arrives between frames and a frame tail.
    wire = frame(7000)[1:] + frame(7001) + GETINFO_REPLY[:40] + frame(7002) + GETINFO_REPLY[40:] + frame(7003)[:2]
    link = ExpectedStream([(b"GETINFO\r", wire)])
    assert ILD1420(link).identify()["serial"] == "15030002"
    link.assert_done()


def test_output_mastering_and_rate_commands() -> None:
    link = ExpectedStream([
        (b"OUTPUT NONE\r", b"\r\n->"),
        (b"OUTPUT\r", b"OUTPUT NONE\r\n->"),
        (b"MASTERMV MASTER 5.000000\r", b"\r\n->"),
        (b"MASTERMV NONE\r", b"MASTERMV NONE\r\n->"),  # with ECHO ON
        (b"MEASRATE 4\r", b"\r\n->"),
        (b"MEASRATE\r", b"MEASRATE 4\r\n->"),
        (b"ECHO OFF\r", b"\r\n->"),
    ])
    dev = ILD1420(link, measuring_range_mm=10.0)
    dev.set_output("NONE")
    assert dev.get_output() == "NONE"
    dev.master(5.0)
    assert dev.mastered
    dev.unmaster()
    assert not dev.mastered
    dev.set_measrate_khz(4)
    assert dev.get_measrate_khz() == 4.0
    dev.set_echo(False)
    link.assert_done()


def test_master_timeout_is_a_device_error_and_leaves_scaling_alone() -> None:
    link = ExpectedStream([(b"MASTERMV MASTER 0.000000\r", b"E104 Timeout\r\n->")])
    dev = ILD1420(link)
    with pytest.raises(DeviceError, match="Timeout") as info:
        dev.master(0.0)
    assert info.value.code == 104 and not dev.mastered
    link.assert_done()


def test_binary_in_a_reply_when_output_is_off_is_a_protocol_error() -> None:
    link = ExpectedStream([(b"OUTPUT NONE\r", b"\r\n->"), (b"OUTPUT\r", b"OUTPUT NONE\r\n" + frame(9) + b"->")])
    dev = ILD1420(link)
    dev.set_output("NONE")
    with pytest.raises(ProtocolError):
        dev.get_output()


def test_silent_sensor_times_out() -> None:
    dev = ILD1420(ExpectedStream([(b"GETINFO\r", b"Name: ILD1420-10\r\n")]), timeout_s=0.05)
    with pytest.raises(TransportTimeout, match="prompt"):
        dev.identify()


def test_read_once_takes_the_newest_complete_frame() -> None:
    wire = frame(32768)[2:] + frame(30000) + frame(32768) + frame(1, first=False) + frame(31000)[:2]
    link = ExpectedStream([(None, wire)])
    reading = ILD1420(link, measuring_range_mm=50.0).read_once()
    assert reading.ok and reading.raw == "32768"
    assert reading.value_mm == pytest.approx(mm(32768, 50.0), abs=1e-12)


def test_read_once_no_target_is_not_a_number() -> None:
    link = ExpectedStream([(None, frame((1 << 18) - 1))])
    reading = ILD1420(link).read_once()
    assert not reading.ok and reading.status is MeasurementStatus.ALARM and math.isnan(reading.value_mm)


def test_read_once_without_stream_times_out() -> None:
    dev = ILD1420(ExpectedStream([]), timeout_s=0.05)
    with pytest.raises(TransportTimeout, match="OUTPUT RS422"):
        dev.read_once()


def test_stream_blocks_with_reply_interleaved_and_damage_counted() -> None:
    raws = [700 + 50 * k for k in range(12)]
    f = [frame(r) for r in raws]
    link = ExpectedStream([
        (b"OUTPUT RS422\r", b"\r\n->"),
        (None, f[0] + f[1] + f[2][:2]),  # split frame
        (None, f[2][2:] + f[3] + frame(5, first=False) + f[4][:2] + f[5]),  # extra value; f[4] lost its H
        # mastering while streaming: reply interleaved with frames, a partial frame after the prompt
        (b"MASTERMV MASTER 1.000000\r", f[6] + b"\r\n" + f[7] + b"->" + f[8][:2]),
        (None, f[8][2:] + f[9] + f[10] + f[11]),
        (b"OUTPUT NONE\r", f[0] + b"\r\n->"),
    ])
    dev = ILD1420(link, measuring_range_mm=10.0)
    dev.start_stream()
    block = dev.read_stream(3)  # needs the second chunk, so the damage in it belongs to this block
    assert block.raw_counts.tolist() == raws[:3] and block.frames_ok == 3
    assert block.values_mm.tolist() == pytest.approx([mm(r, 10.0) for r in raws[:3]], abs=1e-12)
    assert block.statuses == (MeasurementStatus.OK,) * 3
    assert (block.frames_lost, block.resyncs, block.bytes_discarded, block.extra_values) == (1, 1, 2, 1)
    assert not block.ok
    dev.master(1.0)  # f[6], f[7] arrive with the reply: scaling unknown, skipped
    block = dev.read_stream(6)  # 3, 5 (range scaling) then 8..11 (mastered)
    assert block.raw_counts.tolist() == [raws[3], raws[5], *raws[8:]]
    assert (block.frames_lost, block.resyncs, block.bytes_discarded, block.extra_values) == (0, 0, 0, 0)
    assert block.frames_skipped == 2 and block.ok
    expected = [mm(r, 10.0) for r in (raws[3], raws[5])] + [mm(r, 10.0, 0.51) for r in raws[8:]]
    assert block.values_mm.tolist() == pytest.approx(expected, abs=1e-12)
    with pytest.raises(ValueError):
        block.values_mm[0] = 0.0  # read-only
    final = dev.stop_stream()  # the frame that came with the reply
    link.assert_done()
    assert final is not None and final.raw_counts.tolist() == [raws[0]]
    assert not dev.streaming and dev.stop_stream() is None


def test_stream_duration_returns_what_arrived() -> None:
    link = ExpectedStream([(b"OUTPUT RS422\r", b"\r\n->"), (None, frame(1000) + frame(2000))])
    dev = ILD1420(link)
    dev.start_stream()
    block = dev.read_stream(duration_s=0.05)
    assert block.raw_counts.tolist() == [1000, 2000] and block.duration_s >= 0.05


def test_stream_silence_times_out() -> None:
    link = ExpectedStream([(b"OUTPUT RS422\r", b"\r\n->"), (None, frame(1000))])
    dev = ILD1420(link, timeout_s=0.05)
    dev.start_stream()
    with pytest.raises(TransportTimeout, match="1 of 2"):
        dev.read_stream(2)


def test_stream_misuse_is_refused() -> None:
    dev = ILD1420(ExpectedStream([]))
    with pytest.raises(RuntimeError):
        dev.read_stream(1)
    with pytest.raises(ValueError):
        ILD1420(ExpectedStream([]), measuring_range_mm=0)


def test_errors_are_driver_errors() -> None:
    for cls in (DeviceError, ProtocolError, TransportTimeout):
        assert issubclass(cls, DriverError)
