"""``guideway demo``: a complete simulated gauge-block straightness run.

A thin call into the same code path as ``guideway acquire straightness
--simulate --auto`` (simulated devices on real transports, the real drivers,
the straightness plan with the automatic operator), then processing and
results.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TextIO

from processing.straightness import StraightnessResult
from saved_runs.errors import UserError
from saved_runs.evaluation.evaluate import process_run_dir

from .acquire import SimOptions, run_straightness
from .engine import RunOutcome
from .setup.shared_tables import DeviceSetup
from .setup.straightness import StraightnessSetup
from .simulated.rig import SimulatedRig
from .simulated.sensors import default_block


@dataclass(frozen=True)
class DemoResult:
    run_dir: Path
    outcome: RunOutcome
    result: StraightnessResult | None
    sim: SimulatedRig  # stopped; its world stays readable (ground truth for tests)


def default_run_dir() -> Path:
    return Path("runs") / datetime.now(UTC).strftime("demo-%Y%m%dT%H%M%SZ")


def demo_setup(stations: int = 20, samples: int = 5, notes: str = "", sensor: str = "keyence-lkg"
               ) -> StraightnessSetup:
    """The set-up of the default simulated rig with a ``sensor`` head (protocol name; its own sign
    and line rate); no warm-up: the simulated rig does not drift."""
    if stations < 2:
        raise UserError(f"--stations must be at least 2, got {stations}")
    length_mm, geometry = default_block(sensor)
    return StraightnessSetup(block_length_mm=length_mm, stations=stations, geometry=geometry,
                             samples_per_reading=samples, machine="simulated machine", axis="X",
                             operator="simulated technician", notes=notes,
                             devices=DeviceSetup(sensor_protocol=sensor))


def run_demo(
    out: Path | None = None,
    *,
    stations: int = 20,
    seed: int = 0,
    noise: bool = True,
    samples: int = 5,
    faults: str | None = None,
    sensor: str = "keyence-lkg",
    stream: TextIO = sys.stdout,
) -> DemoResult:
    """Run the whole demo with a simulated ``sensor`` (protocol name); print progress to ``stream``."""
    run_dir = Path(out) if out is not None else default_run_dir()
    setup = demo_setup(stations, samples, f"guideway demo, seed {seed}, noise {'on' if noise else 'off'}", sensor)
    res = run_straightness(setup, run_dir, simulate=SimOptions(seed, noise, faults), auto=True, stream=stream)
    outcome = res.outcome
    if outcome.exit_status != "success":
        raise UserError(f"demo run ended early ({outcome.reason}); the points captured are in {run_dir}")
    _, evaluation = process_run_dir(run_dir)
    results_dir = evaluation.write(run_dir / "results")
    evaluation.print_summary(stream)
    print(f"results: {results_dir / 'profile.csv'}, {results_dir / 'profile.png'}", file=stream)
    assert res.sim is not None
    return DemoResult(run_dir, outcome, evaluation.result, res.sim)  # type: ignore[attr-defined]
