"""Every simulated sensor family has a driver and answers it over a pty at its
own line rate (new families join these checks by their registry line)."""

from __future__ import annotations

import pytest

from acquisition.rig import SENSOR_DRIVERS, open_sensor
from acquisition.simulation import SENSOR_EMULATORS, start_simulated_rig


@pytest.mark.parametrize("protocol", sorted(SENSOR_EMULATORS))
def test_registered_emulator_answers_its_driver(protocol: str) -> None:
    assert protocol in SENSOR_DRIVERS
    rig = start_simulated_rig(seed=1, noise=False, sensor=protocol)
    try:
        assert rig.sensor_baudrate == SENSOR_EMULATORS[protocol].baudrate
        dev = open_sensor(protocol, rig.sensor_url, baudrate=rig.sensor_baudrate)
        try:
            reading = dev.read_once()
        finally:
            dev.close()
    finally:
        rig.close()
    world = rig.world  # noise off: the reading is the world's height value in mm, within 1 um
    assert reading.ok
    assert reading.value_mm == pytest.approx(world.block.standoff_mm - world.sensor_distance_mm(), abs=1e-3)
