"""--faults entries that cannot fire are refused before the run; those that did not fire by the
end are reported (terminal and run.json ``fault_plan``).  The sensor requests a run makes are
counted on the simulated devices, not taken from the table the check uses."""

from __future__ import annotations

import io
import json
import tomllib
from pathlib import Path

import pytest

from acquisition.acquire import SimOptions, run_positioning
from acquisition.demo import run_demo
from acquisition.rig import open_rig
from acquisition.setup.positioning import positioning_setup_from_dict
from acquisition.simulated.rig import start_simulated_rig
from acquisition.simulated.sensors import REQUESTS_PER_SAMPLE, SENSOR_EMULATORS
from mocks.faults import FaultPlan
from saved_runs.errors import UserError
from tui.cli import main

ROOT = Path(__file__).resolve().parents[2]


def test_a_plan_knows_which_entries_applied() -> None:
    plan = FaultPlan.parse("sensor:drop@2x1,sensor:garbage@2,controller:delay@4=0")
    for _ in range(3):
        plan.next_request("sensor")
    # request 2 is the first entry's; the second entry applies from request 3
    assert [f.spec() for f in plan.unfired()] == ["controller:delay@4=0"]
    assert plan.faults[0].spec() == "sensor:drop@2x1" and plan.requests("sensor") == 3


@pytest.mark.parametrize("protocol", sorted(SENSOR_EMULATORS))
def test_requests_per_averaged_sample_as_counted_on_the_simulated_sensor(protocol: str) -> None:
    sim = start_simulated_rig(seed=1, noise=False, sensor=protocol)
    try:
        rig = open_rig(sim.sensor_protocol, sim.sensor_url, sim.controller_url, baudrate=sim.sensor_baudrate)
        try:
            assert sim.faults is not None and rig.sensor is not None
            before = sim.faults.requests("sensor")
            rig.sensor.read_averaged(4)
            assert sim.faults.requests("sensor") - before == 4 * REQUESTS_PER_SAMPLE[protocol]
        finally:
            rig.close()
    finally:
        sim.close()


def test_a_sensor_fault_past_the_last_request_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # 20 stations of 5 samples: the LK-G sensor is asked 100 times
    assert main(["demo", "--out", str(tmp_path / "run"), "--faults", "sensor:garbage@500"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "--faults sensor:garbage@500 cannot fire: a run of this set-up asks the sensor 100 times" in err
    assert not (tmp_path / "run").exists()


def test_the_last_request_can_still_fail(tmp_path: Path) -> None:
    # 3 stations x 2 samples = 6 requests: @7 is refused, @6 fires (on the last sample) and is retried
    with pytest.raises(UserError, match="asks the sensor 6 times; give N <= 6"):
        run_demo(tmp_path / "a", stations=3, samples=2, noise=False, faults="sensor:drop@7", stream=io.StringIO())
    out = io.StringIO()
    res = run_demo(tmp_path / "b", stations=3, samples=2, noise=False, faults="sensor:garbage@6x1", stream=out)
    assert res.outcome.exit_status == "success"
    meta = json.loads((tmp_path / "b" / "run.json").read_text(encoding="utf-8"))
    assert meta["fault_plan"]["not_fired"] == [] and meta["fault_plan"]["spec"] == "sensor:garbage@6x1"
    assert meta["fault_plan"]["requests"]["sensor"] == 8  # the retry read both samples of the last station again
    assert "did not fire" not in out.getvalue()


def test_a_fault_that_did_not_fire_is_reported(tmp_path: Path) -> None:
    out = io.StringIO()
    run_demo(tmp_path / "run", stations=3, samples=2, noise=False, faults="controller:exception@100000x1",
             stream=out)
    meta = json.loads((tmp_path / "run" / "run.json").read_text(encoding="utf-8"))
    assert meta["fault_plan"]["not_fired"] == ["controller:exception@100000x1"]
    assert meta["fault_plan"]["requests"]["sensor"] == 6
    assert "note: fault controller:exception@100000x1 did not fire (requests: sensor 6, controller " in out.getvalue()


def test_a_positioning_run_has_no_sensor_to_fault(tmp_path: Path) -> None:
    src = tomllib.loads((ROOT / "docs" / "setup-positioning.toml").read_text(encoding="utf-8"))
    setup = positioning_setup_from_dict(src)
    with pytest.raises(UserError, match="sensor:drop@3 cannot fire: this run has no displacement sensor"):
        run_positioning(setup, tmp_path / "run", simulate=SimOptions(faults="sensor:drop@3"), auto=True,
                        stream=io.StringIO())
    assert not (tmp_path / "run").exists()
