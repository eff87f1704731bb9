"""Nothing injected into NC code: every string that reaches a part program or a controller table is
one the controller accepts, else the command refuses it with one line (exit 2) and writes nothing.

The acceptance rule is checked here from first principles, independently of saved_runs.nc_text: a
G-code program (Fanuc, LinuxCNC) holds one block per line, an axis word is one letter of
X Y Z A B C U V W followed by a number, a comment is ``(...)`` with no ``(`` or ``)`` inside, and
nothing else of the program may come from the set-up's strings."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import pytest

from acquisition.gcode import part_program
from acquisition.setup.positioning import load_positioning_setup
from saved_runs.errors import UserError

from .cli import guideway, one_line_error
from .test_export_end_to_end import write_run

ROOT = Path(__file__).resolve().parents[1]
HOSTILE = ["X\nG0 Z-500", "X\rG0 Z-500", "X)G0 Z-500(", "X(", "X;G0 Z-500", "%", "X%", "Ä", "XÄ", "x" * 200,
           "", " X", "XY", "1", "G", "Q", "N"]


def setup_text(**values: str) -> str:
    """docs/setup-positioning.toml with ``[axis] name`` / ``[gcode] program_number`` replaced (TOML-quoted)."""
    text = (ROOT / "docs" / "setup-positioning.toml").read_text()
    for key, value in values.items():
        text, n = re.subn(rf"(?m)^{key} = \S+", lambda _m, k=key, v=value: f"{k} = {v}", text)
        assert n == 1, key
    return text


def blocks_are_clean(program: str, axis: str) -> None:
    """Every line is a block the tool means: only the one axis moves, comments close on their line."""
    for line in program.splitlines():
        code = re.sub(r"\([^()]*\)", "", line)  # comments removed; what remains must hold none
        assert "(" not in code and ")" not in code, line
        code = re.sub(r"G0?4 [XP][\d.]+", "", code)  # a dwell's time word (Fanuc G04 X<s>), not a move
        moves = re.findall(r"(?<![A-Z#])([XYZABCUVW])-?\d", code)
        assert set(moves) <= {axis}, line
        assert line.isascii() and line.isprintable(), line


@pytest.mark.parametrize("dialect", ["fanuc", "linuxcnc"])
def test_a_hostile_axis_name_is_refused_by_gcode_in_both_dialects(tmp_path: Path, dialect: str) -> None:
    for i, name in enumerate(HOSTILE):
        setup = tmp_path / f"setup{i}.toml"
        setup.write_text(setup_text(name=json.dumps(name, ensure_ascii=False)), encoding="utf-8")
        out = tmp_path / f"prog{i}.nc"
        one_line_error(guideway("gcode", "--setup", setup, "--dialect", dialect, "--out", out),
                       str(setup), "[axis] name", "one axis letter")
        assert not out.exists()
    # what is accepted gives clean blocks, the letter upper-cased
    for name in ("X", "z", "W"):
        setup = tmp_path / "ok.toml"
        setup.write_text(setup_text(name=json.dumps(name)))
        res = guideway("gcode", "--setup", setup, "--dialect", dialect)
        assert res.returncode == 0, res.stderr
        blocks_are_clean(res.stdout, name.upper())


@pytest.mark.parametrize("number", ["-5", "0", "10000", "123456789", "1.5", '"1000\\nG0 Z-500"', "true"])
def test_a_program_number_outside_the_fanuc_range_is_refused(tmp_path: Path, number: str) -> None:
    setup = tmp_path / "setup.toml"
    setup.write_text(setup_text(program_number=number))
    one_line_error(guideway("gcode", "--setup", setup, "--dialect", "fanuc"), str(setup), "program_number")


def test_the_part_program_checks_its_strings_itself() -> None:
    """A set-up built past the loader (a bug, a later caller) still cannot put a block into the program."""
    setup = load_positioning_setup(ROOT / "docs" / "setup-positioning.toml")
    for dialect in ("fanuc", "linuxcnc"):
        for name in ("X\nG0 Z-500", "X)", "X;"):
            with pytest.raises(UserError, match="one axis letter"):
                part_program(dataclasses.replace(setup, dialect=dialect, axis_name=name))
    with pytest.raises(UserError, match="O-number"):
        part_program(dataclasses.replace(setup, dialect="fanuc", program_number=100000))


@pytest.fixture
def run_dir(tmp_path: Path) -> Path:
    write_run(tmp_path / "run")
    return tmp_path / "run"


@pytest.mark.parametrize("fmt", ["fanuc", "siemens", "linuxcnc", "csv"])
def test_a_hostile_axis_option_is_refused_by_every_export_format(run_dir: Path, tmp_path: Path, fmt: str) -> None:
    for i, name in enumerate(HOSTILE[:12]):
        out = tmp_path / f"table{i}"
        one_line_error(guideway("export", run_dir, "--format", fmt, "--axis", name, "--out", out),
                       "--axis", "one axis letter")
        assert not out.exists()


def test_a_hostile_axis_name_in_run_json_is_refused_where_the_table_writes_it(run_dir: Path, tmp_path: Path) -> None:
    meta = json.loads((run_dir / "run.json").read_text())
    meta["setup"]["axis_name"] = "X\nG0 Z-500"
    (run_dir / "run.json").write_text(json.dumps(meta))
    for fmt in ("fanuc", "siemens"):
        out = tmp_path / f"table.{fmt}"
        one_line_error(guideway("export", run_dir, "--format", fmt, "--out", out), "run.json", "--axis LETTER")
        assert not out.exists()
        res = guideway("export", run_dir, "--format", fmt, "--axis", "Y", "--out", out)  # the way out it names
        assert res.returncode == 0, res.stderr
        assert "G0" not in out.read_text() and "Z-500" not in out.read_text()
    res = guideway("export", run_dir, "--format", "linuxcnc", "--out", tmp_path / "t.comp")  # no name in that file
    assert res.returncode == 0, res.stderr


@pytest.mark.parametrize("name", ["X1\nG0 Z-500", "X1;", "X1]", "X1,Y", "1X", "", "Ä1", "X" * 40, "X1=0"])
def test_a_hostile_siemens_axis_is_refused(run_dir: Path, tmp_path: Path, name: str) -> None:
    out = tmp_path / "table.ini"
    one_line_error(guideway("export", run_dir, "--format", "siemens", "--siemens-axis", name, "--out", out),
                   "--siemens-axis", "Siemens machine-axis name")
    assert not out.exists()
    res = guideway("export", run_dir, "--format", "siemens", "--siemens-axis", "AX_3", "--out", out)
    assert res.returncode == 0, res.stderr
    for line in out.read_text().splitlines():  # each line one assignment, comment or end, ASCII
        assert line.isascii() and (line.startswith(("%_N_", "CHANDATA(", "$AA_ENC_COMP")) or line == "M17"), line


def test_gcode_out_replaces_a_symlink_instead_of_writing_through_it(tmp_path: Path) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("not a program\n")
    out = tmp_path / "prog.nc"
    out.symlink_to(victim)
    res = guideway("gcode", "--setup", ROOT / "docs" / "setup-positioning.toml", "--out", out)
    assert res.returncode == 0, res.stderr
    assert victim.read_text() == "not a program\n"  # untouched
    assert not out.is_symlink() and out.read_text().startswith("%\nO1000 ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["prog.nc", "victim.txt"]  # no temporary file left
