"""Micro-Epsilon optoNCDT 1420 driver over a :class:`~drivers.transport.StreamLink`.

The sensor sends its values continuously as binary frames (output RS422) and
takes ASCII commands at any time; the two may be interleaved on the line.
Every command reply is therefore read through :func:`protocol.separate`,
which takes the frames out and leaves the reply text.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass

import numpy as np

from ..errors import DriverError, ProtocolError, TransportTimeout
from ..readings import DisplacementReading, MeasurementStatus
from ..sensor import DisplacementSensor
from ..transport import StreamLink, open_serial
from . import protocol

_READ_CHUNK = 65536


@dataclass(frozen=True, slots=True)
class StreamBlock:
    """A block of distance values from the continuous output.

    ``values_mm`` (read-only numpy array) is NaN where ``statuses`` is not OK;
    ``raw_counts`` are the 18-bit values as sent.  ``frames_ok`` equals the
    number of values; ``extra_values`` counts additional per-block values
    (H-byte flag ``11``) that were skipped, ``frames_skipped`` good frames
    dropped on purpose (received while mastering changed the scaling).  ``frames_lost``, ``resyncs``
    (runs of damaged bytes the decoder skipped to find the next frame) and
    ``bytes_discarded`` count the damage detected since the previous block.
    ``timestamp_s`` is the host time (``time.time()``) when the last value was
    decoded; ``duration_s`` the host time the block took to read.
    """

    values_mm: np.ndarray
    raw_counts: np.ndarray
    statuses: tuple[MeasurementStatus, ...]
    frames_ok: int
    frames_lost: int
    resyncs: int
    bytes_discarded: int
    extra_values: int
    frames_skipped: int
    timestamp_s: float
    duration_s: float

    @property
    def ok(self) -> bool:
        """Every value valid and no damage detected."""
        return self.frames_lost == 0 and self.resyncs == 0 and all(
            s is MeasurementStatus.OK for s in self.statuses
        )


class ILD1420(DisplacementSensor):
    """optoNCDT 1420 on RS-422 (factory setting 921.6 kBd 8N1).

    ``measuring_range_mm`` (MR, e.g. 10, 25, 50 mm for ILD1420-10/-25/-50)
    scales the counts; :meth:`identify` reads it from the sensor with GETINFO.
    """

    protocol = "me-ild1420"
    identity_query = True  # GETINFO

    def __init__(
        self,
        link: StreamLink,
        *,
        measuring_range_mm: float = 10.0,
        endpoint: str = "",
        timeout_s: float = 0.5,
    ) -> None:
        super().__init__(link, endpoint=endpoint, timeout_s=timeout_s)
        if not measuring_range_mm > 0:
            raise ValueError("measuring_range_mm must be > 0")
        self._stream_link = link
        self.measuring_range_mm = measuring_range_mm
        self.mastered = False
        self._output: str | None = None  # None until the driver knows (device default unknown)
        self._streaming = False
        self._fresh = False
        self._decoder = protocol.FrameDecoder()
        # decoded (raw, values_mm, status codes) chunks not yet handed out
        self._backlog: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._extra_pending = 0
        self._skipped_pending = 0
        self._damage_seen = (0, 0, 0)

    @classmethod
    def from_url(cls, url: str, *, baudrate: int = 921600, measuring_range_mm: float = 10.0,
                 timeout_s: float = 0.5) -> ILD1420:
        """Open ``url`` (any pyserial URL) at 8N1 and return a driver."""
        return cls(open_serial(url, baudrate=baudrate), measuring_range_mm=measuring_range_mm,
                   endpoint=url, timeout_s=timeout_s)

    # -- commands ---------------------------------------------------------------------------

    def command(self, request: bytes, *, keep_values: bool = True) -> protocol.Reply:
        """Send one encoded command and return its reply.

        While streaming, values read with the reply are kept for
        :meth:`read_stream`, or counted as skipped with ``keep_values=False``.
        """
        may_stream = self._output != "NONE" and self._output != "ANALOG"
        if not self._streaming:
            self._link.discard_input()
        buf = bytearray(self._decoder.take_carry() if self._streaming else b"")
        stream_start = may_stream and (not self._streaming or self._fresh)
        self._fresh = False
        self._link.write(request)
        deadline = time.monotonic() + self.timeout_s
        while True:
            frames, text = protocol.separate(bytes(buf), stream_start=stream_start)
            idx = text.find(protocol.PROMPT)
            if idx >= 0:
                break
            left = deadline - time.monotonic()
            chunk = self._stream_link.read_some(_READ_CHUNK, left) if left > 0 else b""
            if not chunk:
                if self._streaming:
                    self._take(frames)  # values read while waiting stay accounted for
                name = request.split(b" ")[0].strip().decode("ascii", "replace")
                raise TransportTimeout(
                    f"no '->' prompt from {self.endpoint or 'the ILD1420'} within {self.timeout_s:.3g} s "
                    f"after {name} (got {text[-60:]!r})"
                )
            buf += chunk
        if frames and not may_stream:
            raise ProtocolError(
                f"binary bytes in the ILD1420 reply to {request!r} while output is {self._output}"
            )
        reply_text, rest = text[: idx + len(protocol.PROMPT)], text[idx + len(protocol.PROMPT):]
        if self._streaming:
            self._take(frames + rest, keep=keep_values)
        return protocol.parse_reply(reply_text, request)

    def identify(self) -> dict[str, str]:
        """GETINFO as a dict (``Name``, ``Serial``, ``Measuring range``, ``Version``, ...).

        Adopts the sensor's measuring range for the scaling when it reports one.
        """
        info = protocol.decode_getinfo(self.command(protocol.encode_getinfo()))
        if "Measuring range" in info:
            self.measuring_range_mm = protocol.parse_measuring_range_mm(info["Measuring range"])
        return {"model": info["Name"], **{k.lower().replace(" ", "_"): v for k, v in info.items()}}

    def set_output(self, mode: str) -> None:
        """Select the value output: ``NONE``, ``RS422`` (binary stream) or ``ANALOG``."""
        request = protocol.encode_output(mode)
        protocol.expect_no_lines(self.command(request), "OUTPUT")
        self._output = mode.upper()

    def get_output(self) -> str:
        self._output = protocol.decode_output(self.command(protocol.encode_output()))
        return self._output

    def set_echo(self, on: bool) -> None:
        protocol.expect_no_lines(self.command(protocol.encode_echo(on)), "ECHO")

    def get_measrate_khz(self) -> float:
        return protocol.decode_measrate(self.command(protocol.encode_measrate()))

    def set_measrate_khz(self, khz: float) -> None:
        protocol.expect_no_lines(self.command(protocol.encode_measrate(khz)), "MEASRATE")

    def master(self, master_mm: float = 0.0) -> None:
        """``MASTERMV MASTER <mm>``: the next value reads ``master_mm`` (0 = zero here).

        Values decoded afterwards use the mastered scaling (offset -0.51).
        While streaming, values that arrive during the command are skipped
        (counted in ``StreamBlock.frames_skipped``): which scaling they were
        sent with is not known.
        """
        request = protocol.encode_master(master_mm, self.measuring_range_mm)
        protocol.expect_no_lines(self.command(request, keep_values=False), "MASTERMV")
        self.mastered = True

    def unmaster(self) -> None:
        """``MASTERMV NONE``: back to distances over the measuring range (values in flight skipped)."""
        protocol.expect_no_lines(self.command(protocol.encode_master_none(), keep_values=False), "MASTERMV")
        self.mastered = False

    # -- polled value -----------------------------------------------------------------------

    def read_once(self) -> DisplacementReading:
        """The newest distance value from the stream (mm).

        The 1420 has no poll command in protocols.md: it streams while the
        output is RS422.  This drops what is buffered, then waits for the next
        complete first-of-block frame and returns the newest one received.
        Raises :class:`TransportTimeout` if no frame arrives (output not RS422?).
        """
        if self._streaming:
            raise RuntimeError("read_once() while a stream is running; use read_stream()")
        self._link.discard_input()
        decoder = protocol.FrameDecoder()
        deadline = time.monotonic() + self.timeout_s
        while True:
            left = deadline - time.monotonic()
            chunk = self._stream_link.read_some(_READ_CHUNK, left) if left > 0 else b""
            if not chunk:
                raise TransportTimeout(
                    f"no measurement frame from {self.endpoint or 'the ILD1420'} within {self.timeout_s:.3g} s; "
                    "is the output set to RS422 (OUTPUT RS422)?"
                )
            raw, first = decoder.feed(chunk)
            raw = raw[first]
            if len(raw):
                break
        values, codes = protocol.decode_values(raw[-1:], self.measuring_range_mm, mastered=self.mastered)
        return DisplacementReading(
            value_mm=float(values[0]),
            status=protocol.STATUS_BY_CODE[int(codes[0])],
            timestamp_s=time.time(),
            raw=str(int(raw[-1])),
        )

    # -- continuous output ------------------------------------------------------------------

    def start_stream(self, *, set_output: bool = True) -> None:
        """Start continuous acquisition (sends ``OUTPUT RS422`` unless ``set_output`` is False).

        Buffered input is dropped first; every frame from then on is accounted for.
        """
        self._link.discard_input()
        self._decoder.reset()
        self._backlog = []
        self._extra_pending = 0
        self._skipped_pending = 0
        self._damage_seen = (0, 0, 0)
        self._streaming = True
        self._fresh = True  # the first bytes may be the end of a frame sent before the flush
        if set_output:
            try:
                self.set_output("RS422")
            except DriverError:
                self._streaming = False
                raise

    def _take(self, data: bytes, *, keep: bool = True) -> None:
        if self._fresh:
            data = data[protocol.frame_tail_length(data):]
            self._fresh = False
        raw, first = self._decoder.feed(data)
        if not keep:
            self._skipped_pending += len(raw)
        elif len(raw):
            distance = raw[first]
            values, codes = protocol.decode_values(distance, self.measuring_range_mm, mastered=self.mastered)
            self._backlog.append((distance, values, codes))
            self._extra_pending += int(len(first) - np.count_nonzero(first))

    def _backlog_len(self) -> int:
        return sum(len(chunk[0]) for chunk in self._backlog)

    def read_stream(self, n: int | None = None, *, duration_s: float | None = None,
                    timeout_s: float | None = None) -> StreamBlock:
        """Read the next ``n`` distance values, or all values arriving within ``duration_s``.

        With ``n``, raises :class:`TransportTimeout` if the line stays silent
        for ``timeout_s`` (default: the driver's timeout) before ``n`` arrived.
        """
        if not self._streaming:
            raise RuntimeError("read_stream() before start_stream()")
        if (n is None) == (duration_s is None):
            raise ValueError("give either n or duration_s")
        if n is not None and n < 1:
            raise ValueError("n must be >= 1")
        silence_s = self.timeout_s if timeout_s is None else timeout_s
        t0 = time.monotonic()
        end = t0 + duration_s if duration_s is not None else None
        last_data = t0
        while True:
            if n is not None and self._backlog_len() >= n:
                break
            now = time.monotonic()
            if end is not None and now >= end:
                break
            wait = min(silence_s, end - now) if end is not None else max(0.0, last_data + silence_s - now)
            chunk = self._stream_link.read_some(_READ_CHUNK, wait) if wait > 0 else b""
            if chunk:
                last_data = time.monotonic()
                self._take(chunk)
            elif n is not None:
                raise TransportTimeout(
                    f"stream from {self.endpoint or 'the ILD1420'} silent for {silence_s:.3g} s "
                    f"({self._backlog_len()} of {n} values received)"
                )
        return self._make_block(n, time.monotonic() - t0)

    def _make_block(self, n: int | None, duration_s: float) -> StreamBlock:
        if self._backlog:
            raw, values, codes = (np.concatenate(parts) for parts in zip(*self._backlog, strict=True))
        else:
            raw, values, codes = np.empty(0, np.int64), np.empty(0), np.empty(0, np.int8)
        self._backlog = []
        if n is not None and len(raw) > n:
            self._backlog = [(raw[n:], values[n:], codes[n:])]
            raw, values, codes = raw[:n], values[:n], codes[:n]
        values.flags.writeable = False
        raw.flags.writeable = False
        d = self._decoder
        seen_lost, seen_resync, seen_bytes = self._damage_seen
        self._damage_seen = (d.frames_lost, d.resyncs, d.bytes_discarded)
        extra, self._extra_pending = self._extra_pending, 0
        skipped, self._skipped_pending = self._skipped_pending, 0
        table = protocol.STATUS_BY_CODE
        return StreamBlock(
            values_mm=values,
            raw_counts=raw,
            statuses=tuple(table[c] for c in codes.tolist()),
            frames_ok=len(raw),
            frames_lost=d.frames_lost - seen_lost,
            resyncs=d.resyncs - seen_resync,
            bytes_discarded=d.bytes_discarded - seen_bytes,
            extra_values=extra,
            frames_skipped=skipped,
            timestamp_s=time.time(),
            duration_s=duration_s,
        )

    def stop_stream(self) -> StreamBlock | None:
        """Stop the output (``OUTPUT NONE``); return the values not yet handed out.

        The returned block also holds the frames that arrived with the reply,
        so blocks from :meth:`read_stream` plus this one account for every
        frame received.  ``None`` if no stream was running.
        """
        if not self._streaming:
            return None
        t0 = time.monotonic()
        try:
            self.set_output("NONE")
            self._decoder.flush()
            return self._make_block(None, time.monotonic() - t0)
        finally:
            self._streaming = False
            self._backlog = []
            self._decoder.reset()
            self._link.discard_input()

    @property
    def streaming(self) -> bool:
        return self._streaming

    def close(self) -> None:
        if self._streaming:
            with contextlib.suppress(DriverError):  # best effort; the port closes below
                self.stop_stream()
        super().close()
