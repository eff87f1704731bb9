"""Register codec of the live-compensation interface, version 1 (docs/compensation.md, "Live
compensation interface").  Pure: registers in, values out, and back.

Holding registers, 0-based.  Multi-register values: big-endian inside a register, word order ABCD
(most significant word first) by default or CDAB.  Positions in mm (rotary: deg), offsets in um
(rotary: arcsec).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

VERSION = 1
REG_VERSION, REG_STATUS, REG_DIRECTION, REG_SAMPLE, REG_POSITION = 0, 1, 2, 3, 4  # position: FLOAT64, 4 regs
REG_ENABLE, REG_HEARTBEAT, REG_ECHO, REG_OFFSET_COUNTS, REG_OFFSET = 8, 9, 10, 11, 12  # offset: FLOAT32
REG_APPLIED, REG_TIMEOUT_MS = 14, 16  # applied: FLOAT32
READ_COUNT = 17  # registers 0-16: everything the compensator reads each cycle, in one request
WRITE_START, WRITE_COUNT = REG_HEARTBEAT, 5  # registers 9-13: what it writes each cycle, in one request

ST_APPLIED, ST_STALE, ST_REFERENCED = 1, 2, 4
#: counts of register 11: 0.1 um (linear) or 0.01 arcsec (rotary)
COUNT_UM, COUNT_ARCSEC = 0.1, 0.01
WORD_ORDERS = ("ABCD", "CDAB")


def _words(raw: bytes, word_order: str) -> list[int]:
    if word_order not in WORD_ORDERS:
        raise ValueError(f"word order must be ABCD or CDAB, not {word_order!r}")
    words = [int.from_bytes(raw[i:i + 2], "big") for i in range(0, len(raw), 2)]
    return words[::-1] if word_order == "CDAB" else words


def _raw(words: list[int], word_order: str) -> bytes:
    if word_order not in WORD_ORDERS:
        raise ValueError(f"word order must be ABCD or CDAB, not {word_order!r}")
    ordered = words[::-1] if word_order == "CDAB" else words
    return b"".join(int(w).to_bytes(2, "big") for w in ordered)


def float64_words(value: float, word_order: str = "ABCD") -> list[int]:
    return _words(struct.pack(">d", value), word_order)


def float32_words(value: float, word_order: str = "ABCD") -> list[int]:
    return _words(struct.pack(">f", value), word_order)


def words_float64(words: list[int], word_order: str = "ABCD") -> float:
    return float(struct.unpack(">d", _raw(list(words), word_order))[0])


def words_float32(words: list[int], word_order: str = "ABCD") -> float:
    return float(struct.unpack(">f", _raw(list(words), word_order))[0])


def int16(word: int) -> int:
    """A register read as a signed 16-bit integer (two's complement)."""
    return word - 0x10000 if word & 0x8000 else word


def offset_counts(offset: float, rotary: bool) -> int:
    """Register 11: the offset (um or arcsec) in counts of 0.1 um / 0.01 arcsec, rounded, saturated at
    ±32767, as an unsigned register value (two's complement)."""
    n = max(-32767, min(32767, round(offset / (COUNT_ARCSEC if rotary else COUNT_UM))))
    return n & 0xFFFF


@dataclass(frozen=True)
class ControllerState:
    """What the compensator reads each cycle (registers 0-16)."""

    version: int
    status: int
    direction: int  # +1, -1, 0 before the first motion
    sample: int
    position: float  # mm or deg, without the offset
    enable: int
    heartbeat: int
    applied: float  # um or arcsec
    timeout_ms: int

    @property
    def stale(self) -> bool:
        return bool(self.status & ST_STALE)


def decode_state(regs: list[int], word_order: str = "ABCD") -> ControllerState:
    """Registers 0-16 read in one request → :class:`ControllerState`; ValueError for a wrong count,
    an unknown interface version or a non-finite position (the word order is probably wrong)."""
    if len(regs) != READ_COUNT:
        raise ValueError(f"live compensation: {len(regs)} registers, not {READ_COUNT}")
    if regs[REG_VERSION] != VERSION:
        raise ValueError(f"live compensation interface version {regs[REG_VERSION]}, this tool speaks version "
                         f"{VERSION}: is this the live-compensation interface (docs/compensation.md)?")
    position = words_float64(regs[REG_POSITION:REG_POSITION + 4], word_order)
    if not math.isfinite(position):
        raise ValueError(f"live compensation: the position reads {position} (word order {word_order} right?)")
    direction = int16(regs[REG_DIRECTION])
    if direction not in (-1, 0, 1):
        raise ValueError(f"live compensation: direction register reads {direction}, not +1, -1 or 0")
    return ControllerState(regs[REG_VERSION], regs[REG_STATUS], direction, regs[REG_SAMPLE], position,
                           regs[REG_ENABLE], regs[REG_HEARTBEAT],
                           words_float32(regs[REG_APPLIED:REG_APPLIED + 2], word_order), regs[REG_TIMEOUT_MS])


def encode_cycle(heartbeat: int, echo: int, offset: float, rotary: bool, word_order: str = "ABCD") -> list[int]:
    """Registers 9-13 the compensator writes each cycle: heartbeat, sample echo, offset counts, offset
    FLOAT32 (um or arcsec)."""
    if not math.isfinite(offset):
        raise ValueError(f"live compensation: offset {offset} is not a number")
    return [heartbeat & 0xFFFF, echo & 0xFFFF, offset_counts(offset, rotary), *float32_words(offset, word_order)]
