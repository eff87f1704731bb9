"""PyMeasure-style ``expected_protocol`` for byte drivers.

:class:`ExpectedProtocol` is a fake link holding the exact conversation:
a list of (bytes the driver must send, bytes the device answers).  It fails on
any unexpected, missing or extra byte, and on a reply left unread.
"""

from __future__ import annotations

from drivers.errors import TransportTimeout


class ExpectedProtocol:
    def __init__(self, exchanges: list[tuple[bytes | None, bytes | None]]) -> None:
        self._exchanges = list(exchanges)
        self._sent = bytearray()
        self._reply = bytearray()
        self.closed = False

    # ByteLink interface ------------------------------------------------------------------
    def write(self, data: bytes) -> None:
        assert not self._reply, f"driver wrote {data!r} with reply {bytes(self._reply)!r} unread"
        self._sent += data
        assert self._exchanges, f"driver sent {bytes(self._sent)!r} but no more exchanges expected"
        expected, reply = self._exchanges[0]
        assert expected is not None and expected.startswith(bytes(self._sent)), (
            f"driver sent {bytes(self._sent)!r}, expected {expected!r}"
        )
        if bytes(self._sent) == expected:
            self._exchanges.pop(0)
            self._sent.clear()
            if reply is not None:
                self._reply += reply

    def read_until(self, terminator: bytes, timeout_s: float) -> bytes:
        if not self._reply and self._exchanges and self._exchanges[0][0] is None:
            self._reply += self._exchanges.pop(0)[1] or b""
        idx = self._reply.find(terminator)
        if idx < 0:
            partial = bytes(self._reply)
            self._reply.clear()
            raise TransportTimeout(f"no terminator (got {partial!r})")
        frame = bytes(self._reply[: idx + len(terminator)])
        del self._reply[: idx + len(terminator)]
        return frame

    def read_exact(self, count: int, timeout_s: float) -> bytes:
        if len(self._reply) < count:
            self._reply.clear()
            raise TransportTimeout("not enough bytes")
        data = bytes(self._reply[:count])
        del self._reply[:count]
        return data

    def discard_input(self) -> None:
        self._reply.clear()

    def close(self) -> None:
        self.closed = True

    # checks --------------------------------------------------------------------------------
    def assert_done(self) -> None:
        assert not self._sent, f"partial command {bytes(self._sent)!r} left"
        assert not self._reply, f"reply bytes {bytes(self._reply)!r} left unread"
        assert not self._exchanges, f"expected exchanges not performed: {self._exchanges!r}"


class EmulatorLink:
    """In-process :class:`~drivers.transport.ByteLink` to an emulator's ``receive``.

    What the driver writes goes straight to ``emulator.receive``; the reply
    waits in a buffer for the driver's reads.  A missing terminator is a
    :class:`TransportTimeout`, as on a real link.
    """

    def __init__(self, emulator) -> None:  # noqa: ANN001 - any object with receive(bytes) -> bytes
        self.emulator = emulator
        self._buf = bytearray()
        self.discards = 0

    def write(self, data: bytes) -> None:
        self._buf += self.emulator.receive(data)

    def read_until(self, terminator: bytes, timeout_s: float) -> bytes:
        idx = self._buf.find(terminator)
        if idx < 0:
            partial = bytes(self._buf)
            self._buf.clear()
            raise TransportTimeout(f"no terminator (got {partial!r})")
        frame = bytes(self._buf[: idx + len(terminator)])
        del self._buf[: idx + len(terminator)]
        return frame

    def read_exact(self, count: int, timeout_s: float) -> bytes:
        if len(self._buf) < count:
            self._buf.clear()
            raise TransportTimeout("not enough bytes")
        data = bytes(self._buf[:count])
        del self._buf[:count]
        return data

    def inject(self, data: bytes) -> None:
        """Bytes that arrive unasked (a late reply, line noise)."""
        self._buf += data

    def discard_input(self) -> None:
        self.discards += 1
        self._buf.clear()

    def close(self) -> None:
        pass
