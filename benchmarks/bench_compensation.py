"""Time of the residual figures every `guideway export` computes, for axes with N targets per
direction and 5 runs per direction (every measured point scored):

* ``comparison``: all four models fitted to the per-target means and scored at every point
  (processing.compensation.residuals.compare_models);
* ``cross-validation``: every model refitted without each run and without each target (at most
  100 targets held out) and scored on the held-out points (processing.compensation.crossval);
* ``total``: both, what export adds to writing the table.

Prints the median over several runs per size and the ratio to the 1 s target (interactive
export of a dense 1000-point map), and the median CPU time of this process (close to the wall
time on an idle machine; on a loaded one the wall time grows, the CPU time much less).  Run
against a tree without crossval.py, the cross-validation is reported as not available (to
measure "before").

    python benchmarks/bench_compensation.py [--runs 5] [--sizes 41 256 1000]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from processing.compensation.residuals import MeasuredPoints, compare_models  # noqa: E402

try:
    from processing.compensation.crossval import cross_validate  # noqa: E402
except ImportError:  # a tree before the cross-validation
    cross_validate = None  # type: ignore[assignment]

TARGET_S = 1.0
RUNS_PER_DIRECTION = 5


def axis(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, pd.DataFrame]:
    rng = np.random.default_rng(n)
    x = np.sort(rng.uniform(0, 1000, n))
    up = 5 * np.sin(x / 90) + 0.004 * x + rng.normal(0, 0.2, n)
    dn = up - 2 + rng.normal(0, 0.2, n)
    frames = [pd.DataFrame({"target": x, "direction": d, "run": j, "deviation": m + rng.normal(0, 0.3, n)})
              for j in range(1, RUNS_PER_DIRECTION + 1) for d, m in ((1, up), (-1, dn))]
    dev = pd.concat(frames, ignore_index=True)
    means = dev.groupby(["target", "direction"])["deviation"].mean().unstack("direction")
    return means.index.to_numpy(), means[1].to_numpy(), means[-1].to_numpy(), dev


def median_s(fn: Callable[[], object], runs: int) -> tuple[float, float, float, float]:
    """(median, min, max) wall time and the median CPU time, in s."""
    times, cpu = [], []
    for _ in range(runs):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return statistics.median(times), min(times), max(times), statistics.median(cpu)


def parts(n: int) -> dict[str, Callable[[], object]]:
    x, up, dn, dev = axis(n)
    points = MeasuredPoints.from_deviations(dev)
    out: dict[str, Callable[[], object]] = {"comparison": lambda: compare_models(x, up, dn, deviations=dev)}
    if cross_validate is not None:
        out["cross-validation"] = lambda: cross_validate(points)
        out["total"] = lambda: (compare_models(x, up, dn, deviations=dev), cross_validate(points))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sizes", type=int, nargs="+", default=[41, 256, 1000])
    args = ap.parse_args()
    for n in args.sizes:
        for name, fn in parts(n).items():
            med, lo, hi, cpu = median_s(fn, args.runs)
            print(f"{n:5d} targets, {name:<16}: median {med * 1000:8.1f} ms over {args.runs} runs "
                  f"(min {lo * 1000:.1f}, max {hi * 1000:.1f}; CPU {cpu * 1000:.1f}); target {TARGET_S:.0f} s, "
                  f"ratio {med / TARGET_S:.3f}")
        if cross_validate is None:
            print(f"{n:5d} targets, cross-validation: not available in this tree")
    return 0


if __name__ == "__main__":
    sys.exit(main())
