"""Wall-clock time of the whole ``guideway volumetric MACHINE --out DIR --grid N`` command (a fresh
process: start-up, evaluation, the two CSV files, summary.json and the HTML report) for a small and a
large grid of seed 004's five-axis machine (docs/machines/seed004-5axis.toml), and the ratio of the
two.  Target (issue #19): ``--grid 50`` (125,000 poses, 4.4 million CSV values) within 1.5 times the
time of ``--grid 5`` (125 poses).

Also times, in this process, the parts of the large grid: evaluation, formatting the two CSV files,
and (for comparison) what pandas' ``to_csv(float_format="%.6f")`` takes for the same tables.

    python benchmarks/bench_volumetric_command.py [--runs 5] [--small 5] [--large 50]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from saved_runs.store.fixed_csv import fixed_csv  # noqa: E402
from saved_runs.volumetric.field import evaluate_field, grid_positions  # noqa: E402
from saved_runs.volumetric.machine_file import load_machine  # noqa: E402

MACHINE = ROOT / "docs" / "machines" / "seed004-5axis.toml"
GUIDEWAY = [sys.executable, "-m", "tui.cli"]


def command_s(grid: int, runs: int) -> tuple[list[float], list[float]]:
    """Wall-clock and CPU (user + system of the child) seconds of each run of the command."""
    wall, cpu = [], []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as tmp:
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            subprocess.run([*GUIDEWAY, "volumetric", str(MACHINE), "--out", tmp, "--grid", str(grid)],
                           cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
            wall.append(time.perf_counter() - t0)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return wall, cpu


def median_s(fn, runs: int) -> float:  # noqa: ANN001
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--small", type=int, default=5)
    ap.add_argument("--large", type=int, default=50)
    args = ap.parse_args()
    small_wall, small_cpu = command_s(args.small, args.runs)
    large_wall, large_cpu = command_s(args.large, args.runs)
    small, large = statistics.median(small_wall), statistics.median(large_wall)
    small_c, large_c = statistics.median(small_cpu), statistics.median(large_cpu)
    print(f"guideway volumetric --grid {args.small}: wall {small:.2f} s, CPU {small_c:.2f} s (medians of {args.runs})")
    print(f"guideway volumetric --grid {args.large}: wall {large:.2f} s, CPU {large_c:.2f} s (medians of {args.runs})")
    print(f"ratio large / small: wall {large / small:.2f}, CPU {large_c / small_c:.2f} (target <= 1.5)")

    machine = load_machine(MACHINE)
    gridded, positions = grid_positions(machine.model, args.large, {})
    result = evaluate_field(machine, positions, gridded=gridded, count=args.large)
    tables = [result.table(), result.contribution_table()]
    values = sum(t.size for t in tables)
    ev = median_s(lambda: evaluate_field(machine, positions, gridded=gridded, count=args.large), args.runs)
    fast = median_s(lambda: [fixed_csv(list(t.columns), t.to_numpy(dtype=float)) for t in tables], args.runs)
    slow = median_s(lambda: [t.to_csv(index=False, float_format="%.6f") for t in tables], max(1, args.runs // 2))
    print(f"--grid {args.large} parts: evaluation {ev:.2f} s; CSV text of {values:,} values {fast:.2f} s "
          f"(pandas to_csv: {slow:.2f} s, {slow / fast:.1f}x slower)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
