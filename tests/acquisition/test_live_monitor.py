"""The live monitor reads the rig while the engine lets it, and hands the devices back on a claim."""

from __future__ import annotations

import math
import threading
from pathlib import Path

from acquisition.engine import RunEngine
from acquisition.messages import Requested, Wait
from acquisition.monitor import LiveMonitor, LiveReading
from acquisition.operators import AutoOperator
from acquisition.rig import open_rig
from acquisition.simulated.rig import start_simulated_rig
from tests.waiting import wait_for


def test_streaming_sensor_read_in_blocks_then_handed_back_to_the_engine(tmp_path: Path) -> None:
    sim = start_simulated_rig(seed=1, noise=False, sensor="me-ild1420", sensor_link=tmp_path / "sensor")
    rig = open_rig(sim.sensor_protocol, sim.sensor_url, sim.controller_url)
    readings: list[LiveReading] = []
    try:
        with LiveMonitor(rig, readings.append, interval_s=0.05) as monitor:
            wait_for(lambda: sum(r.sensor_count > 1 for r in readings) >= 3, what="three stream blocks")
            rig.claim()  # what the engine does when it needs the devices
            try:
                n = len(readings)
                # the head streams again for the engine's polled read (output restored after the block)
                value = rig.sensor.read_averaged(3)
                assert value.ok
                assert len(readings) == n  # nothing read while the engine holds the rig
            finally:
                rig.release()
            wait_for(lambda: len(readings) > n, what="readings after the hand-back")
        blocks = [r for r in readings if r.sensor_count > 1]
        # the simulated ILD1420 streams at 1 kHz: a 50 ms block holds dozens of values, none lost
        assert all(r.frames_lost == 0 and r.sensor_status == "ok" for r in blocks)
        assert monitor.frames_received >= sum(r.sensor_count for r in blocks)
        assert any(r.interferometer is not None and r.interferometer.ok for r in readings)
    finally:
        rig.close()
        sim.close()


def test_operator_request_is_answered_once_and_ends_a_wait() -> None:
    sim = start_simulated_rig(seed=1, noise=False)
    rig = open_rig(sim.sensor_protocol, sim.sensor_url, sim.controller_url)
    engine = RunEngine(rig, AutoOperator())
    replies: list[object] = []

    def plan():  # noqa: ANN202
        replies.append((yield Requested("override")))
        replies.append((yield Wait(60.0)))  # ended early by the request below
        replies.append((yield Requested("override")))
        replies.append((yield Requested("override")))

    timer = threading.Timer(0.2, engine.request, args=("override",))
    try:
        timer.start()
        outcome = engine.run(plan())
    finally:
        timer.cancel()
        rig.close()
        sim.close()
    assert outcome.exit_status == "success"
    assert replies[0] is False and replies[1] < 30.0 and replies[2] is True and replies[3] is False


def test_rotary_set_up_reads_the_angle_captured_with_each_trigger() -> None:
    from acquisition.rig import open_controller_rig
    from acquisition.setup.positioning import positioning_setup_from_dict
    from acquisition.simulated.machine import start_simulated_machine

    setup = positioning_setup_from_dict({"axis": {"type": "rotary", "start_deg": 0.0, "end_deg": 360.0, "runs": 1,
                                                  "datum_deg": 0.0}})
    sim = start_simulated_machine(setup, seed=2, noise=False)
    sim.axis.set_datum()
    sim.cycle_start()  # the program runs to its first measured stop (0 deg) and waits there for the acknowledge
    wait_for(lambda: sim.axis.in_position, what="the first target")
    sim.axis.acknowledge(sim.axis.count)  # the PLC moves on to the second target and waits again
    target = sim.axis.stops[sim.axis.index].position
    rig = open_controller_rig(sim.controller_url)
    readings: list[LiveReading] = []
    try:
        with LiveMonitor(rig, readings.append, interval_s=0.02, interferometer_interval_s=0.0, angle=True):
            wait_for(lambda: len(readings) >= 3, what="three live readings")
    finally:
        rig.close()
        sim.close()
    # the angle the simulated controller latched at each live trigger: the axis at rest at the target, from the
    # datum (noise off); the simulated errors put it a few arcsec off the commanded target
    truth = sim.axis.captured[-1][1] - setup.datum
    assert target != 0.0 and abs(truth - target) < 30 / 3600
    assert all(r.problem == "" and r.angle_deg == truth for r in readings)
    # a linear set-up's monitor does not read the angle
    assert math.isnan(LiveReading(0.0).angle_deg)
