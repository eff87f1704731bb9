"""Keyence LK-G3000/LK-G5000 controller emulator (RS-232C ASCII), written from the
manual's command format (protocols.md sections 1.1, 1.2); independent of ``drivers``.

State machine:

* measure mode (``R0``, the power-on state) or set-up mode (``Q0``).  Measuring
  (``M0``/``M1``/``M2``/``MS``) and reset (``VR``) need measure mode, writing a
  setting (``SW``) needs set-up mode; otherwise ``ER,<cmd>,01`` (status error).
  Reading a setting (``SR``) works in both.
* per output a zero offset (``SW,OF``), subtracted from the value as in the
  ISIS emulator the document cites (the sign convention is INFERRED); ``VR``
  clears it.  Per head a measurement-mode function number (``SW,HB``).
* the value comes from ``source(output)`` in mm: ``None`` = no target
  (``XXXXXXXX``), NaN = not settled (``--------``), beyond ``range_mm`` =
  ``+FFFFFFF``/``-FFFFFFF``.

Errors: unknown command 00, wrong mode 01, parameter count 21, invalid
parameter 22.  The manual describes no error latch: each reply stands alone.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable

from .faults import FaultPlan
from .sensor_faults import apply_sensor_fault, flip_bit7

CR = b"\r"
OVER_RANGE = ("+FFFFFFF", "-FFFFFFF")
INVALID = "XXXXXXXX"
NO_VALUE = "--------"


def format_value(value_mm: float | None, decimals: int) -> str:
    """Right-aligned 8-character field: sign + 7 characters (digits and point).

    Over the representable range gives ``+FFFFFFF``/``-FFFFFFF``; no target
    gives ``XXXXXXXX``.
    """
    if value_mm is None:
        return INVALID
    sign = "-" if value_mm < 0 else "+"
    width = 7
    body = f"{abs(value_mm):0{width}.{decimals}f}" if decimals else f"{abs(value_mm):0{width}.0f}"
    if len(body) > width:
        return sign + "F" * 7
    return sign + body


class KeyenceLKGEmulator:
    """Byte-in/byte-out LK-G controller with ``outputs`` outputs (2 on an LK-G3001)."""

    def __init__(
        self,
        source: Callable[[int], float | None],
        *,
        decimals: int = 5,
        range_mm: float = 5.0,
        outputs: int = 2,
        over_range: tuple[str, str] = OVER_RANGE,
        faults: FaultPlan | None = None,
    ) -> None:
        if outputs < 2:
            raise ValueError("an LK-G controller has at least 2 outputs")
        self._source = source
        self.decimals = decimals
        self.range_mm = range_mm
        self.outputs = outputs
        self.over_range = over_range
        self.setup_mode = False
        self.offset_mm = dict.fromkeys(range(1, outputs + 1), 0.0)
        self.head_mode = dict.fromkeys(range(1, outputs + 1), 0)
        self.faults = faults or FaultPlan()
        self._buffer = bytearray()

    def receive(self, data: bytes) -> bytes:
        """Feed received bytes; return the bytes to send back (possibly empty)."""
        self._buffer += data
        out = bytearray()
        while (idx := self._buffer.find(CR)) >= 0:
            line = bytes(self._buffer[:idx])
            del self._buffer[: idx + 1]
            main = line.split(b",")[0].upper()
            out += apply_sensor_fault(
                self.faults, self.handle_line(line) + CR, terminator=CR,
                error_reply=lambda arg, main=main: b"ER," + main + b"," + (arg or "99").encode() + CR,
                corrupt=flip_bit7,
            )
        return bytes(out)

    def _value(self, output: int) -> str:
        raw = self._source(output)
        if raw is None:
            return INVALID
        if math.isnan(raw):
            return NO_VALUE
        v = raw - self.offset_mm[output]
        if v > self.range_mm:
            return self.over_range[0]
        if v < -self.range_mm:
            return self.over_range[1]
        return format_value(v, self.decimals)

    def _output(self, text: str) -> int | None:
        """An output/head identifier (``1`` or ``01``) within range, else None."""
        if not re.fullmatch(r"\d{1,2}", text) or not 1 <= int(text) <= self.outputs:
            return None
        return int(text)

    def handle_line(self, line: bytes) -> bytes:
        """Answer one command line (without its CR)."""
        try:
            text = line.decode("ascii")
        except UnicodeDecodeError:
            return b"ER,??,00"
        fields = text.upper().split(",")
        main, args = fields[0], fields[1:]

        def err(code: str) -> bytes:
            return f"ER,{main},{code}".encode()

        if main in ("M0", "M1", "M2"):
            if args:
                return err("21")
            if self.setup_mode:
                return err("01")
            if main == "M0":
                return f"M0,{self._value(1)},{self._value(2)}".encode()
            return f"{main},{self._value(int(main[1]))}".encode()
        if main == "MS":
            if len(args) != 1:
                return err("21")
            if len(args[0]) != 2 or (out := self._output(args[0])) is None:
                return err("22")
            if self.setup_mode:
                return err("01")
            return f"MS,{args[0]},{self._value(out)}".encode()
        if main in ("Q0", "R0"):
            if args:
                return err("21")
            self.setup_mode = main == "Q0"
            return main.encode()
        if main == "VR":
            if len(args) != 1:
                return err("21")
            if args[0] not in ("0", "1", "2"):
                return err("22")
            if self.setup_mode:
                return err("01")
            for o in (1, 2) if args[0] == "0" else (int(args[0]),):
                self.offset_mm[o] = 0.0
            return b"VR"
        if main == "SW":
            return self._write_setting(args, err)
        if main == "SR":
            return self._read_setting(args, err)
        return err("00")

    def _write_setting(self, args: list[str], err: Callable[[str], bytes]) -> bytes:
        if not args or args[0] not in ("OF", "HB"):
            return err("22")
        if len(args) != 3:
            return err("21")
        out = self._output(args[1])
        if args[0] == "OF":
            if out is None or not re.fullmatch(r"[+-]\d{6}", args[2]):
                return err("22")
            if not self.setup_mode:
                return err("01")
            self.offset_mm[out] = int(args[2]) / 10**self.decimals
        else:
            if out is None or not re.fullmatch(r"\d{1,2}", args[2]):
                return err("22")
            if not self.setup_mode:
                return err("01")
            self.head_mode[out] = int(args[2])
        return f"SW,{args[0]}".encode()

    def _read_setting(self, args: list[str], err: Callable[[str], bytes]) -> bytes:
        if not args or args[0] not in ("OF", "HB"):
            return err("22")
        if len(args) != 2:
            return err("21")
        out = self._output(args[1])
        if out is None:
            return err("22")
        if args[0] == "OF":
            value = format_value(self.offset_mm[out], self.decimals)
        else:
            value = str(self.head_mode[out])
        return f"SR,{args[0]},{args[1]},{value}".encode()
