"""Byte transport over any pyserial URL.

The transport knows nothing about protocols: it writes bytes and reads until a
terminator or a byte count, with a deadline.  Drivers receive an open
:class:`SerialLink`; only :func:`open_serial` opens ports, always through
``serial.serial_for_url`` so ``/dev/ttyUSB0``, ``/dev/pts/N``,
``socket://host:port`` and ``loop://`` all work.
"""

from __future__ import annotations

import contextlib
import time
from typing import Protocol

import serial

from .errors import ConnectionLost, TransportTimeout

try:
    import termios
except ImportError:  # Windows: no termios
    _PORT_ERRORS: tuple[type[BaseException], ...] = (serial.SerialException, OSError)
else:
    # pyserial lets termios.error (not an OSError) out of flush()/tcsetattr on a hung-up tty.
    _PORT_ERRORS = (serial.SerialException, OSError, termios.error)


class ByteLink(Protocol):
    """What a driver needs from a transport."""

    def write(self, data: bytes) -> None: ...

    def read_until(self, terminator: bytes, timeout_s: float) -> bytes: ...

    def read_exact(self, count: int, timeout_s: float) -> bytes: ...

    def discard_input(self) -> None: ...

    def close(self) -> None: ...


class StreamLink(ByteLink, Protocol):
    """A :class:`ByteLink` that can also hand over whatever has arrived (continuous output)."""

    def read_some(self, max_bytes: int, timeout_s: float) -> bytes: ...


class SerialLink:
    """A :class:`ByteLink` over an open ``serial.SerialBase``."""

    def __init__(self, port: serial.SerialBase) -> None:
        self._port = port
        self._pending = bytearray()

    @property
    def port(self) -> serial.SerialBase:
        return self._port

    def write(self, data: bytes) -> None:
        try:
            self._port.write(data)
            self._port.flush()
        except _PORT_ERRORS as exc:
            raise ConnectionLost(f"write to {self._port.name} failed: {exc}") from exc

    def _read_some(self, deadline: float) -> bytes:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return b""
        try:
            waiting = self._port.in_waiting
            if waiting:  # already there: no wait, so no timeout to re-configure
                return self._port.read(waiting)
            # Setting the timeout re-configures a real port (tcsetattr): a hung-up one fails here.
            self._port.timeout = remaining
            chunk = self._port.read(1)
            if chunk and (more := self._port.in_waiting):
                chunk += self._port.read(more)  # the rest of the burst in the same pass
        except _PORT_ERRORS as exc:
            raise ConnectionLost(f"read from {self._port.name} failed: {exc}") from exc
        return chunk

    def read_until(self, terminator: bytes, timeout_s: float) -> bytes:
        """Return bytes up to and including ``terminator``.

        Raises :class:`TransportTimeout` if the terminator has not arrived
        within ``timeout_s``; the partial data is kept out of the next read.
        """
        deadline = time.monotonic() + timeout_s
        while True:
            idx = self._pending.find(terminator)
            if idx >= 0:
                end = idx + len(terminator)
                frame = bytes(self._pending[:end])
                del self._pending[:end]
                return frame
            chunk = self._read_some(deadline)
            if not chunk:
                partial = bytes(self._pending)
                self._pending.clear()
                raise TransportTimeout(
                    f"no reply ending in {terminator!r} from {self._port.name} within "
                    f"{timeout_s:.3g} s (got {partial!r})"
                )
            self._pending += chunk

    def read_exact(self, count: int, timeout_s: float) -> bytes:
        """Return exactly ``count`` bytes or raise :class:`TransportTimeout`."""
        deadline = time.monotonic() + timeout_s
        while len(self._pending) < count:
            chunk = self._read_some(deadline)
            if not chunk:
                got = len(self._pending)
                self._pending.clear()
                raise TransportTimeout(
                    f"only {got} of {count} bytes from {self._port.name} within {timeout_s:.3g} s"
                )
            self._pending += chunk
        data = bytes(self._pending[:count])
        del self._pending[:count]
        return data

    def read_some(self, max_bytes: int, timeout_s: float) -> bytes:
        """Return up to ``max_bytes`` that have arrived, waiting up to ``timeout_s`` for the first.

        Returns ``b""`` when nothing arrived: for a stream, silence is data, not an error.
        """
        if not self._pending:
            self._pending += self._read_some(time.monotonic() + timeout_s)
        data = bytes(self._pending[:max_bytes])
        del self._pending[:max_bytes]
        return data

    def discard_input(self) -> None:
        """Drop stale bytes (e.g. a late reply to a timed-out request)."""
        self._pending.clear()
        try:
            self._port.reset_input_buffer()
        except _PORT_ERRORS as exc:
            raise ConnectionLost(f"{self._port.name}: {exc}") from exc

    def close(self) -> None:
        with contextlib.suppress(*_PORT_ERRORS):
            self._port.close()


def open_serial(
    url: str,
    *,
    baudrate: int = 115200,
    bytesize: int = 8,
    parity: str = "N",
    stopbits: float = 1,
) -> SerialLink:
    """Open ``url`` with ``serial.serial_for_url`` and wrap it in a :class:`SerialLink`."""
    try:
        port = serial.serial_for_url(
            url,
            baudrate=baudrate,
            bytesize=bytesize,
            parity=parity,
            stopbits=stopbits,
            timeout=0.1,
            exclusive=True if not url.startswith(("socket://", "loop://", "rfc2217://")) else None,
        )
    except (serial.SerialException, OSError, ValueError) as exc:
        raise ConnectionLost(f"cannot open serial port {url!r}: {exc}") from exc
    return SerialLink(port)
