"""``guideway simulate``: a synthetic run of a scenario (:mod:`.scenario`), written with the run
store in exactly the run-directory format of a measured run, so that ``process``, ``report``,
``export`` and ``diagnose`` treat it as real data.

The simulated devices are driven without transports (mocks/offline.py): a positioning run takes
the machine time of its cycle (moves at the feed plus the dwell), a straightness run
``[timing] seconds_per_station`` per step; ``time_s`` records that simulated time.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mocks.machine_axis import MachineAxis, MachineStop
from mocks.offline import StepClock, axis_captures, world_captures
from saved_runs.errors import SetupError
from saved_runs.store.whole import write_whole_run

from .effects import scenario_axis, scenario_world
from .machine import optics_of
from .scenario import Scenario, load_scenario
from .sensors import block_for

SIMULATED_INSTRUMENTS = {"simulation": {"protocol": "guideway simulate (no transport)", "endpoint": "-"}}


def simulate_run(scenario: Scenario | Path | str, out: Path | str, *, seed: int | None = None,
                 noise: bool = True) -> tuple[Path, int]:
    """Write the run of ``scenario`` (a file or a loaded scenario) to ``out``; return (out, points).

    ``seed`` defaults to the scenario's own ``seed``."""
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    seed = scenario.seed if seed is None else seed
    simulation = {"seed": seed, "noise": noise, "scenario": scenario.source, "transport": "none (guideway simulate)"}
    header: dict[str, Any]
    if scenario.positioning is None and scenario.straightness is None:
        table = "[axis]" if scenario.kind == "positioning" else "[block]"
        raise SetupError(f"{scenario.source}: no {table} table: simulating a run needs its test cycle "
                         f"(see docs/diagnosis.md)")
    if scenario.kind == "positioning":
        assert scenario.positioning is not None
        rows = simulate_positioning_points(scenario, seed, noise)
        # the simulated axis has no controller compensation (run.json compensation: none, not "not recorded")
        header = {**scenario.positioning.header(), "setup_source": scenario.setup_source,
                  "compensation": {"active": False}}
    else:
        assert scenario.straightness is not None
        rows = simulate_straightness_points(scenario, seed, noise)
        header = scenario.straightness.header()
    header.update(instruments=SIMULATED_INSTRUMENTS, simulation=simulation)
    header["notes"] = "; ".join(filter(None, [header.get("notes", ""), f"simulated from {scenario.source}"]))
    # plain numbers (numpy scalars would not be written in round-trip form); complete or not at all
    return write_whole_run(out, header, scenario.kind,
                           [{k: v if isinstance(v, int) else float(v) for k, v in row.items()} for row in rows],
                           f"simulated ({len(rows)} points, seed {seed})")


def simulate_positioning_points(scenario: Scenario, seed: int, noise: bool = True) -> list[dict[str, Any]]:
    """points.csv records of a positioning run of ``scenario`` (docs/run-format.md), the machine axis
    driven through the scenario's cycle without transports; ``time_s`` is machine time."""
    setup = scenario.positioning
    assert setup is not None
    stops = [MachineStop(s.position, s.target_index, s.run, s.direction) for s in setup.stops()]
    axis = MachineAxis(stops, feed_per_min=setup.feed_per_min, dwell_s=setup.trigger.dwell_s, handshake="ack",
                       datum=setup.datum, seed=seed, optics=optics_of(setup), **scenario_axis(scenario, noise))
    rows = []
    for rec in axis_captures(axis):
        stop, c, env = rec["stop"], rec["capture"], rec["environment"]
        rows.append({"run": stop.run, "direction": stop.direction, "target_index": stop.target_index,
                     "target_mm": stop.position, "reading_mm": setup.datum + c.position_mm, "time_s": rec["time_s"],
                     "stry_um": c.stry_um, "strz_um": c.strz_um, "pitch_urad": c.pitch_urad,
                     "yaw_urad": c.yaw_urad, "roll_urad": c.roll_urad, "air_temp_c": env[0],
                     "air_pressure_hpa": env[1], "humidity_pct": env[2], "material_temp_c": env[3]})
    return rows


def simulate_straightness_points(scenario: Scenario, seed: int, noise: bool = True) -> list[dict[str, Any]]:
    """points.csv records of a straightness run of ``scenario`` (the gauge block placed by the simulated
    technician, ``seconds_per_station`` apart, the sensor read with the set-up's sign)."""
    setup = scenario.straightness
    assert setup is not None
    clock = StepClock()
    world, sensor = scenario_world(scenario, block_for(setup.block_length_mm, setup.geometry), seed, noise,
                                    clock)
    sign = 1.0 if setup.geometry.sensor_sign == "height" else -1.0
    rows = []
    for rec in world_captures(world, clock, setup.steps(), samples=setup.samples_per_reading,
                              seconds_per_step=scenario.timing["seconds_per_station"], sensor=sensor):
        c, env, k = rec["capture"], rec["environment"], rec["station"]
        x = setup.station_x_mm(k)
        rows.append({"station": k, "x_mm": x, "time_s": rec["time_s"], "lin_um": (c.position_mm - x) * 1000.0,
                     "stry_um": c.stry_um, "strz_um": c.strz_um, "pitch_urad": c.pitch_urad, "yaw_urad": c.yaw_urad,
                     "roll_urad": c.roll_urad, "sensor_mm": sign * rec["sensor_mm"], "air_temp_c": env[0],
                     "air_pressure_hpa": env[1], "humidity_pct": env[2], "material_temp_c": env[3],
                     "pass": rec["pass"]})
    return rows
