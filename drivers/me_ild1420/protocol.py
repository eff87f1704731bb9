"""Pure codec for the Micro-Epsilon optoNCDT 1420 RS-422 interface (no I/O).

Source: ILD1420 manual §8 "Digital Interfaces RS422" and appendix A3 "ASCII
communication with sensor", summarised in ``protocols.md`` section 1.6.

Two kinds of traffic share the line:

* **ASCII commands.** ``<COMMAND>[ <P1> ...]`` + CR; a command without
  parameters reads (or executes), with parameters it sets.  Every reply ends
  with a return and the prompt: ``...\\r\\n->``.  An error line ``Exxx <msg>``
  comes before the prompt (the command was refused); a warning ``Wxxx <msg>``
  means the command was executed anyway.  With ``ECHO ON`` the sensor first
  repeats the command.  A read reply has the form ``<COMMAND> <P1> ...`` and
  can be sent back unchanged to set the same value.
* **Binary measurement values.** Each value is three bytes, L, M, H, told
  apart by their two most significant bits (flags)::

      L-Byte: 0 0 D5  D4  D3  D2  D1  D0
      M-Byte: 0 1 D11 D10 D9  D8  D7  D6
      H-Byte: 1 x D17 D16 D15 D14 D13 D12   x = 0: 1st value of a block, 1: additional value

  Distance (no mastering): ``x_mm = (digital * 1.02 / 65520 - 0.01) * MR``;
  with mastering the offset is ``-0.51`` instead of ``-0.01``.  Counts
  0...642 are the start-of-range reserve, 643...64876 the measuring range,
  64877...65519 the end-of-range reserve; values above 65519 (18 bit) are
  error values (their per-code meaning is not documented in protocols.md).

Because every valid frame has flags ``00, 01, 1x`` in that order, two valid
frames can never overlap and ASCII text (all bytes < 0x80) never contains an
H byte: :func:`find_frames` finds every valid frame in a buffer without state,
and whatever is left over is either ASCII reply text or line damage.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import DeviceError, ProtocolError
from ..readings import MeasurementStatus

COMMAND_END = b"\r"
LINE_END = "\r\n"
PROMPT = b"->"

#: Error numbers whose text protocols.md quotes (§1.6).  The sensor sends its
#: own message after the number; this table only fills in when it is missing.
ERROR_TEXT: dict[int, str] = {
    104: "Timeout",  # MASTERMV: no measurement value within 2 s (1420 A3.4.6.2)
    202: "Access denied",
}

OUTPUT_MODES = ("NONE", "RS422", "ANALOG")
MAX_MEASRATE_KHZ = 4.0  # "The maximum measuring rate is 4 kHz" (§8.1)

# Raw-count bands (protocols.md §1.6).
SMR_RESERVE_MAX = 642
RANGE_MIN = 643
RANGE_MAX = 64876
EMR_RESERVE_MAX = 65519
ERROR_MIN = 65520
RAW_MAX = (1 << 18) - 1

OFFSET_PLAIN = 0.01
OFFSET_MASTERED = 0.51

_NAME = re.compile(r"^[A-Z][A-Z0-9_]*$")
_ERROR_LINE = re.compile(r"^([EW])(\d{3})(?:\s+(.*))?$")


# ---------------------------------------------------------------------------------------
# ASCII commands


def encode_command(name: str, *params: str) -> bytes:
    """``NAME P1 P2`` + CR; parameters containing spaces are quoted (manual A3.1)."""
    if not _NAME.match(name):
        raise ValueError(f"not an ILD1420 command name: {name!r}")
    parts = [name]
    for p in params:
        if not p.isascii() or not p.isprintable() or '"' in p:
            raise ValueError(f"ILD1420 parameter must be printable ASCII without quotes: {p!r}")
        parts.append(f'"{p}"' if (" " in p or not p) else p)
    line = " ".join(parts)
    # Only the codec name's spelling can be mutated here ("ASCII" is the same codec).
    wire = line.encode("ascii")  # pragma: no mutate (equivalent)
    return wire + COMMAND_END


def encode_getinfo() -> bytes:
    return encode_command("GETINFO")


def encode_echo(on: bool) -> bytes:
    return encode_command("ECHO", "ON" if on else "OFF")


def encode_output(mode: str | None = None) -> bytes:
    """``OUTPUT`` reads the output selection; ``OUTPUT NONE|RS422|ANALOG`` sets it."""
    if mode is None:
        return encode_command("OUTPUT")
    if mode.upper() not in OUTPUT_MODES:
        raise ValueError(f"ILD1420 output must be one of {', '.join(OUTPUT_MODES)}, not {mode!r}")
    return encode_command("OUTPUT", mode.upper())


def encode_master(master_mm: float, measuring_range_mm: float) -> bytes:
    """``MASTERMV MASTER <MV>``: the next value becomes ``MV`` mm (0 = zeroing).

    The manual allows MV = 0...2 x measuring range and processes six decimals.
    """
    if not 0.0 <= master_mm <= 2.0 * measuring_range_mm:
        raise ValueError(
            f"master value {master_mm} mm outside 0...{2 * measuring_range_mm:g} mm (2 x measuring range)"
        )
    return encode_command("MASTERMV", "MASTER", f"{master_mm:.6f}")


def encode_master_none() -> bytes:
    """``MASTERMV NONE``: end mastering (values go back to the range scaling)."""
    return encode_command("MASTERMV", "NONE")


def encode_measrate(khz: float | None = None) -> bytes:
    """``MEASRATE`` reads, ``MEASRATE <kHz>`` sets the measuring rate (number format INFERRED)."""
    if khz is None:
        return encode_command("MEASRATE")
    if not 0.0 < khz <= MAX_MEASRATE_KHZ:
        raise ValueError(f"ILD1420 measuring rate must be in (0, {MAX_MEASRATE_KHZ:g}] kHz, not {khz}")
    return encode_command("MEASRATE", f"{khz:g}")


@dataclass(frozen=True, slots=True)
class Reply:
    """An ASCII reply: its text lines (echo and empty lines removed) and any warnings."""

    lines: tuple[str, ...]
    warnings: tuple[str, ...] = ()


def parse_reply(text: bytes, command: bytes) -> Reply:
    """Check a complete reply (ending in the prompt) to ``command`` and split it.

    Raises :class:`DeviceError` for an ``Exxx`` line and :class:`ProtocolError`
    for anything that is not a well-formed reply.
    """
    if not text.endswith(PROMPT):
        raise ProtocolError(f"ILD1420 reply does not end with the '->' prompt: {text!r}")
    body = text[: -len(PROMPT)]
    if any(b >= 0x80 for b in body):
        raise ProtocolError(f"non-ASCII byte in ILD1420 reply {text!r}")
    decoded = body.decode("ascii")  # pragma: no mutate (equivalent: "ASCII" is the same codec)
    if not decoded.endswith(LINE_END):
        raise ProtocolError(f"ILD1420 reply lacks the return before the prompt: {text!r}")
    lines = decoded[: -len(LINE_END)].split(LINE_END)
    if any("\r" in line or "\n" in line for line in lines):
        raise ProtocolError(f"stray line break in ILD1420 reply {text!r}")
    # Words of the command: CR/LF and any other whitespace only separate them.  The decode's mutants
    # other than the codec spelling are killed by test_parse_reply_accepts_a_non_ascii_command.
    sent = command.decode("ascii", "replace").split()  # pragma: no mutate (equivalent: "ASCII")
    if lines and _same_command(lines[0], sent):
        lines = lines[1:]  # ECHO ON repeats the command first
    out: list[str] = []
    warnings: list[str] = []
    main = sent[0] if sent else ""
    for line in lines:
        m = _ERROR_LINE.match(line)
        if m and m[1] == "E":
            code = int(m[2])
            raise DeviceError(code, (m[3] or "").strip() or ERROR_TEXT.get(code, "unknown error"), command=main)
        if m:
            warnings.append(line)
        elif line.strip():
            out.append(line)
    return Reply(tuple(out), tuple(warnings))


def _same_command(line: str, sent: list[str]) -> bool:
    """``line`` is the echo of the command whose words are ``sent``."""
    return bool(sent) and line.split() == sent


def expect_no_lines(reply: Reply, command: str) -> None:
    """A set command answers with the return and prompt only."""
    if reply.lines:
        raise ProtocolError(f"unexpected text in the ILD1420 reply to {command}: {reply.lines!r}")


def decode_getinfo(reply: Reply) -> dict[str, str]:
    """``Key: value`` lines of GETINFO (manual A3.3.2) as a dict; ``Name`` is required."""
    info: dict[str, str] = {}
    for line in reply.lines:
        key, sep, value = line.partition(":")
        if not sep or not key.strip() or key != key.strip():
            raise ProtocolError(f"malformed GETINFO line {line!r}; expected 'Key: value'")
        info[key] = value.strip()
    if "Name" not in info:
        raise ProtocolError(f"GETINFO reply has no 'Name:' line: {reply.lines!r}")
    return info


def decode_parameter(reply: Reply, name: str) -> list[str]:
    """Parameters of a read reply ``NAME P1 [P2 ...]``."""
    if len(reply.lines) != 1:
        raise ProtocolError(f"ILD1420 {name} reply must be one line, got {reply.lines!r}")
    fields = reply.lines[0].split()
    if len(fields) < 2 or fields[0].upper() != name:
        raise ProtocolError(f"ILD1420 reply {reply.lines[0]!r} does not answer {name}")
    return fields[1:]


def decode_output(reply: Reply) -> str:
    (mode, *rest) = decode_parameter(reply, "OUTPUT")
    if rest or mode.upper() not in OUTPUT_MODES:
        raise ProtocolError(f"unknown ILD1420 output selection {reply.lines[0]!r}")
    return mode.upper()


def decode_measrate(reply: Reply) -> float:
    (value, *rest) = decode_parameter(reply, "MEASRATE")
    try:
        khz = float(value)
    except ValueError:
        khz = math.nan
    if rest or not 0.0 < khz <= MAX_MEASRATE_KHZ:
        raise ProtocolError(f"bad ILD1420 measuring rate {reply.lines[0]!r}")
    return khz


def parse_measuring_range_mm(text: str) -> float:
    """``10.00mm`` (GETINFO ``Measuring range``) -> 10.0."""
    m = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*mm\s*", text)
    if not m:
        raise ProtocolError(f"cannot read a measuring range from {text!r}")
    return float(m[1])


# ---------------------------------------------------------------------------------------
# Binary measurement frames

FLAG_L, FLAG_M, FLAG_H_FIRST, FLAG_H_MORE = 0b00, 0b01, 0b10, 0b11


def find_frames(buf: np.ndarray) -> np.ndarray:
    """Start indices of every valid L/M/H frame in ``buf`` (uint8 array), ascending."""
    if len(buf) < 3:
        return np.empty(0, dtype=np.intp)
    flags = buf >> 6
    ok = (flags[:-2] == FLAG_L) & (flags[1:-1] == FLAG_M) & (flags[2:] >= FLAG_H_FIRST)
    return np.flatnonzero(ok)


def frame_values(buf: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """18-bit raw values and first-of-block flags of the frames starting at ``starts``."""
    lo = buf[starts].astype(np.int64) & 0x3F
    mid = buf[starts + 1].astype(np.int64) & 0x3F
    hi = buf[starts + 2].astype(np.int64)
    raw = lo | (mid << 6) | ((hi & 0x3F) << 12)
    return raw, (hi >> 6) == FLAG_H_FIRST


def prefix_length(tail: bytes | np.ndarray) -> int:
    """How many bytes at the end of ``tail`` could start a frame (0, 1 = L, 2 = L M)."""
    n = len(tail)
    if n >= 2 and tail[-2] >> 6 == FLAG_L and tail[-1] >> 6 == FLAG_M:
        return 2
    if n >= 1 and tail[-1] >> 6 == FLAG_L:
        return 1
    return 0


def lost_frames(discarded_run: int) -> int:
    """Frames lost in a run of ``discarded_run`` consecutive unusable bytes.

    A frame that lost one byte leaves 2 bytes, one with a stray byte inserted
    leaves 4, a stray byte between frames leaves 1: the nearest whole number of
    3-byte frames counts each of these exactly.
    """
    return (discarded_run + 1) // 3


class FrameDecoder:
    """Incremental decoder of the binary stream with resynchronisation.

    Feed it chunks as they arrive; bytes that are not part of a valid frame
    are discarded (counted in :attr:`bytes_discarded`), each run of them is
    one :attr:`resyncs` event and :func:`lost_frames` whole frames.  A frame
    split across two chunks is carried over.
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self._carry = b""
        self._run = 0  # discarded bytes since the last good frame
        self.frames_ok = 0
        self.frames_lost = 0
        self.resyncs = 0
        self.bytes_discarded = 0

    def take_carry(self) -> bytes:
        """Hand back the partial frame held over (e.g. to parse it with a command reply)."""
        carry, self._carry = self._carry, b""
        return carry

    def _close_run(self, extra: int) -> None:
        run = self._run + extra
        if run:
            self.bytes_discarded += run
            self.resyncs += 1
            self.frames_lost += lost_frames(run)
        self._run = 0

    def feed(self, data: bytes) -> tuple[np.ndarray, np.ndarray]:
        """Decode ``data``; return (raw 18-bit values, first-of-block flags) of complete frames."""
        buf = np.frombuffer(self._carry + data, dtype=np.uint8)
        starts = find_frames(buf)
        if len(starts):
            gaps = np.diff(starts) - 3
            self._close_run(int(starts[0]))
            # ">= 0" is equivalent: a zero gap closes an empty run (no-op).
            for gap in gaps[gaps > 0]:  # pragma: no mutate (equivalent)
                self._close_run(int(gap))
            end = int(starts[-1]) + 3
        else:
            end = 0  # pragma: no mutate (equivalent: buf[None:] is buf[0:])
        tail = buf[end:]
        keep = prefix_length(tail)
        # Bytes before a possible partial frame at the end are damage, but the run
        # may continue into the next chunk, so it stays open.
        self._run += len(tail) - keep
        self._carry = tail[len(tail) - keep:].tobytes()  # keep = 0: empty
        self.frames_ok += len(starts)
        return frame_values(buf, starts)

    def flush(self) -> None:
        """End of stream: count the open damage run and a dangling partial frame as lost."""
        self._run += len(self._carry)
        self._carry = b""
        self._close_run(0)


def separate(buf: bytes, *, stream_start: bool = False) -> tuple[bytes, bytes]:
    """Split bytes read while a command runs into (frame bytes, ASCII text).

    Valid frames are taken out; everything else is the reply text.  With
    ``stream_start`` (the buffer may begin in the middle of a frame, e.g.
    after the input was flushed while the sensor streams) a leading frame tail
    (``H`` or ``M H``) is dropped too.
    """
    arr = np.frombuffer(buf, dtype=np.uint8)
    starts = find_frames(arr)
    in_frame = np.zeros(len(arr), dtype=bool)
    for offset in range(3):
        in_frame[starts + offset] = True
    text = ~in_frame
    if stream_start:
        text[: frame_tail_length(arr)] = False  # pragma: no mutate (equivalent: None is False in a bool array)
    return arr[in_frame].tobytes(), arr[text].tobytes()


def frame_tail_length(buf: bytes | np.ndarray) -> int:
    """Length of the end of a frame (``H`` or ``M H``) that ``buf`` starts with, else 0."""
    if len(buf) >= 1 and buf[0] >> 6 >= FLAG_H_FIRST:
        return 1
    if len(buf) >= 2 and buf[0] >> 6 == FLAG_M and buf[1] >> 6 >= FLAG_H_FIRST:
        return 2
    return 0


def scale_mm(raw: np.ndarray, measuring_range_mm: float, *, mastered: bool = False) -> np.ndarray:
    """The manual's formula, ``(raw * 1.02 / 65520 - offset) * MR``, for any counts."""
    offset = OFFSET_MASTERED if mastered else OFFSET_PLAIN
    return (np.asarray(raw, dtype=np.float64) * 1.02 / 65520.0 - offset) * measuring_range_mm


_STATUS_OK, _STATUS_LOW, _STATUS_HIGH, _STATUS_ERROR = 0, 1, 2, 3
STATUS_BY_CODE = (
    MeasurementStatus.OK,
    MeasurementStatus.OVER_RANGE_LOW,
    MeasurementStatus.OVER_RANGE_HIGH,
    MeasurementStatus.ALARM,
)


def classify(raw: np.ndarray, *, mastered: bool = False) -> np.ndarray:
    """Status code per raw value (index into :data:`STATUS_BY_CODE`).

    Without mastering the reserve bands are out of range (low/high); with
    mastering the whole 16-bit span is a value.  Above 65519: error value.
    """
    raw = np.asarray(raw)
    codes = np.zeros(raw.shape, dtype=np.int8)
    if not mastered:
        codes[raw < RANGE_MIN] = _STATUS_LOW
        codes[raw > RANGE_MAX] = _STATUS_HIGH
    codes[raw >= ERROR_MIN] = _STATUS_ERROR
    return codes


def decode_values(raw: np.ndarray, measuring_range_mm: float, *, mastered: bool = False
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(values in mm, NaN unless OK; status codes) for raw distance counts."""
    codes = classify(raw, mastered=mastered)
    values = scale_mm(raw, measuring_range_mm, mastered=mastered)
    values[codes != _STATUS_OK] = np.nan  # pragma: no mutate (equivalent: None is NaN in a float array)
    return values, codes
