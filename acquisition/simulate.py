"""``guideway simulate``: a synthetic run of a scenario (acquisition/scenario.py), written with
the run store in exactly the run-directory format of a measured run, so that ``process``,
``report``, ``export`` and ``diagnose`` treat it as real data.

The simulated devices are driven without transports (mocks/offline.py): a positioning run takes
the machine time of its cycle (moves at the feed plus the dwell), a straightness run
``[timing] seconds_per_station`` per step; ``time_s`` records that simulated time.
"""

from __future__ import annotations

import uuid
from pathlib import Path
from typing import Any

from .errors import SetupError
from .runstore import RunStore
from .scenario import Scenario, load_scenario
from .simulation import simulate_positioning_points, simulate_straightness_points

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
        header = {**scenario.positioning.header(), "setup_source": scenario.setup_source}
    else:
        assert scenario.straightness is not None
        rows = simulate_straightness_points(scenario, seed, noise)
        header = scenario.straightness.header()
    header.update(instruments=SIMULATED_INSTRUMENTS, simulation=simulation)
    header["notes"] = "; ".join(filter(None, [header.get("notes", ""), f"simulated from {scenario.source}"]))
    store = RunStore(out, header)
    store("start", {"kind": scenario.kind, "uid": uuid.uuid4().hex})
    # plain numbers (numpy scalars would not be written in round-trip form)
    store.record_many([{k: v if isinstance(v, int) else float(v) for k, v in row.items()} for row in rows])
    store("stop", {"exit_status": "success", "reason": f"simulated ({len(rows)} points, seed {seed})"})
    return store.run_dir, store.points_written
