"""docs/modbus-map.md, the driver's register_map.toml and the emulator agree."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from drivers.interferometer import load_register_map
from drivers.interferometer.register_map import parse_register_map
from mocks import interferometer as emu

DOC = Path(__file__).resolve().parents[2] / "docs" / "modbus-map.md"


def doc_table(title_regex: str, ncols: int) -> list[list[str]]:
    text = DOC.read_text(encoding="utf-8")
    rows = []
    in_table = False
    for line in text.splitlines():
        if re.match(title_regex, line):
            in_table = True
            continue
        if in_table and line.startswith("|"):
            cells = [c.strip() for c in line.strip("|").split("|")]
            if set(cells[0]) <= {"-"} or cells[0] in ("reg", "code"):
                continue
            assert len(cells) == ncols, line
            rows.append(cells)
        elif in_table and rows and not line.startswith("|"):
            break
    return rows


def test_register_table_matches_the_map() -> None:
    rows = doc_table(r"^# Modbus register map", 5)
    regmap = load_register_map()
    assert [(int(r[0]), r[1], r[2], r[3], r[4]) for r in rows] == [
        (reg.address, reg.type, reg.access, reg.unit, reg.meaning) for reg in regmap.registers
    ]


def test_error_table_matches_the_map() -> None:
    rows = doc_table(r"^## Error codes", 2)
    assert {int(r[0]): r[1] for r in rows} == load_register_map().error_codes


def test_emulator_addresses_follow_the_doc() -> None:
    regs = {r.name: r.address for r in load_register_map().registers}
    assert (emu.REG_COMMAND, emu.REG_STATUS, emu.REG_SEQUENCE, emu.REG_ERROR) == (
        regs["command"], regs["status"], regs["sequence"], regs["error_code"])
    assert (emu.REG_POSITION, emu.REG_CHANNELS, emu.REG_ENV) == (
        regs["position_mm"], regs["stry_um"], regs["air_temp_c"])
    cmds = load_register_map().commands
    assert (cmds["trigger"], cmds["zero"], cmds["clear_error"]) == (emu.CMD_TRIGGER, emu.CMD_ZERO, emu.CMD_CLEAR)


def test_overlapping_registers_are_rejected() -> None:
    bad = """version = 1
[commands]
[status_bits]
[error_codes]
[[register]]
name = "a"
address = 100
type = "FLOAT64"
access = "R"
[[register]]
name = "b"
address = 102
type = "FLOAT32"
access = "R"
"""
    with pytest.raises(ValueError, match="overlaps"):
        parse_register_map(bad)


def test_xymd02_table_matches_driver_and_emulator() -> None:
    from drivers.environment import xymd02 as drv
    from mocks import xymd02 as sim

    rows = doc_table(r"^## XY-MD02", 5)
    assert [(int(r[0]), int(r[1]), r[2]) for r in rows] == [
        (drv.REG_TEMPERATURE, 4, "INT16"), (drv.REG_HUMIDITY, 4, "UINT16"), (sim.HR_ADDRESS, 3, "UINT16")]
    assert (sim.IR_TEMPERATURE, sim.IR_HUMIDITY) == (drv.REG_TEMPERATURE, drv.REG_HUMIDITY)


def test_controller_fault_table_lists_every_controller_kind() -> None:
    from mocks.faults import KINDS

    rows = doc_table(r"^## Controller faults", 3)
    assert {r[0].strip("`") for r in rows if r[0] != "kind"} == KINDS["controller"]
