"""One request, one reply, over a :class:`~drivers.transport.ByteLink`.

Polled serial devices (Keyence LK-G, Panasonic HL-G1) answer each request
with one terminated frame.  After a failed exchange (timeout, garbled or
corrupt reply) a late or partial reply may still be on its way, so the next
exchange first drops whatever is waiting; a well-formed device error leaves the
line in step and needs no resync.

Limit: these protocols carry no sequence number, so a reply that arrives after
the *next* request has been sent cannot be told apart from its answer; give a
device that timed out a moment (one timeout) before polling it again.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from .errors import DeviceError
from .transport import ByteLink

T = TypeVar("T")


class RequestReply:
    """Send a request, read one reply ending in ``terminator``; resync after failures."""

    def __init__(self, link: ByteLink, terminator: bytes) -> None:
        self.link = link
        self.terminator = terminator
        self._stale = False

    def transact(self, request: bytes, timeout_s: float, decode: Callable[[bytes], T]) -> tuple[T, bytes]:
        """Send ``request``; return ``(decode(reply), reply)``.

        Raises what the link raises (:class:`~drivers.errors.TransportError`)
        or what ``decode`` raises (:class:`~drivers.errors.ProtocolError`,
        :class:`DeviceError`); after anything but a device error the next
        exchange starts by discarding waiting input.
        """
        if self._stale:
            self.link.discard_input()
        self._stale = True  # until a well-formed frame has come back
        self.link.write(request)
        frame = self.link.read_until(self.terminator, timeout_s)
        try:
            value = decode(frame)
        except DeviceError:
            self._stale = False  # a device error is a well-formed reply: the line is in step
            raise
        self._stale = False
        return value, frame
