"""Interferometer register codec: values built here with struct (big-endian 16-bit
registers, ABCD = most significant word first, CDAB = least significant first), and the
refusals a mutation run found unchecked (issue 28)."""

from __future__ import annotations

import math
import struct

import pytest

from drivers.errors import ProtocolError
from drivers.interferometer import load_register_map
from drivers.interferometer.codec import check_word_order, decode_block, decode_status, decode_value, encode_value


def words(fmt: str, value: float | int, word_order: str = "ABCD") -> list[int]:
    raw = struct.pack(">" + fmt, value)
    w = [int.from_bytes(raw[i:i + 2], "big") for i in range(0, len(raw), 2)]
    return w[::-1] if word_order == "CDAB" else w


@pytest.mark.parametrize("word_order", ["ABCD", "CDAB"])
@pytest.mark.parametrize(
    ("type_name", "fmt", "value"),
    [("UINT16", "H", 0), ("UINT16", "H", 65535), ("INT16", "h", -32768), ("INT16", "h", 32767),
     ("INT16", "h", -1), ("UINT32", "I", 0x12345678), ("UINT32", "I", 0xFFFFFFFF), ("FLOAT32", "f", -2.25),
     ("FLOAT64", "d", -1234.567891)],
)
def test_values_round_trip_against_struct(type_name: str, fmt: str, value: float, word_order: str) -> None:
    regs = words(fmt, value, word_order)
    assert decode_value(regs, type_name, word_order) == value
    assert encode_value(value, type_name, word_order) == regs


@pytest.mark.parametrize("regs", [[65536], [-1], [70000, 0], [1.5]])
def test_a_register_outside_16_bits_is_a_protocol_error(regs: list) -> None:
    type_name = "UINT16" if len(regs) == 1 else "FLOAT32"
    with pytest.raises(ProtocolError, match="not 16-bit registers"):
        decode_value(regs, type_name)


@pytest.mark.parametrize(("type_name", "regs"), [("UINT16", [1, 2]), ("FLOAT32", [0x3FC0]), ("FLOAT64", [0, 0])])
def test_a_register_count_that_does_not_fit_the_type_is_a_protocol_error(type_name: str, regs: list) -> None:
    with pytest.raises(ProtocolError, match="register"):
        decode_value(regs, type_name)


@pytest.mark.parametrize(("value", "type_name"), [(65536, "UINT16"), (-1, "UINT16"), (32768, "INT16"),
                                                  (-32769, "INT16"), (2**32, "UINT32")])
def test_an_integer_that_does_not_fit_is_refused(value: int, type_name: str) -> None:
    with pytest.raises(ValueError, match="does not fit"):
        encode_value(value, type_name)


@pytest.mark.parametrize("word_order", ["BADC", "abcd", ""])
def test_unknown_word_order_refused(word_order: str) -> None:
    with pytest.raises(ValueError, match="word order"):
        check_word_order(word_order)
    with pytest.raises(ValueError, match="word order"):
        decode_value([0], "UINT16", word_order)


def test_decode_block_places_each_value_by_its_address() -> None:
    regmap = load_register_map()
    names = ["position_mm", "stry_um"]  # FLOAT64 then FLOAT32
    start = min(regmap[n].address for n in names) - 1  # one spare register in front
    end = max(regmap[n].address + regmap[n].count for n in names)
    regs = [0] * (end - start)
    expect = {}
    for k, n in enumerate(names):
        reg = regmap[n]
        value = 100.5 + k  # exact in FLOAT32 and FLOAT64
        fmt = {"FLOAT32": "f", "FLOAT64": "d"}[reg.type]
        regs[reg.address - start:reg.address - start + reg.count] = words(fmt, value, "CDAB")
        expect[n] = value
    assert decode_block(regs, start, names, regmap, "CDAB") == expect
    with pytest.raises(ProtocolError, match="misses"):
        decode_block(regs[:-1], start, names, regmap, "CDAB")
    with pytest.raises(ProtocolError, match="misses"):
        decode_block(regs, start + 2, names, regmap, "CDAB")
    with pytest.raises(ProtocolError, match="16-bit"):
        decode_block([*regs[:-1], 65536], start, names, regmap, "CDAB")


def test_a_nan_pattern_is_returned_as_nan() -> None:
    assert math.isnan(decode_value(words("f", math.nan), "FLOAT32"))


def test_status_word_each_bit() -> None:
    regmap = load_register_map()
    bits = regmap.status_bits
    for name in ("ready", "busy", "data_valid", "error", "beam_ok"):
        st = decode_status(1 << bits[name], 7, 0, regmap)
        flags = {f: getattr(st, f) for f in ("ready", "busy", "data_valid", "error", "beam_ok")}
        assert flags == {f: f == name for f in flags}
        assert (st.sequence, st.error_code, st.error_text, st.raw_status) == (7, 0, "", 1 << bits[name])
    code = next(c for c in regmap.error_codes if c)  # 0 = no error has no text in the status
    st = decode_status(0, 0, code, regmap)
    assert st.error_text == regmap.error_text(code) and st.error_text


def test_decode_block_refuses_a_bad_register_it_does_not_decode() -> None:
    """The spare register in front of the values is not decoded, yet 65536 there is no 16-bit register."""
    regmap = load_register_map()
    start = regmap["position_mm"].address - 1
    regs = [0] * (1 + regmap["position_mm"].count)
    assert decode_block(regs, start, ["position_mm"], regmap, "ABCD") == {"position_mm": 0.0}
    for bad in (65536, -1, 0.5):
        with pytest.raises(ProtocolError, match=rf"register block from {start} holds values that are not 16-bit"):
            decode_block([bad, *regs[1:]], start, ["position_mm"], regmap, "ABCD")
    assert decode_block([65535, *regs[1:]], start, ["position_mm"], regmap, "ABCD") == {"position_mm": 0.0}


def test_the_message_names_the_first_four_bad_registers() -> None:
    regmap = load_register_map()
    start = regmap["position_mm"].address
    with pytest.raises(ProtocolError) as info:
        decode_block([70001, 70002, 70003, 70004, 70005], start, [], regmap, "ABCD")
    assert str(info.value).endswith("[70001, 70002, 70003, 70004]")
    with pytest.raises(ProtocolError) as info:
        decode_value([70001, 70002, 70003, 70004, 70005], "FLOAT64")
    assert str(info.value).endswith("[70001, 70002, 70003, 70004]")
