"""The simulated conditions of a positioning set-up's ``[simulation]`` and a scenario's ``[conditions]`` are
held to plausible bounds when the file is read (issue 25: ``air_temp_c = 1e6`` was accepted at acquisition,
and the run it recorded could not be evaluated).

The bounds, written here from their sources rather than read from the code: the air-index equations
(Edlén/Ciddor as ``guideway air-index`` states them, and as ``process`` checks a run) hold for -40 to
100 °C, 10 to 140 kPa (100 to 1400 hPa) and 0 to 100 %RH; the material temperature is held to the same
temperature range; drifts and cycle amplitudes to ±10 per hour / ±10.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from acquisition.setup.positioning import load_positioning_setup
from acquisition.simulated.scenario import load_scenario
from saved_runs.errors import SetupError

from ..cli import guideway, one_line_error
from ..setups import DOCS, replace_once

# key, value in the documented example, lowest, highest, unit
SETUP_BOUNDS = [
    ("air_temp_c", "20.4", -40.0, 100.0, "°C"),
    ("air_pressure_hpa", "1012.8", 100.0, 1400.0, "hPa"),
    ("humidity_pct", "45.0", 0.0, 100.0, "%RH"),
    ("material_temp_c", "20.2", -40.0, 100.0, "°C"),
    ("drift_c_per_h", "0.05", -10.0, 10.0, "°C/h"),
]
SCENARIO_BOUNDS = [
    *SETUP_BOUNDS,
    ("air_cycle_c", "0.0", -10.0, 10.0, "°C"),
    ("pressure_drift_hpa_per_h", "0.0", -10.0, 10.0, "hPa/h"),
    ("pressure_cycle_hpa", "0.0", -10.0, 10.0, "hPa"),
]


def setup_file(tmp_path: Path, key: str, old: str, new: str) -> Path:
    text = replace_once((DOCS / "setup-positioning.toml").read_text(), f"\n{key} = {old}", f"\n{key} = {new}")
    path = tmp_path / "setup.toml"
    path.write_text(text)
    return path


def scenario_file(tmp_path: Path, key: str, old: str, new: str) -> Path:
    text = replace_once((DOCS / "scenario-positioning.toml").read_text(), f"\n{key} = {old}", f"\n{key} = {new}")
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    return path


def outside(lo: float, hi: float) -> list[float]:
    """Values just outside each end, far outside, and not numbers at all."""
    return [lo - 0.01, hi + 0.01, 1e6, -1e6, math.inf, math.nan]


def toml_number(v: float) -> str:
    return "nan" if math.isnan(v) else ("inf" if v == math.inf else ("-inf" if v == -math.inf else repr(v)))


@pytest.mark.parametrize(("key", "old", "lo", "hi", "unit"), SETUP_BOUNDS)
def test_setup_simulation_bounds(tmp_path: Path, key: str, old: str, lo: float, hi: float, unit: str) -> None:
    for v in (lo, hi):  # the ends themselves are inside
        load_positioning_setup(setup_file(tmp_path, key, old, toml_number(v)))
    for v in outside(lo, hi):
        with pytest.raises(SetupError) as exc:
            load_positioning_setup(setup_file(tmp_path, key, old, toml_number(v)))
        msg = str(exc.value)
        assert "\n" not in msg and "[simulation]" in msg and key in msg and f"{lo:g} to {hi:g} {unit}" in msg, msg


@pytest.mark.parametrize(("key", "old", "lo", "hi", "unit"), SCENARIO_BOUNDS)
def test_scenario_condition_bounds(tmp_path: Path, key: str, old: str, lo: float, hi: float, unit: str) -> None:
    for v in (lo, hi):
        if key == "air_cycle_c":  # the swing must stay in -40 ... 100 °C as well: centre the air there
            path = scenario_file(tmp_path, key, old, toml_number(v))
            path.write_text(replace_once(path.read_text(), "air_temp_c = 20.4", "air_temp_c = 30.0"))
        else:
            path = scenario_file(tmp_path, key, old, toml_number(v))
        load_scenario(path)
    for v in outside(lo, hi):
        with pytest.raises(SetupError) as exc:
            load_scenario(scenario_file(tmp_path, key, old, toml_number(v)))
        msg = str(exc.value)
        assert "\n" not in msg and key in msg, msg
        if math.isfinite(v):
            assert "[conditions]" in msg and f"{lo:g} to {hi:g} {unit}" in msg, msg


@pytest.mark.parametrize(("key", "cycle", "centre", "amplitude"), [
    ("air_temp_c", "air_cycle_c", 95.0, 6.0),  # peaks at 101 °C
    ("air_temp_c", "air_cycle_c", -35.0, -6.0),  # troughs at -41 °C (the sign is the phase)
    ("air_pressure_hpa", "pressure_cycle_hpa", 1395.0, 6.0),  # peaks at 1401 hPa
])
def test_scenario_cycle_swings_within_the_range(tmp_path: Path, key: str, cycle: str, centre: float,
                                                amplitude: float) -> None:
    old = {"air_temp_c": "20.4", "air_pressure_hpa": "1012.8"}[key]
    path = scenario_file(tmp_path, cycle, "0.0", repr(amplitude))
    path.write_text(replace_once(path.read_text(), f"{key} = {old}", f"{key} = {centre!r}"))
    with pytest.raises(SetupError, match=f"{key} = {centre:g} with {cycle} = {amplitude:g} swings outside"):
        load_scenario(path)


@pytest.mark.parametrize(("key", "old", "bad"), [
    ("pitch_wavelength", "700.0", "0.0"), ("periodic_period", "10.0", "-1.0"), ("noise", "0.15", "-0.1"),
    ("pitch_amplitude", "4.0", "inf"), ("backlash", "3.0", "nan"),
])
def test_setup_simulated_axis_errors(tmp_path: Path, key: str, old: str, bad: str) -> None:
    with pytest.raises(SetupError, match=rf"\[simulation\] {key} = "):
        load_positioning_setup(setup_file(tmp_path, key, old, bad))


def test_acquire_refuses_the_setup_in_one_line(tmp_path: Path) -> None:
    setup = setup_file(tmp_path, "air_temp_c", "20.4", "1e6")
    res = guideway("acquire", "positioning", "--setup", setup, "--simulate", "--auto", "--out", tmp_path / "run")
    one_line_error(res, "[simulation] air_temp_c = 1e+06", "-40 to 100 °C")
    assert not (tmp_path / "run").exists()
