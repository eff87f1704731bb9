"""The ISO 230-2 target rule (standards.md §1.4): fewer than 2 targets give no E, M or A and are
refused; fewer than 5, or fewer than 5 per metre, are evaluated / imported with a note; an explicit
set-up list that breaks the rule is refused unless allowed.  Also the G-code header wording."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from acquisition.gcode import part_program
from acquisition.setup.positioning import positioning_setup_from_dict
from processing.iso230_2 import check_target_count, iso230_2_from_arrays
from saved_runs.errors import SetupError

from ..cli import ROOT, guideway, one_line_error

RULE = "target rule"


def csv(targets: list[float]) -> str:
    """2 runs x 2 directions at each target, readings already compensated, deviation +1 um up / -1 um down."""
    rows = ["run,direction,target_mm,reading_mm"]
    for run in (1, 2):
        rows += [f"{run},+1,{t},{t + 0.001:.4f}" for t in targets]
        rows += [f"{run},-1,{t},{t - 0.001:.4f}" for t in reversed(targets)]
    return "\n".join(rows) + "\n"


# -- the rule itself ------------------------------------------------------------------------
@pytest.mark.parametrize(("targets", "span", "conforms"), [
    ([0, 250, 500, 750, 1000], None, True),            # 5 over 1 m: exactly 5 per metre
    ([0, 100, 200, 300, 400, 500], 1400.0, False),     # 1.4 m of travel needs ceil(7) = 7
    ([0, 240, 480, 720, 960, 1200], None, True),       # 1.2 m needs ceil(6) = 6
    ([0, 300, 600, 900, 1200], None, False),           # ... 5 are too few
    ([0, 10, 20], None, False),                        # fewer than 5 in total
    ([0, 500], 1000.0, False),
])
def test_linear_rule(targets: list[float], span: float | None, conforms: bool) -> None:
    note = check_target_count(targets, "linear", span)
    assert (note is None) == conforms
    if note:
        assert RULE in note and f"{len(targets)} targets" in note


def test_fewer_than_two_targets_cannot_be_evaluated() -> None:
    with pytest.raises(ValueError, match="at least 2 targets"):
        check_target_count([100.0], "linear")
    with pytest.raises(ValueError, match="at least 2 targets"):
        iso230_2_from_arrays(np.array([100.0]), np.array([[1.0, 2.0]]), np.array([[0.0, 1.0]]))


def test_evaluation_notes_too_few_targets() -> None:
    t = np.array([0.0, 100.0, 200.0])
    res = iso230_2_from_arrays(t, np.ones((3, 2)), -np.ones((3, 2)))
    assert any(RULE in n for n in res.notes)
    assert res.axis["E"] == pytest.approx(2.0)  # still evaluated: +1 up, -1 down
    ok = iso230_2_from_arrays(np.linspace(0, 800, 5), np.ones((5, 2)), -np.ones((5, 2)))
    assert not any(RULE in n for n in ok.notes)


# -- import and process on the command line -------------------------------------------------
def test_import_refuses_one_target_and_warns_about_few(tmp_path: Path) -> None:
    one = tmp_path / "one.csv"
    one.write_text(csv([250.0]))
    one_line_error(guideway("import", "positioning", str(one), "--out", str(tmp_path / "r1"), "--compensated"),
                   "at least 2 targets")
    assert not (tmp_path / "r1").exists()

    few = tmp_path / "few.csv"
    few.write_text(csv([0.0, 100.0, 200.0]))
    res = guideway("import", "positioning", str(few), "--out", str(tmp_path / "r3"), "--compensated")
    assert res.returncode == 0, res.stderr
    warnings = [ln for ln in res.stderr.splitlines() if ln.startswith("guideway: warning:")]
    assert len(warnings) == 1 and RULE in warnings[0]

    res = guideway("process", str(tmp_path / "r3"), "--no-write")
    assert res.returncode == 0, res.stderr
    assert any(ln.startswith("note:") and RULE in ln for ln in res.stdout.splitlines())
    res = guideway("process", str(tmp_path / "r3"), "--json", "--no-write")
    out = json.loads(res.stdout)
    assert any(RULE in n for n in out["notes"]) and out["iso230_2"]["E"] == pytest.approx(2.0)


def test_process_refuses_a_run_with_one_target(tmp_path: Path) -> None:
    two = tmp_path / "two.csv"
    two.write_text(csv([0.0, 250.0]))
    assert guideway("import", "positioning", str(two), "--out", str(tmp_path / "run"), "--compensated").returncode == 0
    # keep the points of one target only, as a run recorded elsewhere could be
    pts = tmp_path / "run" / "points.csv"
    lines = pts.read_text().splitlines()
    col = lines[0].split(",").index("target_mm")
    pts.write_text("\n".join([lines[0], *[ln for ln in lines[1:] if float(ln.split(",")[col]) == 0.0]]) + "\n")
    one_line_error(guideway("process", str(tmp_path / "run"), "--no-write"), "at least 2 targets")


# -- explicit targets in a set-up -----------------------------------------------------------
def test_setup_refuses_nonconforming_explicit_targets() -> None:
    data = {"axis": {"targets_mm": [0, 500], "end_mm": 1000.0}}
    with pytest.raises(SetupError, match=RULE) as info:
        positioning_setup_from_dict(data)
    assert "allow_nonconforming_targets" in str(info.value) and "\n" not in str(info.value)
    # the travel (end_mm - start_mm), not the span of the targets, sets the count: 1400 mm needs 7
    with pytest.raises(SetupError, match="at least 7 required"):
        positioning_setup_from_dict({"axis": {"targets_mm": [0, 100, 200, 300, 400, 500], "end_mm": 1400.0}})
    allowed = positioning_setup_from_dict({"axis": {**data["axis"], "allow_nonconforming_targets": True}})
    assert allowed.targets == (0.0, 500.0)
    with pytest.raises(SetupError, match="at least two"):  # never evaluable, allowed or not
        positioning_setup_from_dict({"axis": {"targets_mm": [500], "allow_nonconforming_targets": True}})
    with pytest.raises(SetupError, match=RULE):
        positioning_setup_from_dict({"axis": {"type": "rotary", "targets_deg": [0, 90, 180, 270]}})
    assert len(positioning_setup_from_dict({"axis": {"targets_mm": [0, 200, 400, 600, 800, 1000]}}).targets) == 6


def test_gcode_refuses_nonconforming_targets(tmp_path: Path) -> None:
    text = (ROOT / "docs" / "setup-positioning.toml").read_text()
    text = text.replace("# targets_mm = [0.0, 248.7, 502.1, 747.9, 1000.0]", "targets_mm = [0.0, 500.0]")
    setup = tmp_path / "setup.toml"
    setup.write_text(text)
    one_line_error(guideway("gcode", "--setup", str(setup), "--out", str(tmp_path / "p.nc")), RULE,
                   "allow_nonconforming_targets")
    setup.write_text(text.replace("allow_nonconforming_targets = false", "allow_nonconforming_targets = true"))
    assert guideway("gcode", "--setup", str(setup), "--out", str(tmp_path / "p.nc")).returncode == 0


# -- the G-code header ------------------------------------------------------------------------
@pytest.mark.parametrize("dialect", ["fanuc", "linuxcnc"])
def test_rotary_program_header_names_the_axis_type_not_the_cycle(dialect: str) -> None:
    s = positioning_setup_from_dict({"axis": {"type": "rotary", "name": "C"}, "gcode": {"dialect": dialect}})
    title = [ln for ln in part_program(s).splitlines() if ln != "%"][0].upper()
    assert "STANDARD TEST CYCLE" in title and "ROTARY AXIS C" in title and "LINEAR" not in title
    assert title.count("(") == 1 and title.count(")") == 1  # one comment, nothing nested
