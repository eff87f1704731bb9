"""Keyence LK-G3000 controller emulator (RS-232C ASCII), written from the
manual's command format (protocols.md section 1.1); independent of ``drivers``.

State machine: measure mode (``R0``) or set-up mode (``Q0``); per output a
zero offset (``SW,OF``); the value source is a callable giving the displacement
in mm for an output, or ``None`` when the beam sees no target.
Replies: ``M1`` -> ``M1,<8-char value>``; ``M0`` -> ``M0,<v1>,<v2>``; an
unknown command -> ``ER,<cmd>,00``; a measurement in set-up mode -> ``ER,<cmd>,01``.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from .faults import FaultPlan

CR = b"\r"


def format_value(value_mm: float | None, decimals: int) -> str:
    """Right-aligned 8-character field: sign + 7 characters (digits and point).

    Over the representable range gives ``+FFFFFFF``/``-FFFFFFF``; no target
    gives ``XXXXXXXX``.
    """
    if value_mm is None:
        return "XXXXXXXX"
    sign = "-" if value_mm < 0 else "+"
    width = 7
    body = f"{abs(value_mm):0{width}.{decimals}f}" if decimals else f"{abs(value_mm):0{width}.0f}"
    if len(body) > width:
        return sign + "F" * 7
    return sign + body


class KeyenceLKGEmulator:
    """Byte-in/byte-out LK-G controller."""

    def __init__(
        self,
        source: Callable[[int], float | None],
        *,
        decimals: int = 5,
        range_mm: float = 5.0,
        faults: FaultPlan | None = None,
    ) -> None:
        self._source = source
        self.decimals = decimals
        self.range_mm = range_mm
        self.setup_mode = False
        self.offset_mm = {1: 0.0, 2: 0.0}
        self.faults = faults or FaultPlan()
        self._buffer = bytearray()

    def receive(self, data: bytes) -> bytes:
        """Feed received bytes; return the bytes to send back (possibly empty)."""
        self._buffer += data
        out = bytearray()
        while (idx := self._buffer.find(CR)) >= 0:
            line = bytes(self._buffer[:idx])
            del self._buffer[: idx + 1]
            out += self._apply_fault(line, self.handle_line(line) + CR)
        return bytes(out)

    def _apply_fault(self, line: bytes, reply: bytes) -> bytes:
        fault = self.faults.next_request("sensor")
        if fault is None:
            return reply
        if fault.kind == "garbage":
            return b"\x8f\x13#?\xfe" + CR
        if fault.kind == "drop":
            return b""
        if fault.kind == "delay":
            time.sleep(float(fault.arg or 1.0))
            return reply
        if fault.kind == "error":
            main = line.split(b",")[0].upper()
            return b"ER," + main + b"," + (fault.arg or "99").encode() + CR
        if fault.kind == "corrupt":
            i = len(reply) // 2
            return reply[:i] + bytes([reply[i] ^ 0x80]) + reply[i + 1 :]
        return reply

    def _value(self, output: int) -> str:
        raw = self._source(output)
        if raw is None:
            return "XXXXXXXX"
        v = raw - self.offset_mm[output]
        if v > self.range_mm:
            return "+FFFFFFF"
        if v < -self.range_mm:
            return "-FFFFFFF"
        return format_value(v, self.decimals)

    def handle_line(self, line: bytes) -> bytes:
        """Answer one command line (without its CR)."""
        try:
            text = line.decode("ascii")
        except UnicodeDecodeError:
            return b"ER,??,00"
        fields = text.split(",")
        main = fields[0].upper()
        args = [f.upper() for f in fields[1:]]

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
        if main == "Q0":
            self.setup_mode = True
            return b"Q0"
        if main == "R0":
            self.setup_mode = False
            return b"R0"
        if main == "VR":
            if len(args) != 1 or args[0] not in ("0", "1", "2"):
                return err("22")
            outs = (1, 2) if args[0] == "0" else (int(args[0]),)
            for o in outs:
                self.offset_mm[o] = 0.0
            return b"VR"
        return err("00")
