"""A separate XY-MD02 air temperature / humidity transmitter (for a controller without an
environment unit): its values replace the controller's air temperature and humidity in every
capture, it is listed among the instruments, `devices probe` shows it, and a set-up's
``[transmitter]`` is honoured by a simulated run."""

from __future__ import annotations

import io
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from acquisition.acquire import SimOptions, run_straightness
from acquisition.rig import open_environment, open_rig
from acquisition.setup.straightness import straightness_setup_from_dict
from mocks.xymd02 import XYMD02Emulator, start_xymd02
from saved_runs.errors import UserError
from tui.cli import main

from ..cli import guideway, one_line_error
from .test_acquire_sensor_families import setup_text

# What the transmitter reads here: chosen far from the simulated controller's environment unit
# (about 20.4 C / 45 %RH) so the test sees which device a value came from.
TRANSMITTER_C, TRANSMITTER_RH = 23.4, 61.7


@pytest.fixture
def transmitter():
    server = start_xymd02(XYMD02Emulator(lambda: (TRANSMITTER_C, TRANSMITTER_RH)))
    yield server
    server.stop()


def test_transmitter_values_replace_the_controllers_air_values(sim_rig, transmitter) -> None:
    plain = open_rig(sim_rig.sensor_protocol, sim_rig.sensor_url, sim_rig.controller_url)
    try:
        controller_only = plain.trigger_and_read()
    finally:
        plain.close()
    rig = open_rig(sim_rig.sensor_protocol, sim_rig.sensor_url, sim_rig.controller_url,
                   environment_url=transmitter.url)
    try:
        r = rig.trigger_and_read()
        instruments = rig.instruments()
    finally:
        rig.close()
    assert (r.air_temp_c, r.humidity_pct) == (TRANSMITTER_C, TRANSMITTER_RH)
    assert abs(controller_only.air_temp_c - TRANSMITTER_C) > 1
    assert abs(controller_only.humidity_pct - TRANSMITTER_RH) > 1
    # pressure and material temperature stay the controller's
    assert r.air_pressure_hpa == pytest.approx(controller_only.air_pressure_hpa, abs=0.5)
    assert r.material_temp_c == pytest.approx(controller_only.material_temp_c, abs=0.5)
    assert instruments["environment"]["endpoint"] == transmitter.url
    assert "XY-MD02" in instruments["environment"]["model"]


def test_unreachable_transmitter_is_a_one_line_error(tmp_path: Path) -> None:
    with pytest.raises(UserError, match="environment transmitter") as info:
        open_environment(f"modbus-rtu:{tmp_path / 'no-such-port'}?baud=9600")
    assert "\n" not in str(info.value)


def test_probe_shows_the_transmitter(transmitter, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["devices", "probe", "--environment", transmitter.url, "--count", "2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"environment {transmitter.url}: model=XY-MD02")
    assert lines[1:] == [f"#{i} environment: air 23.4 C  humidity 61.7 %RH" for i in (1, 2)]


def test_probe_with_nothing_to_probe() -> None:
    one_line_error(guideway("devices", "probe"), "nothing to probe", "--environment URL")


def test_simulated_run_with_a_transmitter_in_the_set_up(tmp_path: Path) -> None:
    text = setup_text("keyence-lkg", None, "height") + '\n[transmitter]\nurl = "modbus-rtu:/dev/ttyUSB2?baud=9600"\n'
    setup = straightness_setup_from_dict(tomllib.loads(text), "setup.toml")
    assert setup.devices.environment_url == "modbus-rtu:/dev/ttyUSB2?baud=9600"
    out = io.StringIO()
    res = run_straightness(setup, tmp_path / "run", simulate=SimOptions(seed=3, noise=True), auto=True, stream=out)
    assert res.outcome.exit_status == "success", out.getvalue()
    assert "simulated transmitter: XY-MD02" in out.getvalue()
    meta = json.loads((res.run_dir / "run.json").read_text())
    assert "XY-MD02" in meta["instruments"]["environment"]["model"]
    rows = (res.run_dir / "points.csv").read_text().splitlines()
    header = rows[0].split(",")
    air = np.array([float(r.split(",")[header.index("air_temp_c")]) for r in rows[1:]])
    rh = np.array([float(r.split(",")[header.index("humidity_pct")]) for r in rows[1:]])
    # The XY-MD02 reports tenths (register = value x 10): every logged value is on that grid,
    # which the noisy environment unit of the simulated controller never is.
    assert len(air) == 5
    assert np.allclose(air * 10, np.round(air * 10), atol=1e-9)
    assert np.allclose(rh * 10, np.round(rh * 10), atol=1e-9)


def test_bad_transmitter_url_in_the_set_up() -> None:
    from saved_runs.errors import SetupError

    text = setup_text("keyence-lkg", None, "height") + '\n[transmitter]\nurl = "/dev/ttyUSB2"\n'
    with pytest.raises(SetupError, match=r"\[transmitter\] url"):
        straightness_setup_from_dict(tomllib.loads(text), "setup.toml")
