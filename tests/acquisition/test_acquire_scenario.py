"""A scenario's effects behind the real transports: ``acquire --simulate`` with ``[simulation]
scenario = "FILE"`` (or ``--scenario FILE``) runs the simulated machine axis or world with the
scenario's effects, over Modbus TCP and a pty exactly like a measured run, and ``diagnose``
finds what the scenario hid (positioning: the scale and the backlash in the readings, the Abbe
error through the pitch and the dead path through the air the controller reports)."""

from __future__ import annotations

import io
import tomllib
from pathlib import Path

import numpy as np

from acquisition.acquire import SimOptions, run_positioning, run_straightness
from acquisition.setup.positioning import positioning_setup_from_dict
from acquisition.setup.straightness import straightness_setup_from_dict
from saved_runs.diagnosis.diagnose import diagnose_run
from saved_runs.store.reader import load_run

from ..cli import guideway, one_line_error
from ..setups import straightness_setup_text

ROOT = Path(__file__).resolve().parents[2]

POSITIONING_SCENARIO = """
kind = "positioning"
[conditions]                 # a pressure swing (the air index through the controller's registers)
air_temp_c = 20.0
air_pressure_hpa = 1013.0
humidity_pct = 50.0
material_temp_c = 20.0
drift_c_per_h = 0.0
pressure_cycle_hpa = 8.0
cycle_period_min = 0.05
[motion]                     # the pitch the interferometer reports with every capture
pitch_urad_per_m = 4.0
pitch_amplitude_urad = 8.0
pitch_wavelength_mm = 350.0
[noise]
reading_um = 0.15
[[effect]]
type = "linear_scale"
ppm = 6.0
[[effect]]
type = "backlash"
reversal_um = -3.0
[[effect]]
type = "abbe"
offset_mm = 120.0
channel = "pitch"
[[effect]]
type = "dead_path"
length_mm = 1500.0
"""

POSITIONING_SETUP = """
kind = "positioning"
[axis]
targets_mm = [0.0, 47.9, 95.3, 151.0, 204.1, 252.6, 298.7, 349.5, 402.2, 451.8, 497.9, 553.3, 600.0]
runs = 3
feed_mm_min = 60000.0
[trigger]
dwell_s = 0.0
[simulation]
scenario = "scenario.toml"
"""


def test_positioning_scenario_behind_modbus_is_found_by_diagnose(tmp_path: Path) -> None:
    (tmp_path / "scenario.toml").write_text(POSITIONING_SCENARIO)
    (tmp_path / "setup.toml").write_text(POSITIONING_SETUP)
    setup_path = tmp_path / "setup.toml"
    source = tomllib.loads(setup_path.read_text())
    setup = positioning_setup_from_dict(source, str(setup_path))
    assert Path(setup.scenario) == (tmp_path / "scenario.toml").resolve()  # relative to the set-up file
    res = run_positioning(setup, tmp_path / "run", simulate=SimOptions(seed=4), auto=True, setup_source=source,
                          stream=io.StringIO())
    assert res.outcome.exit_status == "success", res.outcome.reason
    run = load_run(tmp_path / "run")
    assert run.meta["simulation"]["scenario"] == setup.scenario
    d = diagnose_run(tmp_path / "run")
    # the Abbe error of a pitch that is one wave and a tilt may be reported ambiguous with a periodic error
    assert {"backlash", "linear_scale", "dead_path"} <= set(d.named)
    final = {e.type: (e, se) for e, se in zip(d.primary.final.effects, d.primary.final.se, strict=True)}
    assert sorted(final) == ["abbe", "backlash", "dead_path", "linear_scale"]
    for kind, name, value in (("linear_scale", "ppm", 6.0), ("backlash", "reversal_um", -3.0),
                              ("abbe", "offset_mm", 120.0), ("dead_path", "length_mm", 1500.0)):
        assert abs(final[kind][0].params[name] - value) <= 4 * final[kind][1][name], (kind, final[kind])
    assert d.primary.final.rms_um <= 1.2 * 0.15


def test_straightness_scenario_behind_the_pty_sensor(tmp_path: Path) -> None:
    """A block 15 um longer than recorded: the interferometer's lin channel ramps by it per station."""
    scenario = tmp_path / "block.toml"
    scenario.write_text('kind = "straightness"\n[block]\nlength_mm = 100.0\nstations = 5\n'
                        '[noise]\nplacement_um = 2.0\n[[effect]]\ntype = "block_length"\num_per_block = 15.0\n')
    text = straightness_setup_text(stations=8, samples=2, return_pass=True)
    setup = straightness_setup_from_dict(tomllib.loads(text), "setup")
    res = run_straightness(setup, tmp_path / "run", simulate=SimOptions(seed=1, scenario=str(scenario)), auto=True,
                           stream=io.StringIO())
    assert res.outcome.exit_status == "success", res.outcome.reason
    pts = load_run(tmp_path / "run").points
    assert len(pts) == 16
    d = diagnose_run(tmp_path / "run")
    assert d.named == ["block_length"]
    lin = next(c for c in d.channels if c.obs.channel == "lin")
    (step,) = lin.steps
    assert abs(step.effect.params["um_per_block"] - 15.0) <= 4 * step.fit.se[-1]["um_per_block"]
    assert np.isfinite(pts["sensor_mm"]).all()


def test_scenario_of_the_wrong_kind_is_a_one_line_error(tmp_path: Path, setup_file: Path) -> None:
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(POSITIONING_SCENARIO)
    one_line_error(guideway("acquire", "straightness", "--setup", setup_file, "--out", tmp_path / "run", "--simulate",
                            "--auto", "--scenario", scenario),
                   "is a positioning scenario; this is a straightness run")
    assert not (tmp_path / "run").exists()
    one_line_error(guideway("acquire", "straightness", "--setup", setup_file, "--out", tmp_path / "run",
                            "--scenario", scenario), "--scenario needs --simulate")


def test_the_simulation_table_of_a_straightness_setup_is_checked() -> None:
    import pytest

    from saved_runs.errors import SetupError

    text = (ROOT / "docs" / "setup-straightness.toml").read_text()
    data = tomllib.loads(text)
    with pytest.raises(SetupError, match="unknown key 'scenaro' in \\[simulation\\]"):
        straightness_setup_from_dict({**data, "simulation": {"scenaro": "x.toml"}}, "setup")
    assert straightness_setup_from_dict({**data, "simulation": {"scenario": "/abs/x.toml"}}, "setup").scenario \
        == "/abs/x.toml"


def test_a_negative_noise_in_a_scenario_is_a_one_line_error(tmp_path: Path) -> None:
    """A standard deviation below 0 (numpy's ``scale < 0`` traceback before)."""
    for kind, key in (("straightness", "sensor_um"), ("positioning", "reading_um")):
        text = (ROOT / "docs" / f"scenario-{kind}.toml").read_text()
        lines = [f"{key} = -0.05" if ln.split("=")[0].strip() == key else ln for ln in text.splitlines()]
        assert lines != text.splitlines()
        scenario = tmp_path / f"{kind}.toml"
        scenario.write_text("\n".join(lines) + "\n")
        one_line_error(guideway("simulate", scenario, "--out", tmp_path / f"run-{kind}"),
                       str(scenario), f"[noise] {key}", ">= 0", "-0.05")
        assert not (tmp_path / f"run-{kind}").exists()


def test_the_scenario_path_is_relative_to_the_setup_file_not_the_working_directory(
        tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    from acquisition.setup.positioning import load_positioning_setup

    (tmp_path / "cell").mkdir()
    (tmp_path / "cell" / "setup.toml").write_text(POSITIONING_SETUP)
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    setup = load_positioning_setup("../cell/setup.toml")
    assert setup.scenario == str((tmp_path / "cell" / "scenario.toml").resolve())
