"""A scenario's effects put behind the simulated devices: the machine axis of a positioning scenario
and the world (surface, block, sensor) of a straightness scenario."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from mocks.effects import AngularMotion, AxisEffects, Conditions, SensorEffects, straightness_parts
from mocks.machine_axis import AxisErrors
from mocks.world import BlockSetup, Guideway, Noise, Wave, World

if TYPE_CHECKING:
    from .scenario import Scenario


def scenario_axis(scenario: Scenario, noise: bool) -> dict[str, Any]:
    """MachineAxis arguments of a positioning scenario: no built-in errors, its effects and conditions."""
    n = scenario.noise
    c = scenario.conditions
    return {
        "errors": AxisErrors(pitch=(), slope_per_m=0.0, backlash=0.0, periodic=0.0, thermal_per_m_per_h=0.0,
                             noise=n["reading_um"] if noise else 0.0),
        "environment": Conditions(**c),
        "effects": AxisEffects(scenario.effect_specs(), AngularMotion(**scenario.motion),
                               n["angle_urad"] if noise else 0.0),
    }


def scenario_world(scenario: Scenario, recorded: BlockSetup, seed: int, noise: bool,
                    clock: Callable[[], float] = time.monotonic) -> tuple[World, SensorEffects]:
    """The simulated world of a straightness scenario built around the ``recorded`` block, and the sensor's
    own effects."""
    base = Guideway.from_seed(seed)
    if scenario.surface is not None:
        base = Guideway(waves=tuple(Wave(*w) for w in scenario.surface["waves"]),
                        slope_urad=scenario.surface["slope_urad"])
    block, surface, sensor = straightness_parts(scenario.effect_specs(), recorded, base)
    world = World(guideway=surface, block=block, noise=Noise(**scenario.noise) if noise else Noise.off(),
                  seed=seed, clock=clock)
    return world, sensor
