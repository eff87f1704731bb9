"""Pure codec for the Panasonic HL-G1 RS-422/RS-485 command set (no I/O).

Source: HL-G1 User's Manual ch. 4 "Communications Control" (command formats
p.4-8, RMD example p.4-10, error codes p.4-16, read commands p.4-22) and the
BCC rule of the same family's HL-D3 manual, as summarised in ``protocols.md``
section 1.5.  MEWTOCOL-style ASCII frames, CR-terminated::

    request : '%' <station 01..16> '#' <3-letter command> [data] <BCC> CR
    normal  : '%' <station>        '$' <3-letter command> [data] <BCC> CR
    error   : '%' <station>        '!' <2-digit error code>      <BCC> CR

The BCC is the XOR of every byte from ``%`` to the last data character, as
two upper-case hex ASCII characters.  ``**`` in place of the BCC omits the
check; the device then answers with ``**`` too.

Data blocks: a measured value is a sign plus 7 digits in 0.0001 mm
(``-0123456`` = -12.3456 mm, bounded by +-9500000); a setting is a sign plus
5 digits (``+00001``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import reduce

from ..errors import ChecksumError, DeviceError, ProtocolError

TERMINATOR = b"\r"
NO_BCC = b"**"
STATIONS = range(1, 17)
MEASURED_LIMIT = 9_500_000  # counts of 0.0001 mm (p.4-22: -950.0000 to +950.0000 mm)
MM_PER_COUNT = 1e-4

ERROR_TEXT: dict[str, str] = {
    "01": "Command error: the command is undefined",
    "02": "Address error: start address > end address, or address > 999999",
    "03": "Data error: the data length does not correspond to the command",
    "04": "BCC error: BCC check was not conformable",
    "11": "Communication error: parity, framing or overrun error during reception",
    "21": "Control flow error: the system is in setting mode",
    "22": "Execution error: calibration or analog scaling is not executable",
    "31": "Buffering condition error 1: setting changed while buffering",
    "32": "Buffering condition error 2: buffering setting not valid at start",
    "33": "Buffering condition error 3: data read before accumulation completed or beyond the final point",
}

# Read commands without data (p.4-22) and their reply data shape.
READ_MEASURED = "RMD"  # measured value
READ_LIGHT = "RID"  # light intensity +00000..+04095
READ_ALARM = "ROA"  # alarm +00000 off / +00001 on
READ_OUTPUTS = ("RZA", "RZB", "RZC")  # OUT1, OUT2, OUT3
READ_ALL = "RMB"  # value, light intensity, OUT1..3, ALARM
READ_SAMPLING = "RSP"  # sampling cycle code (+00001 = 500 us)
# Write commands with a 6-character setting (sign + 5 digits).
ZERO_SET = "WZS"
RESET = "WRS"
LASER = "WLR"
AVERAGING = "WAV"
THRESHOLD_A = "WHA"  # data is a measured value (sign + 7 digits)

_COMMAND = re.compile(r"[A-Z]{3}")
_MEASURED = re.compile(r"[+-]\d{7}")
_SETTING = re.compile(r"[+-]\d{5}")
_HEX2 = re.compile(r"[0-9A-Fa-f]{2}")


def bcc(data: bytes) -> bytes:
    """XOR of ``data`` as two upper-case hex ASCII characters."""
    return b"%02X" % reduce(lambda acc, b: acc ^ b, data, 0)


def _station_id(station: int) -> str:
    if station not in STATIONS:
        raise ValueError(f"HL-G1 station number must be 1..16, not {station}")
    return f"{station:02d}"


def encode_request(station: int, command: str, data: str = "", *, use_bcc: bool = True) -> bytes:
    """``%<st>#<command><data><BCC>\\r`` (``**`` instead of the BCC if ``use_bcc`` is false)."""
    if not _COMMAND.fullmatch(command):
        raise ValueError(f"HL-G1 command must be 3 upper-case letters, not {command!r}")
    if not data.isascii() or not data.isprintable():
        raise ValueError(f"HL-G1 data must be printable ASCII, not {data!r}")
    body = f"%{_station_id(station)}#{command}{data}".encode("ascii")  # pragma: no mutate (equivalent)
    return body + (bcc(body) if use_bcc else NO_BCC) + TERMINATOR


def format_setting(value: int) -> str:
    """Setting data: sign plus 5 digits (``+00001``)."""
    if abs(value) > 99_999:
        raise ValueError(f"HL-G1 setting {value} does not fit in 5 digits")
    return f"{'-' if value < 0 else '+'}{abs(value):05d}"


def format_measured(value_mm: float) -> str:
    """Measured-value data: sign plus 7 digits in 0.0001 mm (``+0055000`` = 5.5 mm)."""
    if not math.isfinite(value_mm):  # round() would raise a bare OverflowError (inf) or a cryptic ValueError (nan)
        raise ValueError(f"HL-G1 value {value_mm} mm is not a finite number: give a value within +-950 mm")
    counts = round(value_mm / MM_PER_COUNT)
    if abs(counts) > MEASURED_LIMIT:
        raise ValueError(f"HL-G1 value {value_mm} mm is outside +-950 mm")
    return f"{'-' if counts < 0 else '+'}{abs(counts):07d}"


def parse_setting(data: str) -> int:
    """Decode a sign-plus-5-digits setting."""
    if not _SETTING.fullmatch(data):
        raise ProtocolError(f"HL-G1 setting must be a sign and 5 digits, got {data!r}")
    return int(data)


def parse_measured(data: str) -> float:
    """Decode a sign-plus-7-digits measured value into mm."""
    if not _MEASURED.fullmatch(data):
        raise ProtocolError(f"HL-G1 measured value must be a sign and 7 digits, got {data!r}")
    counts = int(data)
    if abs(counts) > MEASURED_LIMIT:
        raise ProtocolError(f"HL-G1 measured value {data!r} is outside +-9500000 (950 mm)")
    return counts / 10_000  # exact decimal division: 0.0001 mm per count


def decode_reply(frame: bytes, station: int, command: str, *, require_bcc: bool = True) -> str:
    """Check a reply frame to ``command`` from ``station`` and return its data block.

    Raises :class:`ChecksumError` if the BCC does not match,
    :class:`DeviceError` for an ``!nn`` error reply and :class:`ProtocolError`
    for anything else that is not a well-formed reply (including a ``**`` BCC
    when ``require_bcc`` is true, i.e. the request carried a real BCC).
    """
    if not frame.endswith(TERMINATOR):
        raise ProtocolError(f"HL-G1 reply not terminated by CR: {frame!r}")
    body, check = frame[:-3], frame[-3:-1]
    if len(frame) < 9 or not body.startswith(b"%"):
        raise ProtocolError(f"HL-G1 reply is not a '%' frame: {frame!r}")
    try:
        text = body.decode("ascii")  # pragma: no mutate (equivalent)
    except UnicodeDecodeError as exc:
        raise ProtocolError(f"non-ASCII bytes in HL-G1 reply {frame!r}") from exc
    if not text.isprintable():
        raise ProtocolError(f"control characters in HL-G1 reply {frame!r}")
    if check == NO_BCC:
        if require_bcc:
            raise ProtocolError(f"HL-G1 reply {frame!r} has no BCC although the request had one")
    elif not _HEX2.fullmatch(check.decode("ascii", "replace")):  # pragma: no mutate (equivalent)
        raise ProtocolError(f"HL-G1 reply BCC {check!r} is not two hex digits: {frame!r}")
    elif check.upper() != bcc(body):
        raise ChecksumError(f"HL-G1 reply BCC {check.decode()} != computed {bcc(body).decode()}: {frame!r}")
    expected = _station_id(station)
    if text[1:3] != expected:
        raise ProtocolError(f"HL-G1 reply from station {text[1:3]!r}, expected {expected}: {frame!r}")
    kind, rest = text[3], text[4:]
    if kind == "!":
        if not re.fullmatch(r"\d\d", rest):
            raise ProtocolError(f"malformed HL-G1 error reply {frame!r}")
        raise DeviceError(rest, ERROR_TEXT.get(rest, "unknown error code"), command=command)
    if kind != "$" or rest[:3] != command:
        raise ProtocolError(f"HL-G1 reply {frame!r} does not answer {command!r}")
    return rest[3:]


def decode_ack(frame: bytes, station: int, command: str, *, require_bcc: bool = True) -> None:
    """Decode the reply to a write command (no data: ``%01$WZS<BCC>``)."""
    data = decode_reply(frame, station, command, require_bcc=require_bcc)
    if data:
        raise ProtocolError(f"HL-G1 reply to {command} carries unexpected data {data!r}")


def decode_measured(frame: bytes, station: int, *, require_bcc: bool = True) -> float:
    """Decode the reply to ``RMD`` into mm."""
    return parse_measured(decode_reply(frame, station, READ_MEASURED, require_bcc=require_bcc))


def decode_setting(frame: bytes, station: int, command: str, *, require_bcc: bool = True) -> int:
    """Decode the reply to a read command whose data is a setting (``RID``, ``ROA``, ``RSP`` ...)."""
    return parse_setting(decode_reply(frame, station, command, require_bcc=require_bcc))


def decode_flag(frame: bytes, station: int, command: str, *, require_bcc: bool = True) -> bool:
    """Decode an on/off reply (``ROA``, ``RZA``/``RZB``/``RZC``): ``+00000`` or ``+00001``."""
    value = decode_setting(frame, station, command, require_bcc=require_bcc)
    if value not in (0, 1):
        raise ProtocolError(f"HL-G1 {command} must be +00000 or +00001: {frame!r}")
    return value == 1


@dataclass(frozen=True, slots=True)
class AllOutputs:
    """The ``RMB`` reply: measured value, light intensity and the four output states."""

    value_mm: float
    light_intensity: int
    out1: bool
    out2: bool
    out3: bool
    alarm: bool


def decode_all_outputs(frame: bytes, station: int, *, require_bcc: bool = True) -> AllOutputs:
    """Decode the reply to ``RMB``: ``<sign+7 value><4-digit light><OUT1 OUT2 OUT3 ALARM>``."""
    data = decode_reply(frame, station, READ_ALL, require_bcc=require_bcc)
    m = re.fullmatch(r"([+-]\d{7})(\d{4})([01])([01])([01])([01])", data)
    if not m:
        raise ProtocolError(f"HL-G1 RMB data must be value(8) light(4) and 4 flags, got {data!r}")
    return AllOutputs(
        value_mm=parse_measured(m[1]),
        light_intensity=int(m[2]),
        out1=m[3] == "1",
        out2=m[4] == "1",
        out3=m[5] == "1",
        alarm=m[6] == "1",
    )
