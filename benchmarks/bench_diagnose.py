"""Time of ``guideway diagnose`` on a 10,000-point positioning run against the full effect library.

The run is simulated once (``guideway simulate``: 100 targets over 1000 mm, 50 runs in each
direction, a linear scale, backlash, a periodic error and a thermal drift hidden, the air
conditioning cycling and the pitch and yaw recorded, so every candidate of the library is
tested).  Each timed repetition is the whole service: read the run, environmental compensation,
the observations, the selection loop with its backward pass and ambiguity checks.  Prints the
median of several repetitions and the ratio to the 5 s target, with one BLAS thread (what
``guideway diagnose`` sets: the matrices are small, at most 10,000 × ~110, and on a busy machine
BLAS threads only contend) and, for comparison, with the default BLAS threads, each in a fresh
process.

    python benchmarks/bench_diagnose.py [--runs 5] [--targets 100] [--approaches 50]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_S = 5.0


def make_run(out: Path, targets: int, approaches: int) -> dict:
    """Simulate the benchmark run into ``out``; return the scenario's hidden effects."""
    import numpy as np

    from acquisition.simulated.scenario import scenario_from_dict
    from acquisition.simulated.synthetic import simulate_run

    rng = np.random.default_rng(0)
    inner = np.sort(rng.uniform(5.0, 995.0, targets - 2))
    positions = [0.0, *np.round(inner, 3).tolist(), 1000.0]
    effects = [{"type": "linear_scale", "ppm": 4.0}, {"type": "backlash", "reversal_um": -1.5},
               {"type": "periodic", "amplitude_um": 0.8, "wavelength_mm": 130.0, "phase_rad": 0.3},
               {"type": "thermal_drift", "um_per_min": 0.002}]
    scenario = scenario_from_dict({
        "kind": "positioning", "axis": {"targets_mm": positions, "runs": approaches, "feed_mm_min": 10000.0},
        "trigger": {"dwell_s": 1.0}, "conditions": {"air_cycle_c": 0.3, "cycle_period_min": 25.0},
        "motion": {"pitch_amplitude_urad": 4.0, "pitch_wavelength_mm": 600.0, "yaw_amplitude_urad": 3.0,
                   "yaw_wavelength_mm": 450.0},
        "effect": effects}, "benchmark scenario")
    simulate_run(scenario, out, seed=1)
    return {"effects": [e["type"] for e in effects]}


def time_diagnose(run_dir: str, repetitions: int) -> dict:
    from saved_runs.diagnosis.diagnose import diagnose_run

    d = diagnose_run(run_dir)  # warm-up: imports, caches
    times = []
    for _ in range(repetitions):
        t0 = time.perf_counter()
        d = diagnose_run(run_dir)
        times.append(time.perf_counter() - t0)
    return {"times": times, "named": d.named, "ambiguous": d.ambiguous, "points": d.primary.obs.n,
            "final_rms_um": d.primary.final.rms_um, "noise_um": d.primary.noise.sigma_um}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="timed repetitions (median reported)")
    ap.add_argument("--targets", type=int, default=100)
    ap.add_argument("--approaches", type=int, default=50, help="runs in each direction")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:  # a fresh process with the BLAS threads its parent set in the environment
        print(json.dumps(time_diagnose(args.child, args.runs)))
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run"
        t0 = time.perf_counter()
        hidden = make_run(run, args.targets, args.approaches)
        print(f"simulated {args.targets} targets x {args.approaches} runs x 2 directions in "
              f"{time.perf_counter() - t0:.1f} s; hidden: {', '.join(hidden['effects'])}")
        one = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        for label, env in (("guideway diagnose (one BLAS thread, as the command sets it)", one),
                           ("library call with the default BLAS threads", {})):
            res = subprocess.run([sys.executable, __file__, "--child", str(run), "--runs", str(args.runs)],
                                 env={**os.environ, **env}, capture_output=True, text=True, check=True)
            r = json.loads(res.stdout)
            med = statistics.median(r["times"])
            print(f"{label}: {r['points']} points, median {med:.2f} s over {args.runs} runs "
                  f"(min {min(r['times']):.2f}, max {max(r['times']):.2f}); target {TARGET_S:.0f} s, "
                  f"ratio {med / TARGET_S:.2f}; named {', '.join(r['named'])}; ambiguous {r['ambiguous'] or 'none'}; "
                  f"final RMS {r['final_rms_um']:.3f} um, noise {r['noise_um']:.3f} um")
    return 0


if __name__ == "__main__":
    sys.exit(main())
