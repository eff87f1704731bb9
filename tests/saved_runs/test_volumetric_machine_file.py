"""Machine files: seeds 002 and 004 written as machine files (element counts, evaluation against the
test-side 4×4 reference), the commented example, and one-line errors for bad files."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from processing.volumetric.evaluate import exact, first_order
from saved_runs.errors import SetupError
from saved_runs.volumetric.machine_file import load_machine, machine_from_dict

from ..processing.volumetric_reference import Reference

ROOT = Path(__file__).resolve().parents[2]


def check_against_reference(path: Path, n: int = 6, seed: int = 0) -> None:
    """Exact evaluation = the 4×4 product; first order within a nanometre of it at these errors."""
    mf = load_machine(path)
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    rng = np.random.default_rng(seed)
    poses = {a.name: rng.uniform(a.range[0], a.range[1], n) for a in mf.model.axes}
    ex = exact(mf.model, poses, mf.conditions)
    fo = first_order(mf.model, poses, mf.conditions)
    ref = Reference(data)
    for i in range(n):
        d, e = ref.error({k: float(v[i]) for k, v in poses.items()})
        np.testing.assert_allclose(ex.position_um[i], d, rtol=0, atol=1e-7)
        np.testing.assert_allclose(ex.orientation_urad[i], e, rtol=0, atol=1e-7)
    assert np.max(np.abs(ex.position_um - fo.position_um)) < 2e-3
    assert np.max(np.abs(ex.position_um)) > 1.0  # the elements do act


def test_seed002_3t1r_machine_has_its_46_elements() -> None:
    path = ROOT / "docs" / "machines" / "seed002-3t1r.toml"
    counts = load_machine(path).model.counts()
    # 29 geometric: 6 motion errors x 4 pairs, 3 squareness, 2 parallelism of b; 17 thermal
    assert counts == {"motion": 24, "location": 2, "squareness": 3, "thermal": 17, "geometric": 29, "total": 46}
    check_against_reference(path)


def test_seed004_five_axis_machine_has_its_45_errors() -> None:
    path = ROOT / "docs" / "machines" / "seed004-5axis.toml"
    model = load_machine(path).model
    counts = model.counts()
    # 30 single-axis errors, 15 of the coordinate system: 3 squareness + 6 location per rotary axis
    assert counts == {"motion": 30, "location": 12, "squareness": 3, "thermal": 0, "geometric": 45, "total": 45}
    assert sorted(e.id for e in model.elements if e.group == "location") == sorted(
        f"E{c}0{a}" for a in "AC" for c in "XYZABC")
    assert [a.name for a in model.axes] == ["X", "Y", "Z", "A", "C"]
    check_against_reference(path, seed=1)


def test_commented_example_machine_file() -> None:
    path = ROOT / "docs" / "machine-example.toml"
    mf = load_machine(path)
    assert mf.model.counts()["total"] == 6 * 4 + 4 + 3 + 2  # motion, location of C, squareness, thermal of S
    check_against_reference(path, seed=2)


def test_conditions_from_the_command_line_override_the_file() -> None:
    path = ROOT / "docs" / "machines" / "seed002-3t1r.toml"
    assert load_machine(path).conditions == {"temperature_c": 24.0, "time_h": 2.0}
    assert load_machine(path, conditions={"temperature_c": 30.0, "time_h": None}).conditions == {
        "temperature_c": 30.0, "time_h": 2.0}


BASE = """
kind = "machine"
[[tool_chain]]
name = "X"
type = "prismatic"
direction = "+X"
range = [0.0, 100.0]
"""


@pytest.mark.parametrize(("extra", "message"), [
    ("[tool_chain.errors]\nEQ = 1.0\n", "unknown key 'EQ' in [tool_chain X errors]"),
    ("[tool_chain.errors]\nEX = { poly = [1.0], of = \"time_h\" }\n", "of: error motions are functions of the axis"),
    ("[tool_chain.errors]\nEX = { poly = [1.0], scale = 2 }\n", "unknown source keys ['poly', 'scale']"),
    ("[tool_chain.errors]\nEX = { positions = [0, 0], values = [1, 2] }\n", "strictly increasing"),
    ("[tool_chain.errors]\nEX = true\n", "must be a whole number or number or table"),
    ("[tool_chain.location]\nEX = 1.0\n", "X is prismatic: its direction errors are squareness"),
    ("[tool_chain.thermal]\nEX = { poly = [1.0] }\n", "of must be one of temperature_c, time_h"),
    ("[tool_chain.thermal]\nEX = 2.0\n", "[tool_chain X thermal] EX must be a table"),
    ("[[squareness]]\naxes = [\"X\", \"Y\"]\nvalue_urad = 1.0\n", "[frame] primary and secondary are needed"),
    ("[tool_chain.errors]\nEX = { run = \"nowhere\", channel = \"linear\" }\n", "[tool_chain X] errors.EX: /"),
    ("[tool_chain.errors]\nEY = { run = \"r\", channel = \"strz\" }\n",
     "channel strz of this run measures EZ of axis X"),
    ("[tool_chain.errors]\nEX = { run = \"r\", channel = \"linear\", up = \"+X\" }\n",
     "up +X must be perpendicular to the travel +X"),
    ("[tool_chain.errors]\nEX = { run = \"r\", channel = \"bogus\" }\n", "channel must be one of linear"),
    ("[tool_chain.errors]\nEY = { run = \"r\", channel = \"stry\", method = \"fast\" }\n",
     "method must be one of exact, first-order, patent"),
    ("[tool_chain.errors]\nEY = { run = \"r\", channel = \"stry\", line = \"best\" }\n",
     "line must be one of least_squares, endpoint, none"),
    ("[tool_chain.errors]\nEY = { run = \"r\", channel = \"stry\", start = \"x\" }\n", "start must be a number"),
    # TOML allows nan and inf; taken as they are they made every result nan (or inf)
    ("[[tool_chain]]\nname = \"S\"\ntype = \"fixed\"\n[tool_chain.location]\nEX = nan\n",
     "[tool_chain S location] EX must be a finite number, got nan"),
    ("[conditions]\ntemperature_c = nan\n", "[conditions] temperature_c must be a finite number"),
    ("[[tool_chain]]\nname = \"Y\"\ntype = \"prismatic\"\ndirection = \"+Y\"\nrange = [0.0, 1.0]\n"
     "[frame]\nprimary = \"X\"\nsecondary = \"Y\"\n[[squareness]]\naxes = [\"X\", \"Y\"]\nvalue_urad = inf\n",
     "[squareness 1] value_urad must be a finite number, got inf"),
])
def test_bad_machine_files_give_one_line_errors(tmp_path: Path, extra: str, message: str) -> None:
    with pytest.raises(SetupError) as info:
        machine_from_dict(tomllib.loads(BASE + extra), "m.toml", base_dir=tmp_path)
    text = str(info.value)
    assert message in text and "\n" not in text and text.startswith("m.toml")


@pytest.mark.parametrize(("toml", "message"), [
    ('kind = "machine"\n', "no bodies"),
    ('kind = "positioning"\n', "needs a machine file"),
    (BASE.replace('range = [0.0, 100.0]', 'range = [100.0, 0.0]'), "range must be [low, high] with low < high"),
    (BASE.replace('direction = "+X"', 'direction = "X"'), "is not a signed axis"),
    (BASE.replace('type = "prismatic"', 'type = "spherical"'), "type must be prismatic, rotary or fixed"),
    (BASE + BASE.replace('kind = "machine"', ""), "body name 'X' is used twice"),
    (BASE + '[frame]\nprimary = "X"\nsecondary = "Q"\n', "frame secondary 'Q' is not a prismatic axis"),
    (BASE.replace('range = [0.0, 100.0]', 'range = [0.0, 100.0]\nreference = 200.0'), "outside the range"),
    (BASE + '[[tool_chain]]\nname = "S"\ntype = "fixed"\ndirection = "+Z"\n', "a fixed body (S) does not move"),
])
def test_bad_structure_gives_one_line_errors(toml: str, message: str) -> None:
    with pytest.raises(SetupError) as info:
        machine_from_dict(tomllib.loads(toml), "m.toml")
    assert message in str(info.value) and "\n" not in str(info.value)


def axis_toml(name: str, direction: str, chain: str = "tool") -> str:
    return f'[[{chain}_chain]]\nname = "{name}"\ntype = "prismatic"\ndirection = "{direction}"\nrange = [0.0, 100.0]\n'


def squareness_toml(a: str, b: str) -> str:
    return f'[[squareness]]\naxes = ["{a}", "{b}"]\nvalue_urad = 1.0\n'


def test_squareness_pairs_follow_the_frame_convention() -> None:
    """(primary, secondary) tilts the secondary; any other pair tilts the axis that is neither."""
    axes = ('kind = "machine"\n' + axis_toml("X", "+X") + axis_toml("Y", "+Y", "workpiece") + axis_toml("Z", "+Z")
            + axis_toml("W", "-X") + '[frame]\nprimary = "X"\nsecondary = "Y"\n')
    pairs = squareness_toml("Y", "X") + squareness_toml("X", "Z") + squareness_toml("Z", "Y")
    model = machine_from_dict(tomllib.loads(axes + pairs), "m.toml").model
    assert {e.id: e.body for e in model.elements if e.group == "squareness"} == {"SYX": "Y", "SXZ": "Z", "SZY": "Z"}
    with pytest.raises(SetupError, match="one axis must be the frame's primary"):
        machine_from_dict(tomllib.loads(axes + squareness_toml("Z", "W")), "m.toml")
    with pytest.raises(SetupError, match="not perpendicular"):
        machine_from_dict(tomllib.loads(axes + squareness_toml("X", "W")), "m.toml")
    with pytest.raises(SetupError, match="needs two different axes"):
        machine_from_dict(tomllib.loads(axes + squareness_toml("X", "X")), "m.toml")
