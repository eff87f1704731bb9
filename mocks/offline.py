"""The simulated machine axis and world driven without transports, exactly as the tool drives
them over the wire (zero at the datum, capture at every stop), for ``guideway simulate``: a
synthetic run in seconds instead of the test's real duration."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from .effects import SensorEffects
from .machine_axis import MachineAxis
from .world import World


@dataclass
class StepClock:
    """A clock the caller sets (seconds): the simulated world's time."""

    t: float = 0.0

    def __call__(self) -> float:
        return self.t


def axis_captures(axis: MachineAxis) -> list[dict[str, Any]]:
    """Run the axis' whole program with the in-position handshake acknowledged at once; one record per
    measured stop: the stop, the interferometer capture, machine time (s) and the environment."""
    if axis.handshake != "ack":
        raise ValueError("the axis must run the in-position (acknowledge) handshake")
    axis.set_datum()
    axis.cycle_start()
    out = []
    while axis.in_position:
        stop = axis.stops[axis.index]
        capture = axis.capture()
        out.append({"stop": stop, "capture": capture, "time_s": axis.machine_time_s,
                    "environment": axis.environment_now()})
        axis.acknowledge(axis.count)
    return out


def world_captures(world: World, clock: StepClock, steps: Sequence[tuple[int, int]], *, samples: int,
                   seconds_per_step: float, sensor: SensorEffects) -> list[dict[str, Any]]:
    """Place the block at every (pass, station) step, ``seconds_per_step`` apart, zero the
    interferometer at the first; one record per step: the capture, the averaged sensor value
    (mm, height sense, the sensor's effects applied), the time (s) and the environment."""
    out = []
    block = world.block
    for i, (pass_, station) in enumerate(steps):
        clock.t = i * seconds_per_step  # the world was built at clock time 0
        world.place_block(station)
        if i == 0:
            world.set_datum()
        capture = world.capture()
        minutes = i * seconds_per_step / 60.0
        values = []
        for _ in range(samples):
            d = world.sensor_distance_mm()
            assert d is not None
            values.append(sensor.reading_mm(block.standoff_mm - d, minutes))
        del world.sample_log[:]
        out.append({"pass": pass_, "station": station, "capture": capture, "sensor_mm": sum(values) / len(values),
                    "time_s": i * seconds_per_step, "environment": world.environment_now()})
    return out

