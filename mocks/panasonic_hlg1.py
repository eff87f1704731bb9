"""Panasonic HL-G1 emulator (RS-485, MEWTOCOL-style frames with BCC), written
from protocols.md section 1.5 only; independent of ``drivers``.

Frames: request ``%<st>#<CMD><data><BCC>CR``, reply ``%<st>$<CMD><data><BCC>CR``
or ``%<st>!<nn><BCC>CR``.  BCC = XOR of the bytes from ``%`` to the end of the
data, as two upper-case hex characters; a request with ``**`` instead of a BCC
is not checked and is answered with ``**``.

State machine:

* station number (1..16): requests for another station get no reply (RS-485
  multi-drop; INFERRED).  Bytes before ``%`` are line noise and are skipped.
* setting mode (entered with the head's keys, so set :attr:`setting_mode`
  directly): every request draws error 21.
* laser on/off (``WLR``), zero set (``WZS +00001`` takes the current value as
  zero, ``+00000`` releases it), reset (``WRS``, acknowledged; this model holds
  no hold values to reset), averaging code (``WAV``), threshold A (``WHA``),
  sampling-cycle code (``RSP``, +00001 = 500 us as in the manual's example).
* the value is ``source(1)`` in mm minus the zero-set offset.  No target
  (``None``), laser off or a distance beyond ``range_mm`` raises the ALARM flag
  (``ROA``, RMB); the value field then reads ``+0000000`` (the manual gives no
  alarm representation; a driver must use the flag, never the number).

Errors: undefined command 01, wrong data length/format 03, BCC mismatch 04,
non-ASCII bytes in a frame 11 (stands for a parity/framing error), setting
mode 21, zero set while the alarm is on 22 (execution error; INFERRED).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from functools import reduce

from .faults import FaultPlan
from .sensor_faults import apply_sensor_fault

CR = b"\r"
NO_BCC = "**"
DEFAULT_ERROR = "11"  # communication error: what a noisy line would draw


def bcc_hex(text: str) -> str:
    """XOR of the ASCII bytes of ``text`` as two upper-case hex characters."""
    return f"{reduce(lambda a, c: a ^ ord(c), text, 0):02X}"


def format_counts(value_mm: float) -> str:
    """Sign plus 7 digits in 0.0001 mm (``-12.3456`` -> ``-0123456``)."""
    counts = round(value_mm * 10_000)
    return ("-" if counts < 0 else "+") + f"{abs(counts):07d}"


class PanasonicHLG1Emulator:
    """Byte-in/byte-out HL-G1 head answering as ``station``."""

    def __init__(
        self,
        source: Callable[[int], float | None],
        *,
        station: int = 1,
        range_mm: float = 10.0,
        light_intensity: int = 567,
        faults: FaultPlan | None = None,
    ) -> None:
        if not 1 <= station <= 16:
            raise ValueError("HL-G1 station must be 1..16")
        self._source = source
        self.station = f"{station:02d}"
        self.range_mm = range_mm
        self.light = light_intensity
        self.faults = faults or FaultPlan()
        self.setting_mode = False
        self.laser_on = True
        self.zero_offset_mm = 0.0
        self.averaging_code = 0
        self.threshold_a = "+0000000"
        self.sampling_code = 1
        self.outputs = [False, False, False]  # judgement outputs OUT1..OUT3
        self.resets = 0
        self._buffer = bytearray()

    # wire side ------------------------------------------------------------------------------------
    def receive(self, data: bytes) -> bytes:
        """Feed received bytes; return the bytes to send back (possibly empty)."""
        self._buffer += data
        out = bytearray()
        while (idx := self._buffer.find(CR)) >= 0:
            line = bytes(self._buffer[:idx])
            del self._buffer[: idx + 1]
            start = line.rfind(b"%")
            if start < 0:
                continue
            reply = self.handle_frame(line[start:])
            if reply is None:
                continue
            out += apply_sensor_fault(
                self.faults, reply, terminator=CR,
                error_reply=lambda arg, chk=reply[-3:-1] == b"**": self._error(arg or DEFAULT_ERROR, chk),
                corrupt=self._wrong_bcc,
            )
        return bytes(out)

    def _frame(self, body: str, no_bcc: bool) -> bytes:
        return (body + (NO_BCC if no_bcc else bcc_hex(body))).encode("ascii") + CR

    def _error(self, code: str, no_bcc: bool) -> bytes:
        return self._frame(f"%{self.station}!{code}", no_bcc)

    @staticmethod
    def _wrong_bcc(reply: bytes) -> bytes:
        body = reply[:-3].decode("ascii")
        good = int(bcc_hex(body), 16)
        return (body + f"{good ^ 0x5A:02X}").encode("ascii") + CR

    def handle_frame(self, frame: bytes) -> bytes | None:
        """Answer one request frame (from ``%``, without CR); None = stay silent."""
        text = frame.decode("latin-1")
        if len(text) < 9 or text[3] != "#" or text[1:3] != self.station:
            return None  # not a request, or for another station
        body, check = text[:-2], text[-2:]
        no_bcc = check == NO_BCC
        if any(ord(c) > 0x7E or ord(c) < 0x20 for c in text):
            return self._error("11", no_bcc)
        if not no_bcc and check.upper() != bcc_hex(body):
            return self._error("04", no_bcc)
        if self.setting_mode:
            return self._error("21", no_bcc)
        command, data = body[4:7], body[7:]
        result = self._execute(command, data)
        if result is None:
            return self._error("01", no_bcc)
        if result.startswith("!"):
            return self._error(result[1:], no_bcc)
        return self._frame(f"%{self.station}${command}{result}", no_bcc)

    # device side ----------------------------------------------------------------------------------
    def _raw(self) -> float | None:
        raw = self._source(1)
        if raw is None or not self.laser_on or math.isnan(raw) or abs(raw) > self.range_mm:
            return None
        return raw

    def _alarm(self) -> bool:
        return self._raw() is None

    def _value_field(self) -> str:
        raw = self._raw()
        return "+0000000" if raw is None else format_counts(raw - self.zero_offset_mm)

    def _execute(self, command: str, data: str) -> str | None:
        """Reply data for ``command``; ``"!nn"`` for an error; None if undefined."""
        reads: dict[str, Callable[[], str]] = {
            "RMD": self._value_field,
            "RID": lambda: f"+{0 if self._alarm() else self.light:05d}",
            "ROA": lambda: f"+{int(self._alarm()):05d}",
            "RZA": lambda: f"+{int(self.outputs[0]):05d}",
            "RZB": lambda: f"+{int(self.outputs[1]):05d}",
            "RZC": lambda: f"+{int(self.outputs[2]):05d}",
            "RSP": lambda: f"+{self.sampling_code:05d}",
            "RMB": lambda: (
                self._value_field()
                + f"{0 if self._alarm() else self.light:04d}"
                + "".join(str(int(b)) for b in (*self.outputs, self._alarm()))
            ),
        }
        if command in reads:
            return reads[command]() if data == "" else "!03"
        if command == "WHA":
            if not re.fullmatch(r"[+-]\d{7}", data):
                return "!03"
            self.threshold_a = data
            return ""
        if command in ("WZS", "WRS", "WLR", "WAV"):
            if not re.fullmatch(r"[+-]\d{5}", data):
                return "!03"
            value = int(data)
            if command == "WAV":
                self.averaging_code = value
                return ""
            if value not in (0, 1):
                return "!03"
            if command == "WZS":
                raw = self._raw()
                if value and raw is None:
                    return "!22"  # nothing to take as zero
                self.zero_offset_mm = raw if value and raw is not None else 0.0
            elif command == "WLR":
                self.laser_on = bool(value)
            elif value:
                self.resets += 1
            return ""
        return None
