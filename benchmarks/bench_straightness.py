"""Processing time and peak memory of a straightness evaluation for N samples.

For N = 1e3, 1e4, 1e5, 1e6 stations of a synthetic capture (a wavy surface
with noise on every channel) it times ``evaluate_straightness`` with the
default exact decoupling: decoupling, station averaging, the three reference
lines (minimum zone by exact hull), the dominant wavelengths and the GUM
per-station uncertainty.  The Monte Carlo uncertainty is NOT included
(``mc_trials=0``): it costs trials x N and is run separately on real runs.

Each size runs in a fresh subprocess (``--runs`` times, median reported) so
its peak memory is that process's own: peak RSS from
``resource.getrusage(RUSAGE_SELF).ru_maxrss`` after the evaluation (it
includes the interpreter, numpy/scipy/pandas and the input DataFrame).

    python benchmarks/bench_straightness.py [--runs 5] [--sizes 1000,10000,100000,1000000]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

TARGET_S = 1.0
TARGET_MB = 500.0
ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, time
import numpy as np, pandas as pd
sys.path.insert(0, sys.argv[3])
from processing.geometry import BlockGeometry
from processing.straightness import evaluate_straightness
from processing.uncertainty import UncertaintyInputs

n, seed = int(sys.argv[1]), int(sys.argv[2])
rng = np.random.default_rng(seed)
step = 2000.0 / n * 1000  # 2 m of guideway per 1000 stations, scaled
x = np.arange(n) * step
surface = 3.0 * np.sin(2 * np.pi * x / (200 * step)) + 0.8 * np.sin(2 * np.pi * x / (71 * step))
pitch = rng.normal(0, 20, n)
points = pd.DataFrame({
    "station": np.arange(n), "x_mm": x, "time_s": np.arange(n) * 5.0, "lin_um": rng.normal(0, 20, n),
    "stry_um": surface + rng.normal(0, 0.1, n), "strz_um": rng.normal(0, 1, n), "pitch_urad": pitch,
    "yaw_urad": rng.normal(0, 20, n), "roll_urad": rng.normal(0, 20, n),
    "sensor_mm": 0.2 + rng.normal(0, 5e-5, n), "pass": np.zeros(n, dtype=int)})
geom = BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0))
t0 = time.perf_counter()
res = evaluate_straightness(points, geom, method="exact", uncertainty=UncertaintyInputs(), mc_trials=0)
dt = time.perf_counter() - t0
peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB
print(json.dumps({"seconds": dt, "peak_mb": peak_mb, "mz": res.straightness_um()["minimum_zone"]}))
"""


def one(n: int, seed: int) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, str(n), str(seed), str(ROOT)], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sizes", default="1000,10000,100000,1000000")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    print(f"{'N':>9} {'median s':>9} {'min s':>7} {'max s':>7} {'us per sample':>14} {'peak RSS MB':>12}")
    last = None
    for n in sizes:
        rs = [one(n, seed) for seed in range(args.runs)]
        ts = [r["seconds"] for r in rs]
        med = statistics.median(ts)
        mem = max(r["peak_mb"] for r in rs)
        print(f"{n:>9} {med:>9.4f} {min(ts):>7.4f} {max(ts):>7.4f} {med / n * 1e6:>14.3f} {mem:>12.1f}")
        last = (n, med, mem)
    if last:
        n, med, mem = last
        print(f"N = {n}: median {med:.3f} s (target {TARGET_S:.0f} s, ratio {med / TARGET_S:.2f}); "
              f"peak RSS {mem:.0f} MB (target {TARGET_MB:.0f} MB, ratio {mem / TARGET_MB:.2f}); "
              f"Monte Carlo not included")
    return 0


if __name__ == "__main__":
    sys.exit(main())
