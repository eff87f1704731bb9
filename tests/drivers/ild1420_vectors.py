"""Shared ILD1420 test vectors, written from protocols.md section 1.6 (not from the driver)."""

from __future__ import annotations

from tests.protocol_fakes import ExpectedProtocol


class ExpectedStream(ExpectedProtocol):
    """ExpectedProtocol plus ``read_some`` (the stream read the ILD1420 driver uses)."""

    def read_some(self, max_bytes: int, timeout_s: float) -> bytes:
        if not self._reply and self._exchanges and self._exchanges[0][0] is None:
            self._reply += self._exchanges.pop(0)[1] or b""
        data = bytes(self._reply[:max_bytes])
        del self._reply[:max_bytes]
        return data


def frame(raw: int, *, first: bool = True) -> bytes:
    """Manual §8.2: L = 00 D5..D0, M = 01 D11..D6, H = 1x D17..D12 (x = 0: first value)."""
    low = raw & 0b111111
    mid = (raw >> 6) & 0b111111
    high = (raw >> 12) & 0b111111
    return bytes([0b00000000 | low, 0b01000000 | mid, (0b10000000 if first else 0b11000000) | high])


def mm(raw: int, mr: float, offset: float = 0.01) -> float:
    """x_mm = (digital * 1.02 / 65520 - 0.01) * MR (offset 0.51 when mastered)."""
    return (raw * 1.02 / 65520 - offset) * mr


GETINFO_LINES = [  # manual A3.3.2 example
    "Name: ILD1420-10", "Serial: 15030002", "Option: 000", "Article: 4120212", "Cable head: Wire",
    "Measuring range: 10.00mm", "Version: 001.010", "Hardware-rev: 00", "Boot-version: 001.000",
]
GETINFO_REPLY = "".join(line + "\r\n" for line in GETINFO_LINES).encode() + b"->"
