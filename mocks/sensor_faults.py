"""Applying a :class:`~mocks.faults.FaultPlan`'s sensor faults to a reply.

Every serial sensor emulator answers a request, then asks
:func:`apply_sensor_fault` what actually goes on the wire.  The fault kinds
are the same for all sensors; only two things are protocol-specific and are
passed in: how the device reports an error code, and how a reply is
corrupted in a way its checksum (if any) catches.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from .faults import FaultPlan

GARBAGE = b"\x8f\x13#?\xfe"  # non-ASCII noise; each emulator appends its own terminator


def flip_bit7(reply: bytes) -> bytes:
    """``reply`` with bit 7 of its middle byte flipped (line noise on a 7-bit text protocol)."""
    i = len(reply) // 2
    return reply[:i] + bytes([reply[i] ^ 0x80]) + reply[i + 1:]


def apply_sensor_fault(
    faults: FaultPlan,
    reply: bytes,
    *,
    terminator: bytes,
    error_reply: Callable[[str | None], bytes],
    corrupt: Callable[[bytes], bytes],
    garbage: bytes = GARBAGE,
) -> bytes:
    """Count one request to ``sensor`` and return the bytes to send for ``reply``.

    ``error_reply(arg)`` builds the device's error frame for the fault's ARG
    (``None``: the protocol's default code); ``corrupt(reply)`` damages a frame.
    ``delay`` blocks the caller (the endpoint's serving thread) for ARG seconds.
    ``garbage``: the noise sent before ``terminator`` (a protocol that tells binary from
    text by bit 7 needs noise that still reads as text).
    """
    fault = faults.next_request("sensor")
    if fault is None:
        return reply
    if fault.kind == "garbage":
        return garbage + terminator
    if fault.kind == "drop":
        return b""
    if fault.kind == "delay":
        time.sleep(float(fault.arg or 1.0))
        return reply
    if fault.kind == "error":
        return error_reply(fault.arg)
    if fault.kind == "corrupt":
        return corrupt(reply)
    return reply
