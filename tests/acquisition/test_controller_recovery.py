"""Runs against controllers that behave like real ones (issue 9, "Controllers"): a beam interruption
latched until *clear error*, a slow controller, a controller at another unit id, and the set-up keys
that describe them (``[controller]`` timing, ``[sensor]`` series / output).  Simulated devices on
real transports (Modbus TCP, pty)."""

from __future__ import annotations

import io
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from acquisition import messages as m
from acquisition.acquire import SimOptions, run_straightness
from acquisition.demo import run_demo
from acquisition.operators import AutoOperator
from acquisition.setup.straightness import StraightnessSetup, straightness_setup_from_dict
from acquisition.simulated.rig import start_simulated_rig
from saved_runs.errors import SetupError
from saved_runs.store.reader import load_run
from tests.test_demo_end_to_end import ls_residual, truth_heights_um

ROOT = Path(__file__).resolve().parents[2]
BEAM = "beam interrupted: check the optics alignment and that nothing crosses the beam"


def straightness(stations: int = 4, **tables: dict[str, Any]) -> StraightnessSetup:
    """docs/setup-straightness.toml with ``stations`` stations, 2 samples, no warm-up, and ``tables`` merged in."""
    d = tomllib.loads((ROOT / "docs" / "setup-straightness.toml").read_text())
    d["block"].update(stations=stations, samples_per_reading=2)
    d["warmup"]["enabled"] = False
    for name, values in tables.items():
        d.setdefault(name, {}).update(values)
    return straightness_setup_from_dict(d, "setup.toml")


# -- a latched beam error ----------------------------------------------------------------------------
def test_demo_with_a_beam_interruption_clears_it_and_repeats_the_capture(tmp_path: Path) -> None:
    stations = 12
    out = io.StringIO()
    res = run_demo(tmp_path / "run", stations=stations, seed=2, noise=False, samples=2,
                   faults="controller:beam-loss@30", stream=out)
    assert res.outcome.exit_status == "success", res.outcome.reason
    run = load_run(res.run_dir)
    assert run.meta["status"] == "complete"
    assert run.points["station"].tolist() == list(range(stations))  # every station once: the lost one repeated
    endpoint = run.meta["instruments"]["interferometer"]["endpoint"]
    assert run.meta["faults"] == [f"controller {endpoint}: device reported error 1 to 'trigger': {BEAM}"]
    text = out.getvalue()
    assert "error cleared, beam OK: repeating the step" in text and "paused" not in text
    # the repeated capture is as good as the others: noise off, the profile is the simulated surface
    # (its sample points) to 0.01 um, the display resolution, after removing the least-squares line
    assert res.result is not None
    prof = res.result.profile
    x_true, h_true = truth_heights_um(res.sim.world)
    err = ls_residual(prof["x_mm"].to_numpy(), prof["height_um"].to_numpy()) - ls_residual(x_true, h_true)
    assert np.max(np.abs(err)) < 0.01


class BeamBlockedAt(AutoOperator):
    """Blocks the beam when asked to place the block at ``station``; unblocks it when the run pauses
    for the fault, then retries (what a technician does)."""

    def __init__(self, world: Any, station: int, **kw: Any) -> None:
        super().__init__(**kw)
        self.world, self.station = world, station
        self.fault_texts: list[str] = []

    def instruct(self, msg: m.Instruct) -> str:
        answer = super().instruct(msg)
        if msg.params.get("station") == self.station:
            self.world.beam_blocked = True
        return answer

    def prompt(self, msg: m.Prompt) -> str:
        if msg.key == "fault":
            self.fault_texts.append(msg.text)
            self.world.beam_blocked = False
        return super().prompt(msg)


def test_a_beam_still_blocked_is_not_captured_the_run_waits_for_it(tmp_path: Path) -> None:
    sim = start_simulated_rig(seed=1, noise=False)
    try:
        setup = straightness()
        setup = replace(setup, devices=replace(setup.devices, sensor_url=sim.sensor_url,
                                               controller_url=sim.controller_url))
        op = BeamBlockedAt(sim.world, 2, actions={"place_block": sim.place_block})
        res = run_straightness(setup, tmp_path / "run", operator=op, stream=io.StringIO())
    finally:
        sim.close()
    assert res.outcome.exit_status == "success", res.outcome.reason
    run = load_run(tmp_path / "run")
    assert run.points["station"].tolist() == [0, 1, 2, 3]
    # the automatic clear found the beam still interrupted: the run paused and asked, the operator's
    # retry cleared the error again with the beam back
    assert len(op.fault_texts) == 1 and "could not be cleared" in op.fault_texts[0]
    assert "check the beam" in op.fault_texts[0]
    assert run.meta["faults"][0] == f"controller {sim.controller_url}: device reported error 1 to 'trigger': {BEAM}"
    assert run.meta["faults"][1].startswith("controller error 1 (beam interrupted")
    assert len(run.meta["faults"]) == 2


# -- slow controllers (the 2.5 s per measurement, scaled by 0.12) ------------------------------
# The deadlines leave a loaded machine at least 0.7 s beyond the measurement for the polls that see it
# complete (a 0.1 s margin let a stalled poll fail the run); the second still needs its retries
# (0.25 s < 0.3 s, 4 x 0.25 s > 0.3 s).
SLOW = "controller:slow@1=0.3"


@pytest.mark.parametrize("controller", [{"trigger_timeout_s": 1.5, "trigger_retries": 0},
                                        {"trigger_timeout_s": 0.25, "trigger_retries": 3}])
def test_a_slow_controller_completes_the_run_with_its_set_up_keys(tmp_path: Path, controller: dict) -> None:
    setup = straightness(controller=controller)
    res = run_straightness(setup, tmp_path / "run", simulate=SimOptions(seed=1, noise=False, faults=SLOW),
                           auto=True, stream=io.StringIO())
    assert res.outcome.exit_status == "success", res.outcome.reason
    run = load_run(tmp_path / "run")
    assert run.points["station"].tolist() == [0, 1, 2, 3] and not run.meta.get("faults")
    assert run.meta["setup"]["devices"]["trigger_timeout_s"] == controller["trigger_timeout_s"]


def test_a_deadline_shorter_than_the_measurement_fails_without_blaming_the_address(tmp_path: Path) -> None:
    # 0.5 s per measurement against a 0.08 s deadline: far enough apart for a loaded machine
    setup = straightness(controller={"trigger_timeout_s": 0.08, "trigger_retries": 0})
    res = run_straightness(setup, tmp_path / "run",
                           simulate=SimOptions(seed=1, noise=False, faults="controller:slow@1=0.5"),
                           auto=True, stream=io.StringIO())
    assert res.outcome.exit_status == "fail"
    assert "not completed within 0.08 s" in res.outcome.reason
    assert "the controller answers" in res.outcome.reason and "address" not in res.outcome.reason


# -- unit id ---------------------------------------------------------------------------------------------
def test_the_simulated_controller_answers_at_the_set_up_device_id(tmp_path: Path) -> None:
    setup = straightness(controller={"url": "modbus-tcp://192.168.0.10:502?device_id=7"})
    res = run_straightness(setup, tmp_path / "run", simulate=SimOptions(seed=1, noise=False), auto=True,
                           stream=io.StringIO())
    assert res.outcome.exit_status == "success", res.outcome.reason
    ifm = load_run(tmp_path / "run").meta["instruments"]["interferometer"]
    assert ifm["device_id"] == 7 and ifm["endpoint"].endswith("?device_id=7")
    # the identity the controller sent, from both read codes
    assert (ifm["vendor"], ifm["product_code"], ifm["revision"]) == ("guideway-sim", "SIM-6DOF", "1.0")
    assert (ifm["product"], ifm["model"]) == ("Simulated 6-DOF interferometer controller", "SIM-6DOF-IFM")


def test_a_wrong_device_id_is_found_before_the_run_starts(tmp_path: Path) -> None:
    from saved_runs.errors import UserError

    sim = start_simulated_rig(seed=1, noise=False, device_id=7)
    try:
        setup = straightness()
        url = sim.controller_url.replace("?device_id=7", "")  # device id 1: nobody there
        setup = replace(setup, devices=replace(setup.devices, sensor_url=sim.sensor_url, controller_url=url))
        with pytest.raises(UserError) as info:
            run_straightness(setup, tmp_path / "run", auto=True, stream=io.StringIO())
    finally:
        sim.close()
    text = str(info.value)
    assert "Modbus exception 11" in text and "no device answers at device id 1 behind the gateway" in text
    assert "\n" not in text and not (tmp_path / "run").exists()


# -- set-up keys --------------------------------------------------------------------------------------------
def test_controller_and_sensor_keys_reach_the_devices_and_run_json(tmp_path: Path) -> None:
    setup = straightness(sensor={"series": "LK-G5000", "output": 2},
                         controller={"trigger_timeout_s": 5.0, "poll_interval_s": 0.01, "request_timeout_s": 1.5,
                                     "trigger_retries": 1})
    d = setup.devices
    assert (d.trigger_timeout_s, d.poll_interval_s, d.request_timeout_s, d.trigger_retries) == (5.0, 0.01, 1.5, 1)
    assert (d.sensor_series, d.sensor_output) == ("LK-G5000", 2)
    res = run_straightness(setup, tmp_path / "run", simulate=SimOptions(seed=1, noise=False), auto=True,
                           stream=io.StringIO())
    assert res.outcome.exit_status == "success", res.outcome.reason
    meta = load_run(tmp_path / "run").meta
    sensor = meta["instruments"]["sensor"]
    assert sensor["model"] == "Keyence LK-G5000 (RS-232C)" and sensor["output"] == 2
    assert meta["setup"]["devices"]["sensor_series"] == "LK-G5000" and meta["setup"]["devices"]["sensor_output"] == 2


def test_defaults_of_the_controller_keys() -> None:
    d = straightness().devices
    assert (d.trigger_timeout_s, d.poll_interval_s, d.request_timeout_s, d.trigger_retries) == (2.0, 0.002, 1.0, 2)
    assert (d.sensor_series, d.sensor_output) == (None, None)


@pytest.mark.parametrize(("tables", "message"), [
    ({"controller": {"trigger_timeout_s": 0}}, "[controller] trigger_timeout_s must be a positive number"),
    ({"controller": {"request_timeout_s": -1.0}}, "[controller] request_timeout_s must be a positive number"),
    ({"controller": {"poll_interval_s": 3.0}}, "poll_interval_s (3 s) must be shorter than trigger_timeout_s (2 s)"),
    ({"controller": {"trigger_retries": -1}}, "[controller] trigger_retries must be a whole number >= 0"),
    ({"controller": {"trigger_retries": 1.5}}, "[controller] trigger_retries must be a whole number"),
    ({"controller": {"trigger_timeout_s": "5"}}, "[controller] trigger_timeout_s must be a number"),
    ({"controller": {"url": "modbus-tcp://10.0.0.5:502?unit=7"}}, "unknown Modbus TCP option(s) unit"),
    ({"controller": {"url": "modbus-rtu:/dev/ttyUSB1?device_id=300"}}, "device_id '300' must be a whole number"),
    ({"sensor": {"series": "LK-H"}}, "[sensor] LK-G series must be one of LK-G3000, LK-G5000"),
    ({"sensor": {"output": 3}}, "[sensor] LK-G3000 output must be 1..2, not 3"),
    ({"sensor": {"series": "LK-G5000", "output": 100}}, "LK-G5000 output must be 1..99"),
    ({"sensor": {"protocol": "panasonic-hlg1", "output": 2}}, "series and output apply to keyence-lkg"),
    ({"auto": {"still_s": 0}}, "[auto] still_s must be a positive number"),
    ({"auto": {"poll_s": 2.0}}, "[auto] poll_s (2 s) must be at most half of still_s"),
])
def test_bad_device_keys_are_one_line_setup_errors(tables: dict, message: str) -> None:
    with pytest.raises(SetupError) as info:
        straightness(**tables)
    text = str(info.value)
    assert message in text and text.startswith("setup.toml: ") and "\n" not in text


def test_a_positioning_set_up_takes_the_same_controller_keys() -> None:
    from acquisition.setup.positioning import positioning_setup_from_dict

    from .test_positioning_workflow import example

    s = positioning_setup_from_dict(example(controller={"trigger_timeout_s": 5.0, "trigger_retries": 0,
                                                        "url": "modbus-tcp://10.0.0.5:502?device_id=7"}))
    assert (s.devices.trigger_timeout_s, s.devices.trigger_retries) == (5.0, 0)
    assert s.to_run_setup()["devices"]["trigger_timeout_s"] == 5.0
    with pytest.raises(SetupError, match=r"setup: \[controller\] request_timeout_s must be a positive number"):
        positioning_setup_from_dict(example(controller={"request_timeout_s": 0.0}))
