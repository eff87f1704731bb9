"""Pure codec for the Keyence LK-G3000 RS-232C command set (no I/O).

Source: KEYENCE LK-G Series User Manual (LK-G-M-NO5-E) ch. 5, summarised in
``protocols.md`` section 1.1.  Commands and replies are ASCII delimited by CR;
the reply repeats the command as its header; errors are ``ER,<cmd>,<nn>``.
A measured value is a fixed 8-character field: sign plus 7 characters
including the decimal point (``+01.2345``); ``+FFFFFFF``/``-FFFFFFF`` mean over
range, ``XXXXXXXX`` alarm/invalid and ``--------`` no value.
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


def encode(main: str, *params: str) -> bytes:
    """Encode ``main[,param...]`` followed by CR."""
    text = ",".join((main, *params))
    if not text.isascii() or "\r" in text:
        raise ValueError(f"not a valid LK-G command: {text!r}")
    return text.encode("ascii") + TERMINATOR


def encode_measure(output: int) -> bytes:
    """``M1``/``M2`` reads OUT1/OUT2; ``M0`` reads both."""
    if output not in (0, 1, 2):
        raise ValueError(f"LK-G output must be 0 (both), 1 or 2, not {output}")
    return encode(f"M{output}")


def parse_value(field: str) -> tuple[float, MeasurementStatus]:
    """Decode one 8-character value field into (mm, status)."""
    if len(field) != 8:
        raise ProtocolError(f"LK-G value field must be 8 characters, got {field!r}")
    special = _SPECIAL.get(field.upper())
    if special is not None:
        return float("nan"), special
    if not _NUMBER.match(field) or field.count(".") > 1 or not any(c.isdigit() for c in field):
        raise ProtocolError(f"malformed LK-G value field {field!r}")
    return float(field), MeasurementStatus.OK


def split_reply(frame: bytes, command: str) -> list[str]:
    """Check the header of a reply to ``command`` and return the fields after it.

    Raises :class:`DeviceError` for ``ER,<cmd>,<nn>`` and :class:`ProtocolError`
    for anything that is not a well-formed reply to ``command``.
    """
    if not frame.endswith(TERMINATOR):
        raise ProtocolError(f"LK-G reply not terminated by CR: {frame!r}")
    try:
        text = frame[:-1].decode("ascii")
    except UnicodeDecodeError as exc:
        raise ProtocolError(f"non-ASCII bytes in LK-G reply {frame!r}") from exc
    if "\r" in text or "\n" in text:
        raise ProtocolError(f"LK-G reply contains a stray line break: {frame!r}")
    fields = text.split(",")
    main = command.split(",")[0].upper()
    if fields[0].upper() == "ER":
        if len(fields) != 3 or fields[1].upper() != main or not re.fullmatch(r"\d\d", fields[2]):
            raise ProtocolError(f"malformed LK-G error reply {frame!r}")
        code = fields[2]
        raise DeviceError(code, ERROR_TEXT.get(code, "unknown error code"), command=main)
    if fields[0].upper() != main:
        raise ProtocolError(f"LK-G reply {frame!r} does not answer {main!r}")
    return fields[1:]


def decode_measure(frame: bytes, output: int) -> list[tuple[float, MeasurementStatus]]:
    """Decode the reply to ``M<output>``: one value (M1/M2) or two (M0)."""
    fields = split_reply(frame, f"M{output}")
    expected = 2 if output == 0 else 1
    if len(fields) != expected:
        raise ProtocolError(f"LK-G M{output} reply needs {expected} value(s): {frame!r}")
    return [parse_value(f) for f in fields]
