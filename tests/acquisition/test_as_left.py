"""The as-left run of an as-found run (acquisition/as_left.py): its folder never overwrites one, its set-up is
the as-found run's own with ``[compensation]`` naming the table, its simulated world the next seed."""

from __future__ import annotations

from pathlib import Path

import pytest

from acquisition.acquire import SimOptions
from acquisition.as_left import as_left_dir, as_left_simulation, as_left_source
from acquisition.setup.files import setup_from_dict
from saved_runs.errors import SetupError

SOURCE = {"kind": "positioning", "machine": "M", "axis": {"name": "X", "type": "linear", "start_mm": 0.0,
                                                         "end_mm": 200.0, "runs": 2, "shift_targets_mm": 20.0},
          "trigger": {"mode": "in-position", "dwell_s": 0.0}}


def test_the_folder_is_named_after_the_found_run_and_never_an_existing_one(tmp_path: Path) -> None:
    found = tmp_path / "found"
    found.mkdir()
    assert as_left_dir(found) == tmp_path / "found-left"
    (tmp_path / "found-left").mkdir()
    assert as_left_dir(found) == tmp_path / "found-left-2"
    (tmp_path / "found-left-2").write_text("")  # a file of that name counts too
    assert as_left_dir(found) == tmp_path / "found-left-3"


def test_the_set_up_is_the_found_runs_with_the_table(tmp_path: Path) -> None:
    table = tmp_path / "t.comp"
    meta = {"kind": "positioning", "setup_source": SOURCE}
    src = as_left_source(meta, tmp_path / "found", table, "linuxcnc")
    assert src["compensation"] == {"file": str(table.resolve()), "format": "linuxcnc", "comp_file_type": 1}
    assert "shift_targets_mm" not in src["axis"]  # measured on the table's points
    assert SOURCE["axis"]["shift_targets_mm"] == 20.0  # the run's own record is not changed
    assert {k: v for k, v in src.items() if k not in ("compensation", "axis")} == \
        {k: v for k, v in SOURCE.items() if k != "axis"}
    assert setup_from_dict(src, "as-left").compensation.file == str(table.resolve())
    rotary = {**SOURCE, "axis": {"name": "C", "type": "rotary", "start_deg": 0.0, "end_deg": 360.0}}
    src = as_left_source({"kind": "positioning", "setup_source": rotary}, tmp_path, table, "siemens", backlash=2.5)
    assert src["compensation"] == {"file": str(table.resolve()), "format": "siemens", "backlash_arcsec": 2.5}


@pytest.mark.parametrize(("meta", "fmt", "words"), [
    ({"kind": "positioning", "setup_source": SOURCE}, "csv", "for other software"),
    ({"kind": "straightness", "setup_source": SOURCE}, "linuxcnc", "straightness run"),
    ({"kind": "positioning"}, "linuxcnc", "holds no set-up"),
])
def test_what_cannot_be_measured_again_is_one_line(tmp_path: Path, meta: dict, fmt: str, words: str) -> None:
    with pytest.raises(SetupError, match=words) as err:
        as_left_source(meta, tmp_path / "found", tmp_path / "t", fmt)
    assert "\n" not in str(err.value)


def test_a_simulated_found_run_is_measured_again_in_its_world_with_the_next_seed() -> None:
    app = SimOptions(seed=0, noise=True, faults="sensor:drop@3")
    sim = as_left_simulation({"simulation": {"seed": 7, "noise": False, "scenario": "s.toml"}}, app)
    assert (sim.seed, sim.noise, sim.scenario, sim.faults) == (8, False, "s.toml", None)
    sim = as_left_simulation({}, app)  # no record: the application's world, without its injected faults
    assert (sim.seed, sim.noise, sim.faults) == (0, True, None)
