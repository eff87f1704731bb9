"""Pure codec for the Keyence LK-G3000 / LK-G5000 RS-232C command set (no I/O).

Source: KEYENCE LK-G Series User Manual (LK-G-M-NO5-E) ch. 5 and, for the
command list, the public drivers cited in ``protocols.md`` sections 1.1/1.2.
Commands and replies are ASCII delimited by CR (upper or lower case); a reply
repeats the command (and its identifiers) as its header; errors are
``ER,<main command>,<nn>``.

A measured value is a fixed 8-character field: sign plus 7 characters
including the decimal point (``+01.2345``); ``+FFFFFFF``/``-FFFFFFF`` mean over
the + / - range, ``XXXXXXXX`` alarm/invalid and ``--------`` no value.  A
setting is written as sign plus six digits without a decimal point
(``+012345``); read back it has the decimal point added (``+01.2345``).

Commands (LK-G3000 unless noted):

========================  =====================================  ==================
request                   meaning                                reply
========================  =====================================  ==================
``M0`` / ``M1`` / ``M2``  OUT1 and OUT2 / OUT1 / OUT2             ``M0,<v1>,<v2>``
``MS,<nn>`` (LK-G5000)    OUT ``nn`` (two digits)                ``MS,<nn>,<v>``
``Q0`` / ``R0``           set-up (communication) / measure mode  ``Q0`` / ``R0``
``VR,<0|1|2>``            reset (0 = both outputs)               ``VR``
``SW,OF,<nn>,<value>``    write the offset (set-up mode)         ``SW,OF``
``SR,OF,<nn>``            read the offset                        ``SR,OF,<nn>,<v>``
``SW,HB,<nn>,<fn>``       set a head's measurement mode          ``SW,HB``
``SR,HB,<nn>``            read a head's measurement mode         ``SR,HB,<nn>,<fn>``
========================  =====================================  ==================
"""

from __future__ import annotations

import re

from ..errors import DeviceError, ProtocolError
from ..readings import MeasurementStatus

TERMINATOR = b"\r"

ERROR_TEXT: dict[str, str] = {
    "00": "Command error",
    "01": "Status error",
    "20": "Command length error",
    "21": "Parameter count error",
    "22": "Invalid parameter error",
    "88": "Timeout error",
    "99": "Other errors",
}

_SPECIAL = {
    "+FFFFFFF": MeasurementStatus.OVER_RANGE_HIGH,
    "-FFFFFFF": MeasurementStatus.OVER_RANGE_LOW,
    "XXXXXXXX": MeasurementStatus.ALARM,
    "--------": MeasurementStatus.NO_VALUE,
}
_NUMBER = re.compile(r"^[+-](?=[0-9.]{7}$)[0-9]*\.?[0-9]*$")
SETTING_DIGITS = 6
MAX_MS_OUTPUT = 99


def encode(main: str, *params: str) -> bytes:
    """Encode ``main[,param...]`` followed by CR."""
    text = ",".join((main, *params))
    if not text.isascii() or "\r" in text:
        raise ValueError(f"not a valid LK-G command: {text!r}")
    return text.encode("ascii") + TERMINATOR  # pragma: no mutate (equivalent: "ASCII" is the same codec)


def _out_id(output: int, *, low: int = 1, high: int = 2) -> str:
    if not low <= output <= high:
        raise ValueError(f"LK-G output/head must be {low}..{high}, not {output}")
    return f"{output:02d}"


def encode_measure(output: int) -> bytes:
    """``M1``/``M2`` reads OUT1/OUT2; ``M0`` reads both (LK-G3000)."""
    if output not in (0, 1, 2):
        raise ValueError(f"LK-G output must be 0 (both), 1 or 2, not {output}")
    return encode(f"M{output}")


def encode_measure_ms(output: int) -> bytes:
    """``MS,<nn>`` reads OUT ``nn`` (LK-G5000, two digits)."""
    return encode("MS", _out_id(output, high=MAX_MS_OUTPUT))


def encode_setup_mode() -> bytes:
    """``Q0``: go to set-up (communication) mode; measurement stops."""
    return encode("Q0")


def encode_measure_mode() -> bytes:
    """``R0``: return to measure (general) mode."""
    return encode("R0")


def encode_reset(output: int) -> bytes:
    """``VR,<0|1|2>``: reset OUT1, OUT2 or both (0)."""
    if output not in (0, 1, 2):
        raise ValueError(f"LK-G reset output must be 0 (both), 1 or 2, not {output}")
    return encode("VR", str(output))


def format_setting(counts: int) -> str:
    """Setting-change format: sign plus six digits, no decimal point (``+012345``)."""
    if abs(counts) >= 10**SETTING_DIGITS:
        raise ValueError(f"LK-G setting {counts} does not fit in {SETTING_DIGITS} digits")
    return f"{'-' if counts < 0 else '+'}{abs(counts):0{SETTING_DIGITS}d}"


def encode_write_offset(output: int, counts: int) -> bytes:
    """``SW,OF,<nn>,<value>``: the offset in units of the displayed last digit."""
    return encode("SW", "OF", _out_id(output), format_setting(counts))


def encode_read_offset(output: int) -> bytes:
    """``SR,OF,<nn>``: read the offset of OUT ``nn``."""
    return encode("SR", "OF", _out_id(output))


def encode_write_head_mode(head: int, function: int) -> bytes:
    """``SW,HB,<nn>,<fn>``: set the measurement mode of head ``nn``."""
    if not 0 <= function <= 99:
        raise ValueError(f"LK-G head measurement mode must be 0..99, not {function}")
    return encode("SW", "HB", _out_id(head), str(function))


def encode_read_head_mode(head: int) -> bytes:
    """``SR,HB,<nn>``: read the measurement mode of head ``nn``."""
    return encode("SR", "HB", _out_id(head))


def parse_value(field: str) -> tuple[float, MeasurementStatus]:
    """Decode one 8-character value field into (mm, status)."""
    if len(field) != 8:
        raise ProtocolError(f"LK-G value field must be 8 characters, got {field!r}")
    special = _SPECIAL.get(field.upper())
    if special is not None:
        return float("nan"), special  # pragma: no mutate (equivalent: "NAN" parses to the same NaN)
    # _NUMBER admits a sign then exactly 7 of [0-9.] with at most one point, hence at least six digits:
    # no separate check for a second point or a field without digits is needed.
    if not _NUMBER.match(field):
        raise ProtocolError(f"malformed LK-G value field {field!r}")
    return float(field), MeasurementStatus.OK


def decimals_of(field: str) -> int:
    """Digits after the decimal point of a valid numeric field (0 without a point)."""
    parse_value(field)
    # parse_value allows at most one point, so index and rindex agree
    return len(field) - field.index(".") - 1 if "." in field else 0  # pragma: no mutate (equivalent)


def split_reply(frame: bytes, command: str) -> list[str]:
    """Check the header of a reply to ``command`` and return the fields after it.

    ``command`` is the main command, optionally with identifiers that the reply
    must repeat (``"SR,OF,01"``).  Raises :class:`DeviceError` for
    ``ER,<cmd>,<nn>`` and :class:`ProtocolError` for anything that is not a
    well-formed reply to ``command``.
    """
    if not frame.endswith(TERMINATOR):
        raise ProtocolError(f"LK-G reply not terminated by CR: {frame!r}")
    try:
        text = frame[:-1].decode("ascii")  # pragma: no mutate (equivalent: "ASCII" is the same codec)
    except UnicodeDecodeError as exc:
        raise ProtocolError(f"non-ASCII bytes in LK-G reply {frame!r}") from exc
    if "\r" in text or "\n" in text:
        raise ProtocolError(f"LK-G reply contains a stray line break: {frame!r}")
    fields = text.split(",")
    header = command.upper().split(",")
    main = header[0]
    if fields[0].upper() == "ER":
        if len(fields) != 3 or fields[1].upper() != main or not re.fullmatch(r"\d\d", fields[2]):
            raise ProtocolError(f"malformed LK-G error reply {frame!r}")
        code = fields[2]
        raise DeviceError(code, ERROR_TEXT.get(code, "unknown error code"), command=main)
    if [f.upper() for f in fields[: len(header)]] != header:
        raise ProtocolError(f"LK-G reply {frame!r} does not answer {command!r}")
    return fields[len(header):]


def decode_measure(frame: bytes, output: int) -> list[tuple[float, MeasurementStatus]]:
    """Decode the reply to ``M<output>``: one value (M1/M2) or two (M0)."""
    fields = split_reply(frame, f"M{output}")
    expected = 2 if output == 0 else 1
    if len(fields) != expected:
        raise ProtocolError(f"LK-G M{output} reply needs {expected} value(s): {frame!r}")
    return [parse_value(f) for f in fields]


def decode_measure_ms(frame: bytes, output: int) -> tuple[float, MeasurementStatus]:
    """Decode ``MS,<nn>,<value>`` (the reply repeats the output number)."""
    fields = split_reply(frame, f"MS,{output:02d}")
    if len(fields) != 1:
        raise ProtocolError(f"LK-G MS reply needs one value: {frame!r}")
    return parse_value(fields[0])


def decode_ack(frame: bytes, command: str) -> None:
    """Decode a reply that only repeats its header (``Q0``, ``R0``, ``VR``, ``SW,OF``)."""
    fields = split_reply(frame, command)
    if fields:
        raise ProtocolError(f"LK-G reply to {command!r} has unexpected fields: {frame!r}")


def decode_read_offset(frame: bytes, output: int) -> tuple[float, int]:
    """Decode ``SR,OF,<nn>,<value>`` into (offset in mm, decimals shown)."""
    fields = split_reply(frame, f"SR,OF,{output:02d}")
    if len(fields) != 1:
        raise ProtocolError(f"LK-G SR,OF reply needs one value: {frame!r}")
    value, status = parse_value(fields[0])
    if status is not MeasurementStatus.OK:
        raise ProtocolError(f"LK-G offset is not a number: {frame!r}")
    return value, decimals_of(fields[0])


def decode_read_head_mode(frame: bytes, head: int) -> int:
    """Decode ``SR,HB,<nn>,<fn>`` into the function number."""
    fields = split_reply(frame, f"SR,HB,{head:02d}")
    if len(fields) != 1 or not re.fullmatch(r"\d{1,2}", fields[0]):
        raise ProtocolError(f"LK-G SR,HB reply needs one function number: {frame!r}")
    return int(fields[0])
