"""Complete simulated straightness runs over the real pty and Modbus TCP
transports: return pass, a device fault that pauses the run until the
controller is reachable again, and ``guideway acquire`` killed with SIGKILL at
a random point and resumed."""

from __future__ import annotations

import io
import json
import random
from pathlib import Path

import numpy as np
import pytest

from acquisition import messages as m
from acquisition.acquire import SimOptions, run_straightness
from acquisition.demo import demo_setup
from acquisition.engine import RunEngine, RunState
from acquisition.operators import AutoOperator
from acquisition.plans import straightness_plan
from acquisition.rig import open_rig
from acquisition.simulated.rig import start_simulated_rig
from mocks.interferometer import InterferometerEmulator, ModbusServerThread
from saved_runs.store.reader import load_run
from saved_runs.store.writer import RunStore

from ..cli import guideway, kill_when
from ..setups import straightness_setup_text
from ..waiting import line_count

MEASURED = ["station", "pass", "x_mm", "lin_um", "stry_um", "strz_um", "pitch_urad", "yaw_urad", "roll_urad",
            "sensor_mm"]


def test_return_pass_run_repeats_the_forward_values(tmp_path: Path) -> None:
    setup = demo_setup(stations=6, samples=2)
    from dataclasses import replace

    setup = replace(setup, return_pass=True)
    res = run_straightness(setup, tmp_path / "run", simulate=SimOptions(seed=2, noise=False), auto=True,
                           stream=io.StringIO())
    assert res.outcome.exit_status == "success"
    run = load_run(tmp_path / "run")
    pts = run.points
    assert list(zip(pts["pass"], pts["station"], strict=True)) == (
        [(0, k) for k in range(6)] + [(1, k) for k in range(5, -1, -1)])
    # noise-free and the block re-placed exactly: each station reads the same on the way back
    fwd = pts[pts["pass"] == 0].set_index("station").sort_index()
    back = pts[pts["pass"] == 1].set_index("station").sort_index()
    for col in ("stry_um", "pitch_urad", "sensor_mm"):
        np.testing.assert_allclose(back[col], fwd[col], atol=1e-3)
    assert run.meta["status"] == "complete" and run.meta["setup"]["return_pass"] is True
    assert run.meta["progress"] == {"pass": 1, "station": 0} and run.meta["simulation"]["seed"] == 2


def test_controller_lost_mid_run_pauses_and_continues_after_reconnection(tmp_path: Path) -> None:
    sim = start_simulated_rig(seed=3, noise=False)
    port = int(sim.controller_url.rsplit(":", 1)[1])
    servers: list[ModbusServerThread] = []
    try:
        rig = open_rig(sim.sensor_protocol, sim.sensor_url, sim.controller_url)

        class Technician(AutoOperator):
            """Pulls the controller's plug before station 3; plugs it back in when told of the fault."""

            def instruct(self, msg: m.Instruct) -> str:
                if msg.params.get("station") == 3 and not servers:
                    sim._modbus.stop()
                return super().instruct(msg)

            def prompt(self, msg: m.Prompt) -> str:
                if msg.key == "fault" and not servers:
                    self.fault_text = msg.text
                    servers.append(ModbusServerThread(InterferometerEmulator(sim.world).device(), port=port))
                return super().prompt(msg)

        op = Technician({"place_block": sim.place_block})
        store = RunStore(tmp_path / "run", {"setup": {}})
        engine = RunEngine(rig, op, (store,))
        out = engine.run(straightness_plan(demo_setup(stations=6, samples=2), {}))
        rig.close()
    finally:
        for s in servers:
            s.stop()
        sim.close()
    assert out.exit_status == "success", out.reason
    assert "Device fault" in op.fault_text and "controller" in op.fault_text and "retry" in op.fault_text
    assert RunState.PAUSED in engine.state_log
    run = load_run(tmp_path / "run")
    assert run.points["station"].tolist() == list(range(6)) and run.meta["status"] == "complete"
    assert len(run.meta["faults"]) == 1


KILLED_STATIONS = 30  # with the return pass: 60 steps, so a kill can land in either pass
KILLED_COMMON = ["--simulate", "--auto", "--no-noise", "--seed", "5"]


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The set-up of the killed runs, and the run it gives when never interrupted (the same for every kill)."""
    base = tmp_path_factory.mktemp("uninterrupted")
    setup = base / "setup.toml"
    setup.write_text(straightness_setup_text(stations=KILLED_STATIONS, return_pass=True))
    ref = guideway("acquire", "straightness", "--setup", setup, "--out", base / "ref", *KILLED_COMMON)
    assert ref.returncode == 0, ref.stderr
    return setup, base / "ref"


@pytest.mark.parametrize("seed", [11, 29, 4])
def test_sigkill_then_resume_gives_the_uninterrupted_points(tmp_path: Path, seed: int,
                                                            uninterrupted: tuple[Path, Path]) -> None:
    stations = KILLED_STATIONS
    steps = 2 * stations
    setup, ref_dir = uninterrupted
    common = KILLED_COMMON
    killed_dir = tmp_path / "killed"
    kill_after = random.Random(seed).randrange(2, steps - 25)  # points on disk before the kill
    # a separate process, killed; its temporary files (the sensor link) go to a TMPDIR this test owns
    kill_when(lambda: line_count(killed_dir / "points.csv") > kill_after, "acquire", "straightness", "--setup", setup,
              "--out", killed_dir, *common, tmp_dir=tmp_path / "tmp", what="points")
    partial = load_run(killed_dir)
    assert partial.meta["status"] == "in-progress" and len(partial.points) < steps
    res = guideway("acquire", "straightness", "--out", killed_dir, "--resume", *common)
    assert res.returncode == 0, res.stderr
    resumed, reference = load_run(killed_dir), load_run(ref_dir)
    assert resumed.meta["status"] == "complete" and resumed.meta["uid"] == partial.meta["uid"]
    assert resumed.meta["resumed"][0]["points"] == len(partial.points)
    assert resumed.points["station"].tolist() == list(range(stations)) + list(range(stations - 1, -1, -1))
    # every measured value is the same as in the run that was never interrupted
    assert resumed.points[MEASURED].equals(reference.points[MEASURED])
    assert json.loads((killed_dir / "run.json").read_text())["points"] == steps


def test_live_heights_equal_the_offline_profile(tmp_path: Path) -> None:
    from saved_runs.evaluation.evaluate import process_run_dir

    out = io.StringIO()
    res = run_straightness(demo_setup(stations=8, samples=2), tmp_path / "run", simulate=SimOptions(seed=6),
                           auto=True, stream=out)
    assert res.outcome.exit_status == "success" and res.live is not None
    _, evaluation = process_run_dir(tmp_path / "run")
    profile = evaluation.result.profile  # type: ignore[attr-defined]
    live = [res.live.heights[(0, k)] for k in range(8)]
    np.testing.assert_allclose(live, profile["height_um"].to_numpy(), atol=1e-9)
    assert "live: station 7 surface height" in out.getvalue()
