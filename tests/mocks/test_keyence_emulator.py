"""The LK-G emulator against the manual's formats and command table
(protocols.md sections 1.1 and 1.2).  The drivers against the emulators over
each transport: tests/mocks/test_sensor_links.py."""

from __future__ import annotations

import math

import pytest

from mocks.faults import FaultPlan
from mocks.keyence_lkg import KeyenceLKGEmulator, format_value


@pytest.mark.parametrize(
    ("value", "decimals", "field"),
    [(1.2345, 4, "+01.2345"), (-0.012, 4, "-00.0120"), (1234.56, 2, "+1234.56"), (-1.2, 1, "-00001.2"),
     (12345.0, 4, "+FFFFFFF"), (-12345.0, 4, "-FFFFFFF"), (None, 4, "XXXXXXXX")],
)
def test_value_format_matches_manual_table(value: float | None, decimals: int, field: str) -> None:
    assert format_value(value, decimals) == field


def test_emulator_state_machine() -> None:
    values = {1: 1.2345, 2: -0.012}
    emu = KeyenceLKGEmulator(lambda out: values[out], decimals=4, range_mm=10)
    assert emu.receive(b"M1\r") == b"M1,+01.2345\r"
    assert emu.receive(b"m0\r") == b"M0,+01.2345,-00.0120\r"  # commands are case-insensitive
    assert emu.receive(b"Q0\r") == b"Q0\r"
    assert emu.receive(b"M1\r") == b"ER,M1,01\r"  # status error in set-up mode
    assert emu.receive(b"R0\r") == b"R0\r"
    assert emu.receive(b"XX\r") == b"ER,XX,00\r"
    assert emu.receive(b"M1,5\r") == b"ER,M1,21\r"
    assert emu.receive(b"M") == b""  # partial command: nothing yet
    assert emu.receive(b"2\rM1\r") == b"M2,-00.0120\rM1,+01.2345\r"
    values[1] = 12.0
    assert emu.receive(b"M1\r") == b"M1,+FFFFFFF\r"




def test_lkg5000_ms_command() -> None:
    emu = KeyenceLKGEmulator(lambda out: 0.26 if out == 1 else -0.5 * out, decimals=3, outputs=4)
    assert emu.receive(b"MS,01\r") == b"MS,01,+000.260\r"  # rlab script example
    assert emu.receive(b"MS,04\r") == b"MS,04,-002.000\r"
    assert emu.receive(b"MS,05\r") == b"ER,MS,22\r"  # no such output
    assert emu.receive(b"MS,1\r") == b"ER,MS,22\r"  # two digits
    assert emu.receive(b"MS\r") == b"ER,MS,21\r"
    assert emu.receive(b"Q0\rMS,01\rR0\r") == b"Q0\rER,MS,01\rR0\r"


def test_offsets_are_settings_of_the_set_up_mode() -> None:
    values = {1: 1.0, 2: 2.0}
    emu = KeyenceLKGEmulator(lambda out: values[out], decimals=4, range_mm=10)
    assert emu.receive(b"SR,OF,01\r") == b"SR,OF,01,+00.0000\r"
    assert emu.receive(b"SW,OF,01,+012345\r") == b"ER,SW,01\r"  # measure mode: status error
    assert emu.receive(b"Q0\r") == b"Q0\r"
    assert emu.receive(b"SW,OF,01,+012345\r") == b"SW,OF\r"  # 12345 counts of 0.0001 mm
    assert emu.receive(b"SW,OF,02,-002000\r") == b"SW,OF\r"
    assert emu.receive(b"SW,OF,01,+12345\r") == b"ER,SW,22\r"  # six digits
    assert emu.receive(b"SW,OF,03,+000001\r") == b"ER,SW,22\r"
    assert emu.receive(b"SW,OF,01\r") == b"ER,SW,21\r"
    assert emu.receive(b"SR,OF,01\r") == b"SR,OF,01,+01.2345\r"  # readable in set-up mode too
    assert emu.receive(b"VR,0\r") == b"ER,VR,01\r"  # reset needs measure mode
    assert emu.receive(b"R0\r") == b"R0\r"
    # value = source - offset
    assert emu.receive(b"M0\r") == b"M0,-00.2345,+02.2000\r"
    assert emu.receive(b"VR,1\r") == b"VR\r"
    assert emu.receive(b"M0\r") == b"M0,+01.0000,+02.2000\r"
    assert emu.receive(b"VR,0\r") == b"VR\r"
    assert emu.receive(b"M2\r") == b"M2,+02.0000\r"
    assert emu.receive(b"VR,3\r") == b"ER,VR,22\r"
    assert emu.receive(b"VR\r") == b"ER,VR,21\r"


def test_head_measurement_mode() -> None:
    emu = KeyenceLKGEmulator(lambda out: 0.0)
    assert emu.receive(b"SR,HB,02\r") == b"SR,HB,02,0\r"
    assert emu.receive(b"SW,HB,02,3\r") == b"ER,SW,01\r"
    assert emu.receive(b"Q0\rSW,HB,02,3\rR0\r") == b"Q0\rSW,HB\rR0\r"
    assert emu.receive(b"sr,hb,02\r") == b"SR,HB,02,3\r"
    assert emu.receive(b"SR,XX,02\r") == b"ER,SR,22\r"
    assert emu.receive(b"SR,HB\r") == b"ER,SR,21\r"


def test_invalid_value_strings() -> None:
    src: dict[int, float | None] = {1: None, 2: math.nan}
    emu = KeyenceLKGEmulator(lambda out: src[out], decimals=4, over_range=("+FFFFFFF", "-FFFFFFF"))
    assert emu.receive(b"M0\r") == b"M0,XXXXXXXX,--------\r"
    src[1], src[2] = -6.0, 6.0
    assert emu.receive(b"M0\r") == b"M0,-FFFFFFF,+FFFFFFF\r"


@pytest.mark.parametrize(
    ("spec", "reply"),
    [("sensor:drop@1", b""), ("sensor:garbage@1", b"\x8f\x13#?\xfe\r"), ("sensor:error@1", b"ER,M1,99\r"),
     # corrupt: bit 7 of the middle byte (13 // 2 = 6, the '.') flipped
     ("sensor:error@1=88", b"ER,M1,88\r"), ("sensor:corrupt@1", b"M1,+00\xae5000\r")],
)
def test_faults_apply_to_the_reply(spec: str, reply: bytes) -> None:
    emu = KeyenceLKGEmulator(lambda out: 0.5, decimals=4, faults=FaultPlan.parse(spec))
    assert emu.receive(b"M1\r") == reply
    assert emu.receive(b"M1\r") == reply  # no COUNT: every request from N on
    clean = KeyenceLKGEmulator(lambda out: 0.5, decimals=4, faults=FaultPlan.parse(spec.replace("@1", "@1x1")))
    clean.receive(b"M1\r")
    assert clean.receive(b"M1\r") == b"M1,+00.5000\r"
