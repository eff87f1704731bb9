"""A positioning run started before the NC-string checks (#18) resumes: its stored set-up may name the axis
``X1`` or give a program number the part program would refuse; resuming writes no NC code, so neither is
an obstacle (``guideway gcode`` and ``export`` still refuse them where they would reach the controller)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ..cli import guideway, one_line_error
from ..reliability import COMMON, partial_run, points_on_disk


def test_a_run_whose_stored_setup_has_a_non_nc_axis_name_resumes(
        tmp_path: Path, reliability_references: dict[str, tuple[Path, Path]]) -> None:
    setup, reference = reliability_references["positioning"]
    run = partial_run("positioning", setup, tmp_path, points=3)
    meta = json.loads((run / "run.json").read_text())
    # as the version before wrote them: any string for the name, any whole number for the program
    meta["setup_source"]["axis"]["name"] = "X1"
    meta["setup_source"].setdefault("gcode", {})["program_number"] = 12345
    meta["setup"]["axis_name"] = "X1"
    (run / "run.json").write_text(json.dumps(meta))
    res = guideway("acquire", "positioning", "--resume", run, *COMMON)
    assert res.returncode == 0, res.stderr
    assert json.loads((run / "run.json").read_text())["status"] == "complete"
    assert points_on_disk(run) == points_on_disk(reference)


@pytest.mark.parametrize(("key", "value", "what"), [("name", '"X1"', "[axis] name"),
                                                    ("program_number", "12345", "program_number")])
def test_a_new_setup_is_still_checked(tmp_path: Path, key: str, value: str, what: str) -> None:
    from ..test_nc_code_safety import setup_text

    setup = tmp_path / "setup.toml"
    setup.write_text(setup_text(**{key: value}))
    one_line_error(guideway("acquire", "positioning", "--setup", setup, "--out", tmp_path / "run", *COMMON),
                   what)
