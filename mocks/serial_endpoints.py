"""Serial endpoints for byte-level emulators: a real pty pair (raw mode) or a
TCP loopback listener, with line timing at the configured baud rate.

An emulator is any object with ``receive(data: bytes) -> bytes``.  The
endpoint delivers what the emulator answers after the time the request and
the reply would take on the wire (a pty delivers instantly otherwise).
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import threading
import time
import tty
from typing import Protocol


class ByteEmulator(Protocol):
    def receive(self, data: bytes) -> bytes: ...


def wire_time_s(nbytes: int, baudrate: int, bits_per_char: int = 10) -> float:
    """Seconds to send ``nbytes`` at ``baudrate`` (8N1 = 10 bits per character)."""
    return nbytes * bits_per_char / baudrate if baudrate else 0.0


class _Endpoint:
    def __init__(self, emulator: ByteEmulator, baudrate: int, bits_per_char: int) -> None:
        self.emulator = emulator
        self.baudrate = baudrate
        self.bits_per_char = bits_per_char
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()

    def _answer(self, data: bytes) -> bytes:
        t_in = time.monotonic()
        with self._lock:
            reply = self.emulator.receive(data)
        if reply and self.baudrate:
            # The request's last byte arrives after its wire time; the reply takes its own.
            due = t_in + wire_time_s(len(data) + len(reply), self.baudrate, self.bits_per_char)
            while (left := due - time.monotonic()) > 0:
                time.sleep(left)
        return reply

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name=type(self).__name__, daemon=True)
        self._thread.start()

    def _run(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)


class PtyEndpoint(_Endpoint):
    """Emulator behind a pseudo-terminal; drivers open :attr:`path` with pyserial."""

    def __init__(self, emulator: ByteEmulator, *, baudrate: int = 115200, bits_per_char: int = 10) -> None:
        super().__init__(emulator, baudrate, bits_per_char)
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # before anything is written, or the line discipline cooks it
        self.path = os.ttyname(self._slave)
        self.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.05)
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:  # EIO while no process has the slave open: keep serving
                time.sleep(0.01)
                continue
            if not data:
                continue
            reply = self._answer(data)
            if reply:
                with contextlib.suppress(OSError):
                    os.write(self._master, reply)

    def write_unsolicited(self, data: bytes) -> None:
        """Send bytes the device emits on its own (streaming, garbage injection)."""
        os.write(self._master, data)

    def stop(self) -> None:
        super().stop()
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)


class TcpEndpoint(_Endpoint):
    """Emulator behind a TCP listener on 127.0.0.1; drivers open ``socket://127.0.0.1:PORT``."""

    def __init__(self, emulator: ByteEmulator, *, baudrate: int = 0, bits_per_char: int = 10,
                 port: int = 0) -> None:
        super().__init__(emulator, baudrate, bits_per_char)
        self._sock = socket.create_server(("127.0.0.1", port))
        self._sock.settimeout(0.05)
        self.port = self._sock.getsockname()[1]
        self.url = f"socket://127.0.0.1:{self.port}"
        self.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                conn, _ = self._sock.accept()
            except (TimeoutError, OSError):
                continue
            with conn:
                conn.settimeout(0.05)
                while not self._stop.is_set():
                    try:
                        data = conn.recv(4096)
                    except TimeoutError:
                        continue
                    except OSError:
                        break
                    if not data:
                        break
                    reply = self._answer(data)
                    if reply:
                        try:
                            conn.sendall(reply)
                        except OSError:
                            break

    def stop(self) -> None:
        super().stop()
        self._sock.close()
