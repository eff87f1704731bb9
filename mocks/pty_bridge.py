"""A serial null-modem cable made of two pseudo-terminals.

pymodbus's serial server and a serial client each need a device path of their
own, so two pty pairs (both slaves in raw mode, protocols.md 3.1) are joined
by a thread that copies master A <-> master B.  A pty delivers bytes
instantly; the bridge holds each chunk for its wire time at ``baudrate``
(``bits_per_char`` per byte, 11 for 8E1, 10 for 8N1) and sends one direction
at a time, so RTU frames arrive with line timing.  ``tap`` lets a test see or
rewrite the bytes in flight.

Linux ptys reject parity settings (termios EINVAL), so both ends open their
path at 8N1; the timing still models the configured framing.
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
import time
import tty
from collections.abc import Callable


class PtyBridge:
    """Two raw pty endpoints, :attr:`path_a` and :attr:`path_b`, wired back to back."""

    def __init__(self, *, baudrate: int = 19200, bits_per_char: int = 11,
                 tap: Callable[[str, bytes], bytes] | None = None) -> None:
        self.baudrate = baudrate
        self.bits_per_char = bits_per_char
        self.tap = tap
        self._fds: list[int] = []
        self._masters: list[int] = []
        self.paths: list[str] = []
        for _ in range(2):
            master, slave = os.openpty()
            tty.setraw(slave)  # before any byte flows, or the line discipline cooks it
            self._fds += [master, slave]  # keep the slave open: a master read gives EIO otherwise
            self._masters.append(master)
            self.paths.append(os.ttyname(slave))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="pty-bridge", daemon=True)
        self._thread.start()

    @property
    def path_a(self) -> str:
        return self.paths[0]

    @property
    def path_b(self) -> str:
        return self.paths[1]

    def wire_time_s(self, nbytes: int) -> float:
        return nbytes * self.bits_per_char / self.baudrate if self.baudrate else 0.0

    def _run(self) -> None:
        a, b = self._masters
        peer = {a: (b, "a->b"), b: (a, "b->a")}
        line_free = time.monotonic()
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([a, b], [], [], 0.05)
            except (OSError, ValueError):
                return
            for fd in ready:
                try:
                    data = os.read(fd, 4096)
                except OSError:  # EIO while nobody holds the other side open: keep going
                    continue
                dst, direction = peer[fd]
                if self.tap is not None:
                    data = self.tap(direction, data)
                if not data:
                    continue
                # The chunk's last byte leaves the wire after its own wire time, after the line is free.
                due = max(time.monotonic(), line_free) + self.wire_time_s(len(data))
                while (left := due - time.monotonic()) > 0:
                    time.sleep(left)
                line_free = due
                with contextlib.suppress(OSError):
                    os.write(dst, data)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        for fd in self._fds:
            with contextlib.suppress(OSError):
                os.close(fd)
