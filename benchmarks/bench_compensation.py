"""Time to fit all four compensation models and compute the residual comparison
(what every `guideway export` does) for axes with N targets per direction.

Prints the median over several runs per size and the ratio to the 1 s target (interactive
export of a dense 1000-point map).

    python benchmarks/bench_compensation.py [--runs 5] [--sizes 41 256 1000]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from processing.compensation.residuals import compare_models  # noqa: E402

TARGET_S = 1.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sizes", type=int, nargs="+", default=[41, 256, 1000])
    args = ap.parse_args()
    for n in args.sizes:
        rng = np.random.default_rng(n)
        x = np.sort(rng.uniform(0, 1000, n))
        up = 5 * np.sin(x / 90) + 0.004 * x + rng.normal(0, 0.2, n)
        dn = up - 2 + rng.normal(0, 0.2, n)
        times = []
        for _ in range(args.runs):
            t0 = time.perf_counter()
            compare_models(x, up, dn)
            times.append(time.perf_counter() - t0)
        med = statistics.median(times)
        print(f"{n:5d} targets: median {med * 1000:8.1f} ms over {args.runs} runs "
              f"(min {min(times) * 1000:.1f}, max {max(times) * 1000:.1f}); target {TARGET_S:.0f} s, "
              f"ratio {med / TARGET_S:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
