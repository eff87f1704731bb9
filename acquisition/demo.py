"""``guideway demo``: a complete simulated gauge-block straightness run.

Simulated devices on real transports (pty + Modbus TCP), the real drivers,
the straightness plan with an automatic operator, then processing and
results.  The same code paths a real rig uses; only the endpoints differ.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TextIO

from processing.straightness import StraightnessResult

from .engine import RunEngine, RunOutcome
from .errors import UserError
from .evaluate import process_run_dir
from .operators import AutoOperator
from .plans import straightness_plan
from .rig import open_rig
from .runstore import RunStore
from .setup import DeviceSetup, StraightnessSetup
from .simulation import SimulatedRig, start_simulated_rig


@dataclass(frozen=True)
class DemoResult:
    run_dir: Path
    outcome: RunOutcome
    result: StraightnessResult | None
    sim: SimulatedRig  # stopped; its world stays readable (ground truth for tests)


def default_run_dir() -> Path:
    return Path("runs") / datetime.now(UTC).strftime("demo-%Y%m%dT%H%M%SZ")


def run_demo(
    out: Path | None = None,
    *,
    stations: int = 20,
    seed: int = 0,
    noise: bool = True,
    samples: int = 5,
    faults: str | None = None,
    stream: TextIO = sys.stdout,
) -> DemoResult:
    """Run the whole demo; print progress to ``stream``."""
    run_dir = Path(out) if out is not None else default_run_dir()
    if stations < 2:
        raise UserError(f"--stations must be at least 2, got {stations}")
    sim = start_simulated_rig(seed=seed, noise=noise, faults=faults)
    try:
        print(f"simulated sensor     : {sim.sensor_protocol} on {sim.sensor_url}", file=stream)
        print(f"simulated controller : {sim.controller_url}", file=stream)
        rig = open_rig(sim.sensor_protocol, sim.sensor_url, sim.controller_url)
        try:
            setup = StraightnessSetup(
                block_length_mm=sim.world.block.length_mm,
                stations=stations,
                geometry=sim.geometry(),
                devices=DeviceSetup(sim.sensor_protocol, sim.sensor_url, 115200, sim.controller_url),
                samples_per_reading=samples,
                machine="simulated machine",
                axis="X",
                operator="simulated technician",
                notes=f"guideway demo, seed {seed}, noise {'on' if noise else 'off'}",
            )
            header = {
                "machine": setup.machine, "axis": setup.axis, "operator": setup.operator,
                "notes": setup.notes, "setup": setup.to_run_setup(), "instruments": rig.instruments(),
            }
            store = RunStore(run_dir, header)
            store.prepare()
            operator = AutoOperator({"place_block": sim.place_block}, log_to=stream)
            engine = RunEngine(rig, operator, (store,))
            outcome = engine.run(straightness_plan(setup, {}))
        finally:
            rig.close()
    finally:
        sim.close()
    print(f"run {outcome.exit_status}: {outcome.num_events} stations written to {run_dir}", file=stream)
    if outcome.exit_status != "success":
        raise UserError(f"demo run ended early ({outcome.reason}); the points captured are in {run_dir}")
    _, evaluation = process_run_dir(run_dir)
    results_dir = evaluation.write(run_dir / "results")
    evaluation.print_summary(stream)
    print(f"results: {results_dir / 'profile.csv'}, {results_dir / 'profile.png'}", file=stream)
    return DemoResult(run_dir, outcome, evaluation.result, sim)  # type: ignore[attr-defined]
