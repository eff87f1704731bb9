"""Every simulated sensor family has a driver and answers it over a pty at its
own line rate (new families join these checks by their registry line), and
each family's values carry the sign the simulated rig reports."""

from __future__ import annotations

import threading
from types import SimpleNamespace

import numpy as np
import pytest

from acquisition.rig import SENSOR_DRIVERS, open_sensor
from acquisition.simulated.rig import SAMPLE_LOG_LIMIT, bound_sample_log, start_simulated_rig
from acquisition.simulated.sensors import SENSOR_EMULATORS, default_block

# What each family reports for a surface height h (mm, closer -> larger), from its protocol
# document: the LK-G and HL-G1 a signed value around the head's reference distance, the ILD1420
# the distance from the start of its 10 mm range (mid-range at h = 0; further away -> larger).
EXPECTED = {
    "keyence-lkg": (115200, "height", lambda h: h),
    "panasonic-hlg1": (115200, "height", lambda h: h),
    "me-ild1420": (921600, "gap", lambda h: 10.0 / 2 - h),
}


def test_every_family_with_a_driver_is_simulated() -> None:
    assert set(SENSOR_EMULATORS) == set(SENSOR_DRIVERS) == set(EXPECTED)


@pytest.mark.parametrize("protocol", sorted(EXPECTED))
def test_registry_line_rate_sign_and_value_convention(protocol: str) -> None:
    baud, sign, value = EXPECTED[protocol]
    kind = SENSOR_EMULATORS[protocol]
    assert (kind.baudrate, kind.sensor_sign) == (baud, sign)
    for h in (-0.0123, 0.0, 0.25):
        assert kind.reading(h) == pytest.approx(value(h), abs=1e-12)
    assert default_block(protocol)[1].sensor_sign == sign


@pytest.mark.parametrize("protocol", sorted(SENSOR_EMULATORS))
def test_registered_emulator_answers_its_driver(protocol: str) -> None:
    _, sign, value = EXPECTED[protocol]
    rig = start_simulated_rig(seed=1, noise=False, sensor=protocol)
    try:
        assert rig.sensor_baudrate == SENSOR_EMULATORS[protocol].baudrate
        assert rig.geometry().sensor_sign == sign
        dev = open_sensor(protocol, rig.sensor_url, baudrate=None)  # the driver's own default rate
        try:
            reading = dev.read_once()
            averaged = dev.read_averaged(3)
        finally:
            dev.close()
    finally:
        rig.close()
    world = rig.world  # noise off: the reading is the family's value of the world's height,
    h = world.block.standoff_mm - world.sensor_distance_mm()  # within the coarsest resolution (0.16 um)
    assert reading.ok
    assert reading.value_mm == pytest.approx(value(h), abs=2e-4)
    assert averaged.count == 3 and averaged.mean_mm == pytest.approx(value(h), abs=2e-4)


@pytest.mark.parametrize("protocol", sorted(SENSOR_EMULATORS))
def test_a_set_up_with_the_other_sign_is_honoured(protocol: str) -> None:
    """A set-up declaring the opposite sign gets a head read the other way round: the reading
    moves against the family's own convention when the surface comes closer."""
    _, sign, value = EXPECTED[protocol]
    other = "gap" if sign == "height" else "height"
    length_mm, geometry = default_block(protocol)
    flipped = type(geometry)(geometry.mirror_mm, geometry.sensor_mm, geometry.sensor_beam, other)
    rig = start_simulated_rig(seed=1, noise=False, sensor=protocol, block_length_mm=length_mm, geometry=flipped)
    heights, readings = [], []
    try:
        assert rig.geometry().sensor_sign == other
        dev = open_sensor(protocol, rig.sensor_url, baudrate=None)
        try:
            for station in (0, 3):
                rig.place_block(station)
                readings.append(dev.read_once().value_mm)
                heights.append(rig.world.block.standoff_mm - rig.world.sensor_distance_mm())
        finally:
            dev.close()
    finally:
        rig.close()
    assert abs(heights[1] - heights[0]) > 1e-3  # the surface moved by more than 1 um between the stations
    # within the coarsest family's resolution (ILD1420-10: 10 mm x 1.02 / 65520 = 0.16 um a count)
    assert readings == pytest.approx([value(-h) for h in heights], abs=2e-4)


def pacer_threads() -> int:
    return sum(t.name == "ILD1420StreamPacer" for t in threading.enumerate())


def test_streaming_head_streams_from_start_until_close() -> None:
    before = pacer_threads()
    rig = start_simulated_rig(seed=1, noise=False, sensor="me-ild1420")
    try:
        assert pacer_threads() == before + 1
        dev = open_sensor("me-ild1420", rig.sensor_url, baudrate=None)
        try:
            assert dev.read_once().ok  # no command sent: the values flow from power-up
        finally:
            dev.close()
    finally:
        rig.close()
    assert pacer_threads() == before


def test_sample_log_keeps_the_newest_sample_of_each_station() -> None:
    world = SimpleNamespace(sample_log=[(k % 3, np.array([float(k)])) for k in range(SAMPLE_LOG_LIMIT + 1)])
    bound_sample_log(world)  # type: ignore[arg-type]
    n = SAMPLE_LOG_LIMIT + 1
    newest = {st: max(k for k in range(n) if k % 3 == st) for st in range(3)}
    assert sorted((st, float(hit[0])) for st, hit in world.sample_log) == sorted(
        (st, float(k)) for st, k in newest.items())
    short = SimpleNamespace(sample_log=[(0, np.zeros(3))] * 10)
    bound_sample_log(short)  # type: ignore[arg-type]
    assert len(short.sample_log) == 10  # below the limit nothing is dropped
