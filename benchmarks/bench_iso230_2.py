"""Time of the ISO 230-2 evaluation of 1000 targets x 5 runs x 2 directions.

Times :func:`processing.iso230_2.evaluate_iso230_2` on a long DataFrame (the
path `guideway process` takes, including the reshape into per-direction
arrays) and :func:`iso230_2_from_arrays` alone, and prints every median and the
ratio to the 50 ms target.

    python benchmarks/bench_iso230_2.py [--runs 15] [--targets 1000] [--approaches 5]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np
import pandas as pd

from processing.iso230_2 import deviation_arrays, evaluate_iso230_2, iso230_2_from_arrays

TARGET_MS = 50.0


def make_deviations(m: int, n: int, seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    targets = np.arange(m) * 2.0 + rng.uniform(-0.5, 0.5, m)
    ti, d, r = np.meshgrid(np.arange(1, m + 1), [1, -1], np.arange(1, n + 1), indexing="ij")
    dev = (np.sin(targets / 50.0)[:, None, None] * 5 + (d == -1) * 2.0 + rng.normal(0, 0.5, ti.shape))
    return pd.DataFrame({"target_index": ti.ravel(), "target": targets[ti.ravel() - 1], "direction": d.ravel(),
                         "run": r.ravel(), "deviation": dev.ravel()})


def median_ms(fn, runs: int) -> tuple[float, list[float]]:  # noqa: ANN001
    fn()  # warm-up (imports, caches)
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1000)
    return statistics.median(times), times


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("--targets", type=int, default=1000)
    ap.add_argument("--approaches", type=int, default=5)
    args = ap.parse_args()
    df = make_deviations(args.targets, args.approaches)
    _, targets, up, down = deviation_arrays(df)
    full, times = median_ms(lambda: evaluate_iso230_2(df), args.runs)
    arrays, _ = median_ms(lambda: iso230_2_from_arrays(targets, up, down), args.runs)
    print(f"points: {len(df)} ({args.targets} targets x {args.approaches} runs x 2 directions), {args.runs} runs each")
    print(f"evaluate_iso230_2 (DataFrame in): median {full:.2f} ms (min {min(times):.2f}, max {max(times):.2f}); "
          f"target {TARGET_MS:.0f} ms, ratio {full / TARGET_MS:.3f}")
    print(f"iso230_2_from_arrays (arrays in):  median {arrays:.2f} ms; ratio {arrays / TARGET_MS:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
