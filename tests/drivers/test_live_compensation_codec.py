"""The live-compensation register codec against values worked out by hand from docs/compensation.md
("Live compensation interface": big-endian registers, ABCD word order by default)."""

from __future__ import annotations

import math

import pytest

from drivers.live_compensation.codec import (
    READ_COUNT,
    decode_state,
    encode_cycle,
    float32_words,
    float64_words,
    int16,
    offset_counts,
    words_float32,
    words_float64,
)


def test_float_words_in_both_word_orders() -> None:
    # 123.456 as IEEE float32 is 0x42F6E979 (docs/modbus-map.md's example); 1.5 as float64 is 0x3FF8000000000000
    assert float32_words(123.456) == [0x42F6, 0xE979]
    assert float32_words(123.456, "CDAB") == [0xE979, 0x42F6]
    assert float64_words(1.5) == [0x3FF8, 0, 0, 0]
    assert float64_words(1.5, "CDAB") == [0, 0, 0, 0x3FF8]
    assert words_float64([0x3FF8, 0, 0, 0]) == 1.5
    assert words_float32([0xC020, 0x0000]) == -2.5  # 0xC0200000 = -2.5
    with pytest.raises(ValueError, match="word order"):
        float32_words(1.0, "BADC")


def test_offset_counts_are_signed_tenths_of_a_micrometre_or_hundredths_of_an_arcsecond() -> None:
    assert offset_counts(-1.25, rotary=False) == (-12) & 0xFFFF == 0xFFF4  # -12.5 counts rounds to even: -12
    assert offset_counts(3.0, rotary=False) == 30
    assert offset_counts(0.5, rotary=True) == 50
    assert offset_counts(5000.0, rotary=False) == 32767  # saturated
    assert offset_counts(-5000.0, rotary=False) == 0x8001  # -32767
    assert int16(0xFFF4) == -12 and int16(0x7FFF) == 32767


def registers(direction: int = 0xFFFF, position: list[int] | None = None, version: int = 1) -> list[int]:
    regs = [0] * READ_COUNT
    regs[0], regs[1], regs[2], regs[3] = version, 0b101, direction, 7
    regs[4:8] = position or [0x4059, 0x0000, 0x0000, 0x0000]  # 100.0 = 0x4059000000000000
    regs[8], regs[9] = 1, 41
    regs[14:16] = [0xBFC0, 0x0000]  # -1.5
    regs[16] = 500
    return regs


def test_decode_state() -> None:
    s = decode_state(registers())
    assert (s.version, s.status, s.direction, s.sample, s.position) == (1, 5, -1, 7, 100.0)
    assert (s.enable, s.heartbeat, s.applied, s.timeout_ms) == (1, 41, -1.5, 500)
    assert not s.stale
    cdab = decode_state(registers(position=[0, 0, 0, 0x4059]), "CDAB")
    assert cdab.position == 100.0


@pytest.mark.parametrize(("regs", "fragment"), [
    (registers(version=2), "version 2"),
    (registers(direction=5), "direction register reads 5"),
    (registers(position=[0x7FF8, 0, 0, 0]), "word order"),  # NaN
    (registers()[:16], "16 registers"),
])
def test_decode_refuses_what_is_not_the_interface(regs: list[int], fragment: str) -> None:
    with pytest.raises(ValueError, match=fragment):
        decode_state(regs)


def test_encode_cycle() -> None:
    # heartbeat 65536 wraps to 0; echo; -1.5 um = -15 counts; FLOAT32 -1.5 = 0xBFC00000
    assert encode_cycle(65536, 7, -1.5, rotary=False) == [0, 7, (-15) & 0xFFFF, 0xBFC0, 0x0000]
    assert encode_cycle(1, 2, -1.5, rotary=True, word_order="CDAB") == [1, 2, (-150) & 0xFFFF, 0x0000, 0xBFC0]
    with pytest.raises(ValueError, match="not a number"):
        encode_cycle(1, 1, math.nan, rotary=False)
