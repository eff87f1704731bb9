"""Serial endpoints for byte-level emulators: a real pty pair (raw mode) or a
TCP loopback listener, with line timing at the configured baud rate.

An emulator is any object with ``receive(data: bytes) -> bytes``.  The
endpoint delivers what the emulator answers after the time the request and
the reply would take on the wire (a pty delivers instantly otherwise).

Given the emulator's :class:`~mocks.faults.FaultPlan`, the endpoint carries out
the port-level fault ``close`` (see :mod:`mocks.faults`): behind a pty it
closes its master side (the driver sees a hang-up) and opens a fresh pty pair,
behind TCP it closes the connection and keeps listening.
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import threading
import time
import tty
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

from .faults import FaultPlan


class ByteEmulator(Protocol):
    def receive(self, data: bytes) -> bytes: ...


def wire_time_s(nbytes: int, baudrate: int, bits_per_char: int = 10) -> float:
    """Seconds to send ``nbytes`` at ``baudrate`` (8N1 = 10 bits per character)."""
    return nbytes * bits_per_char / baudrate if baudrate else 0.0


# time.sleep overshoots by the kernel's timer slack (~50-100 us); the last stretch is spun.
_SPIN_S = 0.0003


def sleep_until(due: float) -> None:
    """Wait until ``time.monotonic()`` reaches ``due``, to within a few microseconds."""
    while (left := due - time.monotonic()) > _SPIN_S:
        time.sleep(left - _SPIN_S)
    while time.monotonic() < due:
        pass


class _Endpoint:
    def __init__(self, emulator: ByteEmulator, baudrate: int, bits_per_char: int,
                 faults: FaultPlan | None, device: str) -> None:
        self.emulator = emulator
        self.baudrate = baudrate
        self.bits_per_char = bits_per_char
        self.faults = faults
        self.device = device
        self.link_drops = 0  # ``close`` faults carried out (counted once the link is ready again)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()

    def _answer(self, data: bytes, t_in: float, send: Callable[[bytes], None]) -> bool:
        """Pass ``data`` (seen at ``t_in``) to the emulator and send its reply at line speed.

        Returns False when a ``close`` fault says to drop the link instead of answering.
        """
        with self._lock:
            before = self.faults.requests(self.device) if self.faults else 0
            reply = self.emulator.receive(data)
            if self.faults is not None:
                for n in range(before + 1, self.faults.requests(self.device) + 1):
                    fault = self.faults.fault_for(self.device, n)
                    if fault is not None and fault.kind == "close":
                        return False
        if not reply:
            return True
        if not self.baudrate:
            send(reply)
            return True
        # The request's last byte arrives after its wire time, the reply takes its own and
        # its bytes arrive one after the other: all but the last are there one character
        # before the end (the reader may start on them), the last one exactly at the end.
        due = t_in + wire_time_s(len(data) + len(reply), self.baudrate, self.bits_per_char)
        if len(reply) > 1:
            sleep_until(due - wire_time_s(1, self.baudrate, self.bits_per_char))
            send(reply[:-1])
        sleep_until(due)
        send(reply[-1:])
        return True

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
    """Emulator behind a pseudo-terminal; drivers open :attr:`path` with pyserial.

    ``link``: a path kept as a symlink to the current pty (like udev's
    ``/dev/serial/by-id/...``), so a driver can re-open the same name after a
    ``close`` fault replaced the pty pair.
    """

    def __init__(self, emulator: ByteEmulator, *, baudrate: int = 115200, bits_per_char: int = 10,
                 faults: FaultPlan | None = None, device: str = "sensor",
                 link: str | Path | None = None) -> None:
        super().__init__(emulator, baudrate, bits_per_char, faults, device)
        self.link = Path(link) if link is not None else None
        self._fd_lock = threading.Lock()  # unsolicited writers never see a half-replaced pty pair
        self._open_pair()
        self._wake_r, self._wake_w = os.pipe()  # stop() wakes the serving select at once
        self.start()

    def _open_pair(self) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # before anything is written, or the line discipline cooks it
        self.path = os.ttyname(self._slave)
        if self.link is not None:
            tmp = self.link.with_name(self.link.name + ".new")
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
            tmp.symlink_to(self.path)
            tmp.replace(self.link)  # atomic: the name always points at a pty

    def _close_pair(self) -> None:
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)

    def _run(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master, self._wake_r], [], [], 0.05)
            if self._master not in ready:
                continue
            t_in = time.monotonic()
            try:
                data = os.read(self._master, 4096)
            except OSError:  # EIO while no process has the slave open: keep serving
                time.sleep(0.01)
                continue
            if not data:
                continue
            if not self._answer(data, t_in, self._send):
                # Unplugged: closing the master hangs the driver's side up; the new pair ("re-enumerated")
                # is opened and the link re-pointed first, so the stable name never dangles at a closed pty
                # (a driver re-opening it at once, as an unattended retry does, would get ENOENT)
                with self._fd_lock:
                    old = (self._master, self._slave)
                    self._open_pair()
                    for fd in old:
                        with contextlib.suppress(OSError):
                            os.close(fd)
                self.link_drops += 1

    def _send(self, data: bytes) -> None:
        with contextlib.suppress(OSError):  # the driver may have closed its side meanwhile
            os.write(self._master, data)

    def writable(self) -> bool:
        """Whether the pty's buffer takes more bytes now (False once unread bytes filled it)."""
        with self._fd_lock:
            try:
                return bool(select.select([], [self._master], [], 0)[1])
            except (OSError, ValueError):  # closed by stop()
                return False

    def write_unsolicited(self, data: bytes, *, drop_when_full: bool = False) -> None:
        """Send bytes the device emits on its own (streaming, garbage injection).

        ``drop_when_full``: if the pty's buffer is full (nobody has read the
        stream for a while) the bytes are lost, as on a serial line without a
        reader, instead of blocking the caller until a driver reads.
        """
        if drop_when_full and not self.writable():
            return
        with self._fd_lock:
            os.write(self._master, data)

    def stop(self) -> None:
        self._stop.set()
        if self._wake_w >= 0:
            with contextlib.suppress(OSError):
                os.write(self._wake_w, b"\0")
        super().stop()
        locked = self._fd_lock.acquire(timeout=2)  # a writer blocked on a full pty must not hang stop()
        try:
            self._close_pair()
        finally:
            if locked:
                self._fd_lock.release()
        for fd in (self._wake_r, self._wake_w):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._wake_r = self._wake_w = -1  # a second stop() must not touch re-used descriptor numbers
        if self.link is not None:
            with contextlib.suppress(OSError):
                self.link.unlink()


class TcpEndpoint(_Endpoint):
    """Emulator behind a TCP listener on 127.0.0.1; drivers open ``socket://127.0.0.1:PORT``."""

    def __init__(self, emulator: ByteEmulator, *, baudrate: int = 0, bits_per_char: int = 10,
                 port: int = 0, faults: FaultPlan | None = None, device: str = "sensor") -> None:
        super().__init__(emulator, baudrate, bits_per_char, faults, device)
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
            dropped = False
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
                    try:
                        if not self._answer(data, time.monotonic(), conn.sendall):
                            dropped = True  # close fault: hang up, keep listening
                            break
                    except OSError:
                        break
            if dropped:
                self.link_drops += 1

    def stop(self) -> None:
        super().stop()
        self._sock.close()
