"""Time to evaluate a 5-axis volumetric model (seed 004's machine, 45 elements: docs/machines/
seed004-5axis.toml) on a 50×50×50 grid of X, Y, Z (125,000 poses), the rotary axes held.

Prints, per evaluation, the median wall-clock and CPU time over several runs and the ratio of the
wall-clock median to the 1 s target:

* first-order total, exact total (processing.volumetric, vectorised over the poses);
* the grid service of ``guideway volumetric --out`` before writing files (totals plus every element's
  and every axis's first-order contribution), first order and ``--exact``.

    python benchmarks/bench_volumetric.py [--runs 5] [--grid 50]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from processing.volumetric.evaluate import exact, first_order  # noqa: E402
from saved_runs.volumetric.field import evaluate_field, grid_positions  # noqa: E402
from saved_runs.volumetric.machine_file import load_machine  # noqa: E402

TARGET_S = 1.0
MACHINE = ROOT / "docs" / "machines" / "seed004-5axis.toml"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--grid", type=int, default=50)
    args = ap.parse_args()
    machine = load_machine(MACHINE)
    gridded, positions = grid_positions(machine.model, args.grid, {"A": 30.0, "C": 120.0})
    n = len(positions[gridded[0]])
    print(f"{MACHINE.name}: {machine.model.counts()['total']} elements, {len(machine.model.axes)} axes; "
          f"grid {args.grid}^{len(gridded)} = {n} poses over {', '.join(gridded)} (A = 30 deg, C = 120 deg)")
    cases = {
        "first-order total": lambda: first_order(machine.model, positions, machine.conditions),
        "exact total": lambda: exact(machine.model, positions, machine.conditions),
        "grid service, first order + contributions": lambda: evaluate_field(machine, positions),
        "grid service, exact + contributions": lambda: evaluate_field(machine, positions, method="exact"),
    }
    for name, run in cases.items():
        run()  # warm-up (first-touch allocations)
        wall, cpu = [], []
        for _ in range(args.runs):
            w0, c0 = time.perf_counter(), time.process_time()
            run()
            wall.append(time.perf_counter() - w0)
            cpu.append(time.process_time() - c0)
        med = statistics.median(wall)
        print(f"{name:<44} median {med * 1000:7.1f} ms wall, {statistics.median(cpu) * 1000:7.1f} ms CPU over "
              f"{args.runs} runs (min {min(wall) * 1000:.1f}, max {max(wall) * 1000:.1f}); target {TARGET_S:.0f} s, "
              f"ratio {med / TARGET_S:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
