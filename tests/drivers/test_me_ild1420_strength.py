"""Strength tests of the ILD1420 codec (issue 28, mutation testing).

Byte examples are written from protocols.md section 1.6: the flag bits of the L/M/H bytes
(L = 00xxxxxx, M = 01xxxxxx, H = 10xxxxxx first value / 11xxxxxx additional value), the reply
form ``...\\r\\n->`` with ``Exxx``/``Wxxx`` lines, the GETINFO ``Key: value`` lines, MASTERMV
0...2 x measuring range, the 4 kHz maximum rate and ``x_mm = (digital * 1.02 / 65520 - 0.01) * MR``.
Error messages are checked for their key words: they are what the user reads.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivers.errors import DeviceError, ProtocolError
from drivers.me_ild1420 import protocol as p
from tests.drivers.ild1420_vectors import frame, mm

L, M, H_FIRST, H_MORE = 0b0000_0000, 0b0100_0000, 0b1000_0000, 0b1100_0000  # flag bits, data bits 0


# -- commands --------------------------------------------------------------------------------

def test_parameters_with_spaces_or_empty_are_quoted() -> None:
    # "Parameters containing spaces go in quotes" (1750 syntax); an empty parameter needs quotes to exist at all.
    assert p.encode_command("PASSWD", "old pw", "new pw", "new pw") == b'PASSWD "old pw" "new pw" "new pw"\r'
    assert p.encode_command("PASSWD", "") == b'PASSWD ""\r'
    assert p.encode_command("LOGIN", "secret") == b"LOGIN secret\r"


def test_master_value_may_be_twice_the_measuring_range() -> None:
    # MASTERMV: "MV = 0...2 x measuring range": both ends are allowed.
    assert p.encode_master(20.0, 10.0) == b"MASTERMV MASTER 20.000000\r"
    assert p.encode_master(0.0, 10.0) == b"MASTERMV MASTER 0.000000\r"


def test_small_measuring_rates_are_sent() -> None:
    assert p.encode_measrate(0.25) == b"MEASRATE 0.25\r"
    assert p.encode_measrate(4.0) == b"MEASRATE 4\r"  # "The maximum measuring rate is 4 kHz"


@pytest.mark.parametrize(
    ("bad", "words"),
    [(lambda: p.encode_command("getinfo"), r"not an ILD1420 command name: 'getinfo'"),
     (lambda: p.encode_command("X", 'a"b'), r"parameter must be printable ASCII without quotes: 'a\"b'"),
     (lambda: p.encode_command("X", "\r"), r"parameter must be printable ASCII"),
     (lambda: p.encode_output("USB"), r"output must be one of NONE, RS422, ANALOG, not 'USB'"),
     (lambda: p.encode_master(20.001, 10.0), r"master value 20\.001 mm outside 0\.\.\.20 mm \(2 x measuring range\)"),
     (lambda: p.encode_master(-1.0, 2.5), r"master value -1\.0 mm outside 0\.\.\.5 mm"),
     (lambda: p.encode_measrate(4.5), r"measuring rate must be in \(0, 4\] kHz, not 4\.5"),
     (lambda: p.encode_measrate(0.0), r"measuring rate must be in \(0, 4\] kHz, not 0\.0")],
)
def test_refused_commands_say_what_is_wrong(bad, words: str) -> None:
    with pytest.raises(ValueError, match=words):
        bad()


# -- replies ---------------------------------------------------------------------------------

@pytest.mark.parametrize(
    ("wire", "words"),
    [(b"OUTPUT NONE\r\n", r"does not end with the '->' prompt"),
     (b"OUTPUT\x80NONE\r\n->", r"non-ASCII byte in ILD1420 reply"),  # 0x80: the smallest H-flagged byte
     (b"OUTPUT\xffNONE\r\n->", r"non-ASCII byte in ILD1420 reply"),
     (b"OUTPUT NONE->", r"lacks the return before the prompt"),
     (b"OUT\rPUT NONE\r\n->", r"stray line break in ILD1420 reply"),
     (b"OUTPUT NONE\n\r\n->", r"stray line break in ILD1420 reply")],
)
def test_malformed_replies_say_what_is_wrong(wire: bytes, words: str) -> None:
    with pytest.raises(ProtocolError, match=words):
        p.parse_reply(wire, b"OUTPUT\r")


def test_error_without_message_and_unknown_code_says_unknown_error() -> None:
    with pytest.raises(DeviceError, match=r"device reported error 999 to 'GETINFO': unknown error") as info:
        p.parse_reply(b"E999\r\n->", b"GETINFO\r")
    assert info.value.code == 999 and info.value.text == "unknown error" and info.value.command == "GETINFO"


@pytest.mark.parametrize(
    ("command", "name"),
    [(b"GETINFO\r", "GETINFO"),  # no parameters: the CR is not part of the name
     (b"GETINFO\r\n", "GETINFO"),  # CR LF is accepted too
     (b"MASTERMV MASTER 1.000000\r", "MASTERMV"),
     (b"MASTERMV\tMASTER 1.000000\r", "MASTERMV"),  # any whitespace separates the words, as in the echo check
     (b"\r", "")],  # nothing sent: no name, and no crash
)
def test_device_error_names_the_command(command: bytes, name: str) -> None:
    with pytest.raises(DeviceError) as info:
        p.parse_reply(b"E202 Access denied\r\n->", command)
    assert info.value.command == name and info.value.text == "Access denied"


def test_echo_of_a_command_ending_in_x_is_skipped() -> None:
    assert p.parse_reply(b"LOGIN MAX\r\n->", b"LOGIN MAX\r").lines == ()
    assert p.parse_reply(b"LOGIN MAX\r\nW001 Note\r\n->", b"LOGIN MAX\r\n").warnings == ("W001 Note",)


def test_parse_reply_accepts_a_non_ascii_command() -> None:
    # encode_command never makes one, but the reply parser must not crash on the bytes it is handed.
    assert p.parse_reply(b"\r\n->", b"PASSWD \xe9\r") == p.Reply(())
    with pytest.raises(DeviceError) as info:
        p.parse_reply(b"E202 Access denied\r\n->", b"PASSWD \xe9\r")
    assert info.value.command == "PASSWD"


def test_text_after_a_set_command_is_reported() -> None:
    with pytest.raises(ProtocolError, match=r"unexpected text in the ILD1420 reply to OUTPUT: \('OUTPUT NONE',\)"):
        p.expect_no_lines(p.Reply(("OUTPUT NONE",)), "OUTPUT")


def test_getinfo_value_may_contain_a_colon() -> None:
    info = p.decode_getinfo(p.Reply(("Name: ILD1420-10", "Date: 2015-03-02 10:20")))
    assert info == {"Name": "ILD1420-10", "Date": "2015-03-02 10:20"}


@pytest.mark.parametrize(
    ("lines", "words"),
    [(("Name: ILD1420-10", "Serial 15030002"), r"malformed GETINFO line 'Serial 15030002'; expected 'Key: value'"),
     (("Name: ILD1420-10", " Serial: 15030002"), r"malformed GETINFO line ' Serial: 15030002'"),
     (("Name: ILD1420-10", ": 15030002"), r"malformed GETINFO line ': 15030002'"),
     (("Serial: 15030002",), r"GETINFO reply has no 'Name:' line: \('Serial: 15030002',\)")],
)
def test_malformed_getinfo_says_what_is_wrong(lines: tuple[str, ...], words: str) -> None:
    with pytest.raises(ProtocolError, match=words):
        p.decode_getinfo(p.Reply(lines))


@pytest.mark.parametrize(
    ("lines", "name", "words"),
    [(("OUTPUT NONE", "OUTPUT NONE"), "OUTPUT", r"ILD1420 OUTPUT reply must be one line, got \('OUTPUT NONE', "),
     (("OUTPUT",), "OUTPUT", r"ILD1420 reply 'OUTPUT' does not answer OUTPUT"),
     (("ECHO ON",), "OUTPUT", r"ILD1420 reply 'ECHO ON' does not answer OUTPUT"),
     (("MEASRATE",), "MEASRATE", r"ILD1420 reply 'MEASRATE' does not answer MEASRATE")],
)
def test_parameter_reply_mismatch_says_what_is_wrong(lines: tuple[str, ...], name: str, words: str) -> None:
    with pytest.raises(ProtocolError, match=words):
        p.decode_parameter(p.Reply(lines), name)


def test_output_and_measrate_replies() -> None:
    with pytest.raises(ProtocolError, match=r"unknown ILD1420 output selection 'OUTPUT USB'"):
        p.decode_output(p.Reply(("OUTPUT USB",)))
    assert p.decode_measrate(p.Reply(("MEASRATE 0.25",))) == 0.25
    assert p.decode_measrate(p.Reply(("MEASRATE 4",))) == 4.0
    for bad in ("MEASRATE 0", "MEASRATE 4.01", "MEASRATE x", "MEASRATE 2 3"):
        with pytest.raises(ProtocolError, match=rf"bad ILD1420 measuring rate '{bad}'"):
            p.decode_measrate(p.Reply((bad,)))


def test_unreadable_measuring_range_says_so() -> None:
    with pytest.raises(ProtocolError, match=r"cannot read a measuring range from '10\.00 inch'"):
        p.parse_measuring_range_mm("10.00 inch")


# -- binary frames ---------------------------------------------------------------------------

@pytest.mark.parametrize(
    ("tail", "keep"),
    [(bytes([L]), 1), (bytes([L | 0x3F]), 1), (bytes([L, M]), 2), (bytes([H_FIRST, L, M]), 2),
     (bytes([M, L, M]), 2),  # only the last two bytes count
     (bytes([M]), 0), (bytes([M | 0x3F]), 0), (bytes([H_FIRST]), 0), (bytes([H_MORE]), 0),
     (bytes([M, M]), 0), (bytes([H_FIRST, M]), 0), (bytes([L, L]), 1), (b"", 0),
     (b"AB", 0), (b"\r\n", 1)],  # ASCII letters carry the M flags, CR LF the L flags
)
def test_prefix_length_counts_only_l_or_l_m_at_the_end(tail: bytes, keep: int) -> None:
    assert p.prefix_length(tail) == keep
    assert p.prefix_length(np.frombuffer(tail, dtype=np.uint8)) == keep


@pytest.mark.parametrize(
    ("head", "length"),
    [(bytes([H_FIRST]), 1), (bytes([H_MORE | 0x3F]), 1), (bytes([H_FIRST, L]), 1),
     (bytes([M, H_FIRST]), 2), (bytes([M | 0x3F, H_MORE]), 2), (bytes([M, H_MORE, L]), 2),
     (bytes([L, M, H_FIRST]), 0), (bytes([M]), 0), (bytes([M, M]), 0), (bytes([M, L]), 0),
     (bytes([L]), 0), (b"", 0)],
)
def test_frame_tail_length_is_h_or_m_h_at_the_start(head: bytes, length: int) -> None:
    assert p.frame_tail_length(head) == length
    assert p.frame_tail_length(np.frombuffer(head, dtype=np.uint8)) == length


def test_separate_drops_a_leading_frame_tail_only_at_stream_start() -> None:
    tail = frame(5000)[1:]  # M H of a frame whose L was flushed away
    wire = tail + b"OK\r\n" + frame(6000) + b"->"
    assert p.separate(wire) == (frame(6000), tail + b"OK\r\n->")  # default: kept, so the reply is refused
    assert p.separate(wire, stream_start=False) == (frame(6000), tail + b"OK\r\n->")
    assert p.separate(wire, stream_start=True) == (frame(6000), b"OK\r\n->")
    lone_h = frame(5000, first=False)[2:]
    assert p.separate(lone_h + b"\r\n->", stream_start=True) == (b"", b"\r\n->")


def test_flush_counts_and_forgets_the_partial_frame() -> None:
    dec = p.FrameDecoder()
    dec.feed(frame(100) + frame(200)[:2])
    dec.flush()
    assert (dec.frames_ok, dec.frames_lost, dec.resyncs, dec.bytes_discarded) == (1, 1, 1, 2)
    assert dec.take_carry() == b""
    raw, first = dec.feed(frame(300))  # nothing of the old frame is prefixed to new data
    assert raw.tolist() == [300] and first.tolist() == [True]
    assert (dec.frames_ok, dec.frames_lost, dec.resyncs, dec.bytes_discarded) == (2, 1, 1, 2)


def test_chunk_without_a_frame_is_all_damage() -> None:
    dec = p.FrameDecoder()
    raw, _ = dec.feed(bytes([H_FIRST, H_MORE]))
    assert raw.tolist() == [] and dec.take_carry() == b""
    dec.flush()
    assert (dec.frames_ok, dec.frames_lost, dec.resyncs, dec.bytes_discarded) == (0, 1, 1, 2)


def test_partial_frame_is_carried_and_ascii_is_not() -> None:
    dec = p.FrameDecoder()
    dec.feed(frame(100) + frame(200)[:2])
    assert dec.take_carry() == frame(200)[:2]
    dec.feed(frame(100) + b"AB")  # M-flagged letters can not start a frame
    assert dec.take_carry() == b""
    dec.feed(frame(100) + b"A" + frame(200)[:1])
    assert dec.take_carry() == frame(200)[:1]


def test_scale_mm_without_mastering_by_default() -> None:
    # protocols.md byte example: raw 32768 -> 25.006 mm for MR = 50 mm (offset 0.01, no mastering)
    assert p.scale_mm(np.array([32768]), 50.0)[0] == pytest.approx(25.006, abs=5e-4)
    assert p.scale_mm(np.array([32768]), 50.0)[0] == pytest.approx(mm(32768, 50.0), abs=1e-12)


def test_scale_mm_computes_in_double_precision_for_any_count_type() -> None:
    # float32 counts (e.g. read back from a file) must not pull the millimetres down to 7 digits.
    for dtype in (np.float32, np.uint16, np.int32):
        values = p.scale_mm(np.array([32768, 643], dtype=dtype), 50.0)
        assert values.dtype == np.float64
        assert values.tolist() == pytest.approx([mm(32768, 50.0), mm(643, 50.0)], abs=1e-12)


def test_classify_without_mastering_by_default() -> None:
    raw = np.array([0, 642, 643, 64876, 64877, 65519, 65520])
    assert p.classify(raw).tolist() == [1, 1, 0, 0, 2, 2, 3]
    assert p.classify(raw, mastered=True).tolist() == [0, 0, 0, 0, 0, 0, 3]
