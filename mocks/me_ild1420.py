"""Micro-Epsilon optoNCDT 1420 emulator (RS-422: ASCII commands, binary value stream),
written from protocols.md section 1.6; independent of ``drivers``.

ASCII side: a command line ends with CR (CR LF accepted).  Every reply is its
lines, each ended by CR LF (a lone CR LF - "a return" - when there are none),
then the prompt ``->``; with ``ECHO ON`` the command line comes first; a
refused command answers ``Exxx <message>`` before the prompt.

Commands: ``GETINFO``; ``ECHO [ON|OFF]``; ``OUTPUT [NONE|RS422|ANALOG]``;
``MASTERMV [NONE | MASTER <MV>]`` (MV in mm, 0...2 x MR; the next value reads
MV, ``E104 Timeout`` if there is no value, i.e. no target); ``MEASRATE [<kHz>]``
(0 < rate <= 4 kHz; number format INFERRED).  Anything else, or a bad
parameter, is refused with ``E<reject_code>``: protocols.md does not give the
sensor's numbers for those cases, so the code is a constructor parameter.

Binary side: while the output is RS422, :meth:`ILD1420Emulator.stream_bytes`
gives frames of three bytes L/M/H (flags ``00``, ``01``, ``10`` = first value
of a block) with ``digital = (x / MR + 0.01) * 65520 / 1.02`` (offset 0.51
when mastered); a distance outside what 16 bits can code, or no target,
sends ``error_raw`` (an 18-bit error value; the manual's list of error values
is not in protocols.md).  :class:`StreamPacer` pushes the frames out at the
measuring rate.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable

from .faults import FaultPlan
from .sensor_faults import apply_sensor_fault, flip_bit7

CR = b"\r"
CRLF = b"\r\n"
PROMPT = b"->"
OUTPUTS = ("NONE", "RS422", "ANALOG")
MAX_RATE_KHZ = 4.0


def encode_frame(raw: int, *, first: bool = True) -> bytes:
    """Three bytes L, M, H of an 18-bit value (manual §8.2)."""
    if not 0 <= raw < 1 << 18:
        raise ValueError(f"ILD1420 values are 18 bit, not {raw}")
    h_flags = 0x80 if first else 0xC0
    return bytes((raw & 0x3F, 0x40 | ((raw >> 6) & 0x3F), h_flags | ((raw >> 12) & 0x3F)))


def counts_for_mm(x_mm: float, measuring_range_mm: float, *, mastered: bool = False) -> int:
    """Inverse of ``x = (digital * 1.02 / 65520 - offset) * MR``, rounded to a count."""
    offset = 0.51 if mastered else 0.01
    return round((x_mm / measuring_range_mm + offset) * 65520 / 1.02)


class ILD1420Emulator:
    """Byte-in/byte-out optoNCDT 1420 with a value stream.

    ``source(1)`` gives the distance in mm from the start of the measuring
    range (0...MR), or ``None`` when the beam sees no target.
    """

    def __init__(
        self,
        source: Callable[[int], float | None],
        *,
        faults: FaultPlan | None = None,
        measuring_range_mm: float = 10.0,
        measrate_khz: float = 2.0,
        output: str = "RS422",
        echo: bool = False,
        serial: str = "15030002",
        error_raw: int = (1 << 18) - 1,
        reject_code: int = 200,
    ) -> None:
        self._source = source
        self.faults = faults or FaultPlan()
        self.measuring_range_mm = measuring_range_mm
        self.measrate_khz = measrate_khz
        self.output = output
        self.echo = echo
        self.serial = serial
        self.error_raw = error_raw
        self.reject_code = reject_code
        self.master_mm: float | None = None  # None: not mastered
        self._master_shift_mm = 0.0
        self.lock = threading.RLock()
        self.frames_sent = 0
        self.frames_broken = 0
        self._stream_faults: dict[int, tuple[str, int, int]] = {}
        self._buffer = bytearray()

    # -- ASCII commands ---------------------------------------------------------------------

    def receive(self, data: bytes) -> bytes:
        """Feed received bytes; return the bytes to send back (possibly empty)."""
        out = bytearray()
        with self.lock:
            self._buffer += data
            while (idx := self._buffer.find(CR)) >= 0:
                line = bytes(self._buffer[:idx]).strip(b"\n")
                del self._buffer[: idx + 1]
                out += self._apply_fault(line, self.handle_line(line))
        return bytes(out)

    def _apply_fault(self, line: bytes, reply: bytes) -> bytes:
        def error_reply(arg: str | None) -> bytes:
            code = int(arg or 104)
            text = {104: "Timeout", 202: "Access denied"}.get(code, "Error")
            return (line + CRLF if self.echo else b"") + f"E{code:03d} {text}".encode() + CRLF + PROMPT

        # the noise is 7-bit: bytes with bit 7 set would be taken for value frames
        return apply_sensor_fault(self.faults, reply, terminator=CRLF + PROMPT, error_reply=error_reply,
                                  corrupt=flip_bit7, garbage=b"#?\x13\x7f!")

    def handle_line(self, line: bytes) -> bytes:
        """The complete reply (echo, lines, prompt) to one command line without its CR."""
        try:
            text = line.decode("ascii")
        except UnicodeDecodeError:
            text = None
        echo = line + CRLF if self.echo else b""
        try:
            lines = self._execute(text) if text is not None else self._refuse("Unknown command")
        except _Refused as exc:
            lines = [str(exc)]
        body = b"".join(s.encode("ascii") + CRLF for s in lines)
        if not echo and not body:
            body = CRLF  # "always a return and a prompt"
        return echo + body + PROMPT

    def _refuse(self, message: str) -> list[str]:
        raise _Refused(f"E{self.reject_code:03d} {message}")

    def _execute(self, text: str) -> list[str]:
        fields = text.split()
        if not fields:
            return []
        name, args = fields[0].upper(), [a.upper() for a in fields[1:]]
        if name == "GETINFO" and not args:
            return self._info()
        if name == "ECHO":
            if not args:
                return [f"ECHO {'ON' if self.echo else 'OFF'}"]
            if args in (["ON"], ["OFF"]):
                self.echo = args[0] == "ON"
                return []
            return self._refuse("Wrong parameter")
        if name == "OUTPUT":
            if not args:
                return [f"OUTPUT {self.output}"]
            if len(args) == 1 and args[0] in OUTPUTS:
                self.output = args[0]
                return []
            return self._refuse("Wrong parameter")
        if name == "MASTERMV":
            return self._mastermv(args)
        if name == "MEASRATE":
            if not args:
                return [f"MEASRATE {self.measrate_khz:g}"]
            try:
                rate = float(args[0])
            except ValueError:
                rate = float("nan")
            if len(args) != 1 or not 0 < rate <= MAX_RATE_KHZ:
                return self._refuse("Wrong parameter")
            self.measrate_khz = rate
            return []
        return self._refuse("Unknown command")

    def _info(self) -> list[str]:
        return [
            f"Name: ILD1420-{self.measuring_range_mm:g}",
            f"Serial: {self.serial}",
            "Option: 000",
            "Article: 4120212",
            "Cable head: Wire",
            f"Measuring range: {self.measuring_range_mm:.2f}mm",
            "Version: 001.010",
            "Hardware-rev: 00",
            "Boot-version: 001.000",
        ]

    def _mastermv(self, args: list[str]) -> list[str]:
        if not args:
            if self.master_mm is None:
                return ["MASTERMV NONE"]
            return [f"MASTERMV MASTER {self.master_mm:.6f}"]
        if args == ["NONE"]:
            self.master_mm = None
            self._master_shift_mm = 0.0
            return []
        if len(args) == 2 and args[0] == "MASTER":
            try:
                mv = round(float(args[1]), 6)
            except ValueError:
                return self._refuse("Wrong parameter")
            if not 0.0 <= mv <= 2 * self.measuring_range_mm:
                return self._refuse("Wrong parameter")
            d = self._source(1)
            if d is None:
                raise _Refused("E104 Timeout")
            self.master_mm = mv
            self._master_shift_mm = mv - d
            return []
        return self._refuse("Wrong parameter")

    # -- binary stream ----------------------------------------------------------------------

    def current_raw(self) -> int:
        """The 18-bit value the sensor would send now."""
        d = self._source(1)
        if d is None:
            return self.error_raw
        mastered = self.master_mm is not None
        x = d + self._master_shift_mm if mastered else d
        raw = counts_for_mm(x, self.measuring_range_mm, mastered=mastered)
        return raw if 0 <= raw <= 65519 else self.error_raw

    def schedule_stream_fault(self, frame_index: int, kind: str = "drop", *, position: int = 1,
                              byte: int = 0x7F) -> None:
        """Break frame number ``frame_index`` (0-based, counted from the first frame sent).

        ``drop``: the byte at ``position`` (0 = L, 1 = M, 2 = H) is not sent.
        ``garbage``: ``byte`` is inserted after the byte at ``position``.  The
        protocol has no checksum, so a stray byte whose flag bits fit the
        expected sequence cannot be detected; the default 0x7F (flags ``01``
        after M) can.
        """
        if kind not in ("drop", "garbage") or position not in (0, 1, 2) or not 0 <= byte <= 0xFF:
            raise ValueError(f"bad stream fault {kind!r} at position {position}")
        with self.lock:
            self._stream_faults[frame_index] = (kind, position, byte)

    def stream_bytes(self, n_frames: int) -> bytes:
        """The next ``n_frames`` frames of the continuous output (empty unless OUTPUT RS422)."""
        with self.lock:
            if self.output != "RS422":
                return b""
            out = bytearray()
            for _ in range(n_frames):
                frame = encode_frame(self.current_raw())
                fault = self._stream_faults.pop(self.frames_sent, None)
                if fault is not None:
                    kind, pos, byte = fault
                    if kind == "drop":
                        frame = frame[:pos] + frame[pos + 1 :]
                    else:
                        frame = frame[: pos + 1] + bytes([byte]) + frame[pos + 1 :]
                    self.frames_broken += 1
                out += frame
                self.frames_sent += 1
            return bytes(out)


class _Refused(Exception):
    """A command the emulator answers with an ``Exxx`` line."""


class StreamPacer:
    """A thread writing the emulator's frames through ``write`` at its measuring rate.

    Frames go out in bursts every ``batch_s`` (like a USB-serial adapter
    delivers them); the average rate is exact.  The emulator lock is held
    while writing, so no frame follows the reply to ``OUTPUT NONE``.  Use
    with ``PtyEndpoint.write_unsolicited``.  ``ready()`` false (say, the
    line's buffer is full: nobody reads): the frames of that interval are not
    made, as if lost on a line without a reader.
    """

    def __init__(self, emulator: ILD1420Emulator, write: Callable[[bytes], None], *,
                 batch_s: float = 0.005, ready: Callable[[], bool] | None = None) -> None:
        self.emulator = emulator
        self._write = write
        self._ready = ready
        self.batch_s = batch_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="ILD1420StreamPacer", daemon=True)
        self.error: OSError | None = None

    def start(self) -> StreamPacer:
        self._thread.start()
        return self

    def _run(self) -> None:
        emu = self.emulator
        last = time.monotonic()
        owed = 0.0
        while not self._stop.wait(self.batch_s):
            now = time.monotonic()
            with emu.lock:
                if emu.output != "RS422" or (self._ready is not None and not self._ready()):
                    owed = 0.0
                else:
                    owed += (now - last) * emu.measrate_khz * 1000.0
                    n = int(owed)
                    owed -= n
                    if n:
                        try:
                            self._write(emu.stream_bytes(n))
                        except OSError as exc:  # endpoint closed under us
                            self.error = exc
                            return
            last = now

    def stop(self) -> None:
        self._stop.set()
        with contextlib.suppress(RuntimeError):
            self._thread.join(timeout=2)

    def __enter__(self) -> StreamPacer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
