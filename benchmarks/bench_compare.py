"""Time of a comparison: ``compare_runs`` (both runs loaded and evaluated as ``process`` does, matched,
the change computed) and the HTML report, in this process, on runs made by ``guideway simulate`` from the
commented scenarios (docs/scenario-*.toml): a positioning run of 21 targets x 4 runs x 2 directions and a
16-station straightness run with its return pass (straightness with the default 10 000 Monte Carlo
trials per run, and with them off).  Prints every time and the median of N repetitions.

    python benchmarks/bench_compare.py [--runs 5]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from acquisition.simulated.synthetic import simulate_run  # noqa: E402
from fleet.compare.compare import compare_runs  # noqa: E402
from fleet.compare.report import write_comparison_report  # noqa: E402


def median_time(label: str, fn: Callable[[], object], runs: int) -> float:
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    print(f"{label}: median {med * 1000:.0f} ms over {runs} runs ({', '.join(f'{t * 1000:.0f}' for t in times)})")
    return med


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        for kind in ("positioning", "straightness"):
            for seed in (1, 2):
                simulate_run(ROOT / "docs" / f"scenario-{kind}.toml", t / f"{kind}-{seed}", seed=seed)
        pa, pb = t / "positioning-1", t / "positioning-2"
        sa, sb = t / "straightness-1", t / "straightness-2"
        compare_runs(pa, pb)  # warm the imports
        median_time("compare positioning (21 targets x 4 runs)", lambda: compare_runs(pa, pb), args.runs)
        median_time("compare straightness (16 stations, return pass), Monte Carlo 10 000 trials",
                    lambda: compare_runs(sa, sb), args.runs)
        median_time("compare straightness, Monte Carlo off", lambda: compare_runs(sa, sb, mc_trials=0), args.runs)
        c = compare_runs(pa, pb)
        median_time("HTML report of the positioning comparison (overlay plot included)",
                    lambda: write_comparison_report(c, t / "report.html"), args.runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
