"""``guideway acquire --auto`` with real devices: hands-free capture.  The tool waits at each station
until the interferometer shows the block at the station (|lin| within ``max_lin_um``) and still
(``[auto]``), then captures.  Tested as a plan with scripted readings, and end to end against the
simulated rig opened as real devices, with a simulated technician that slides the block to the next
station on its own once the previous point is on disk."""

from __future__ import annotations

import io
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest

from acquisition import messages as m
from acquisition.acquire import SimOptions, run_straightness
from acquisition.plans.straightness import straightness_plan
from acquisition.setup.straightness import StraightnessSetup
from acquisition.simulated.rig import SimulatedRig, start_simulated_rig
from drivers.readings import ControllerStatus, InterferometerReading
from saved_runs.store.reader import load_run

from .plan_driver import Scripted, drive
from .sim_clock import simulated_clock
from .test_controller_recovery import straightness

OK = ControllerStatus(True, False, True, False, True, 1, 0, "", 0b10101)


def setup(stations: int, **auto: float) -> StraightnessSetup:
    return straightness(stations, auto={"station_timeout_s": 10.0, "still_s": 0.3, "still_um": 2.0, "poll_s": 0.05,
                                        **auto})


# the end-to-end runs: the block must rest for 0.8 s (16 readings of the simulated clock), eight times
# the technician's 0.1 s steps
STILL = {"still_s": 0.8, "poll_s": 0.05}


# -- the plan, scripted --------------------------------------------------------------------------------
def ifm(t: float, x_mm: float) -> InterferometerReading:
    return InterferometerReading(x_mm, 0.0, 0.0, 0.0, 0.0, 0.0, 20.0, 1013.0, 45.0, 20.0, 1, OK, t)


def test_the_plan_waits_for_the_block_at_the_station_and_still() -> None:
    s = setup(2)  # station 1 at x = 100 mm; max_lin_um 2000, still 2 um over 0.3 s, polled every 0.05 s
    # (time s, position mm) of the block at station 0, then being slid to station 1
    script = [(0.0, 0.0),  # datum capture
              (1.0, 0.0), (1.05, 60.0),  # not at station 1 yet
              (1.10, 98.5), (1.15, 99.2),  # within 2000 um, but still moving
              (1.20, 100.0010), (1.25, 100.0011), (1.30, 100.0009), (1.35, 100.0012), (1.40, 100.0010),
              (1.45, 100.0011), (1.50, 100.0010), (1.55, 100.0010)]
    msgs = drive(straightness_plan(s, {}, hands_free=True), Scripted(ifm(*r) for r in script)).msgs
    rows = [x.data for x in msgs if isinstance(x, m.Record)]
    # nobody was asked to place the block at station 1 (only the datum instruction)
    assert [x.key for x in msgs if isinstance(x, m.Instruct)] == ["datum"]
    assert not [x for x in msgs if isinstance(x, m.Prompt)]
    # from 1.20 s the block stays within 2 um; at 1.50 s it has done so for 0.3 s: the next reading
    # (1.55 s) is the capture's
    assert [r["station"] for r in rows] == [0, 1]
    assert rows[1]["time_s"] == pytest.approx(1.55) and rows[1]["lin_um"] == pytest.approx(1.0, abs=1e-6)


# -- end to end against the simulated rig, opened as real devices -----------------------------------------
class SlideTechnician:
    """Once station k's point is on disk, slides the block to station k + 1 in steps (1.5, 0.8, 0.3 mm
    short of it, 0.1 s apart, after 0.15 s) and lets go.  It acts at the interferometer readings of a
    simulated clock of one poll (0.05 s) per reading (tests/acquisition/sim_clock.py), so a stall of a
    loaded machine cannot turn a step into a rest of 0.8 s."""

    STEPS = {3: 1.5, 5: 0.8, 7: 0.3, 9: 0.0}  # readings after the point was on disk -> mm short (0: let go)

    def __init__(self, sim: SimulatedRig, points: Path, stations: int) -> None:
        self.sim, self.points, self.stations = sim, points, stations
        self.k = 0  # the station the block rests at (or is being slid from)
        self.seen: int | None = None  # the reading at which station k's point was found on disk

    def __call__(self, n: int) -> None:
        if self.k >= self.stations - 1:
            return
        if self.seen is None:
            if self.points.exists() and len(self.points.read_text().splitlines()) >= self.k + 2:
                self.seen = n
            return
        offset = self.STEPS.get(n - self.seen)
        if offset is None:
            return
        if offset:
            self.sim.world.place_block(self.k + 1, offset_mm=offset)
        else:
            self.sim.place_block(self.k + 1)
            self.k, self.seen = self.k + 1, None


@pytest.fixture
def rig() -> Iterator[SimulatedRig]:
    sim = start_simulated_rig(seed=3, noise=True)
    yield sim
    sim.close()


def with_devices(s: StraightnessSetup, sim: SimulatedRig) -> StraightnessSetup:
    return replace(s, devices=replace(s.devices, sensor_url=sim.sensor_url, controller_url=sim.controller_url))


def test_hands_free_run_captures_each_station_once_the_block_rests_there(
        tmp_path: Path, rig: SimulatedRig, monkeypatch: pytest.MonkeyPatch) -> None:
    stations = 4
    out = tmp_path / "run"
    stream = io.StringIO()
    tech = SlideTechnician(rig, out / "points.csv", stations)
    with simulated_clock(monkeypatch, step_s=STILL["poll_s"]) as clock:
        clock.on_reading = tech
        res = run_straightness(with_devices(setup(stations, **STILL), rig), out, auto=True, stream=stream)
    assert tech.k == stations - 1  # every slide was made
    assert res.outcome.exit_status == "success", res.outcome.reason
    run = load_run(out)
    pts = run.points
    assert pts["station"].tolist() == list(range(stations))
    # captured at rest at the station: within the placement scatter (20 um, noise on), never 300 um or
    # more short of it as while the block was being slid
    assert (pts["lin_um"].abs() < 100).all(), pts["lin_um"].tolist()
    assert "hands-free: at each station the tool waits up to 10 s" in stream.getvalue()
    assert "hands-free: waiting for the block at station 3 (x = 300 mm)" in stream.getvalue()


def test_a_block_that_never_arrives_asks_then_the_unattended_run_gives_up(tmp_path: Path, rig: SimulatedRig
                                                                         ) -> None:
    s = setup(3, station_timeout_s=0.4, still_s=0.2, poll_s=0.05)
    res = run_straightness(with_devices(s, rig), tmp_path / "run", auto=True, stream=io.StringIO())
    # the automatic operator keeps waiting once, then aborts: the fault ends the run
    assert res.outcome.exit_status == "fail"
    assert res.outcome.reason == "block not at rest at station 1 (x = 100 mm) within 0.4 s"
    assert load_run(tmp_path / "run").points["station"].tolist() == [0]


def test_simulate_auto_is_still_the_simulated_technician(tmp_path: Path) -> None:
    # --simulate --auto places the block itself when asked (no waiting for a technician)
    stream = io.StringIO()
    res = run_straightness(setup(3), tmp_path / "run", simulate=SimOptions(seed=1, noise=False), auto=True,
                           stream=stream)
    assert res.outcome.exit_status == "success" and "hands-free" not in stream.getvalue()
