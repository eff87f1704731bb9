"""Seed 003's experiment in simulation (docs/compensation.md, "Seed 003's experiment"): a rotary axis
whose ↑ and ↓ error curves cross (tests/data/seed003/), measured as found, then as left with live
compensation by each of the four models, on targets midway between the as-found ones (a model is
judged between its points, as a re-measurement on the machine would); the table of errors before and
after per model (the analogue of seed 003's comparison, where the spline cut the error by 94 %).

    python benchmarks/seed003_experiment.py [--out DIR] [--seed 1]

Figures (arcsec), every one from the runs' points.csv: E = max − min of the per-target, per-direction
mean errors (ISO 230-2 E of the means); max|e| over every point; reduction = 1 − E_after / E_before,
"before" = the axis uncompensated on the as-left targets.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "seed003"
MODELS = ("polynomial", "linear", "spline", "bidirectional-table")


def guideway(*args: object) -> None:
    res = subprocess.run([sys.executable, "-m", "tui.cli", *map(str, args)], cwd=ROOT, capture_output=True,
                         text=True)
    if res.returncode != 0:
        raise SystemExit(f"guideway {' '.join(map(str, args))} failed: {res.stderr.strip()}")


def figures(run: Path) -> tuple[float, float, float]:
    """E of the means, max|e| over all points, and the largest |x̄↑ − x̄↓| (arcsec)."""
    p = pd.read_csv(run / "points.csv")
    e = (p["reading_deg"] - p["target_deg"]) * 3600.0
    means = e.groupby([p["target_deg"], p["direction"]]).mean()
    split = means.unstack("direction")
    return float(means.max() - means.min()), float(e.abs().max()), float((split[1] - split[-1]).abs().max())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None, help="keep the runs here (default: a temporary folder)")
    ap.add_argument("--seed", type=int, default=1, help="noise seed of the as-left runs (as-found: 0)")
    a = ap.parse_args()
    out = a.out or Path(tempfile.mkdtemp(prefix="seed003-"))
    found, before = out / "as-found", out / "uncompensated"
    common = ("--simulate", "--auto")
    guideway("acquire", "positioning", "--setup", DATA / "rotary-found.toml", "--out", found, *common)
    guideway("acquire", "positioning", "--setup", DATA / "rotary-left.toml", "--out", before, *common,
             "--seed", a.seed)
    e0, max0, split0 = figures(before)
    ef, maxf, splitf = figures(found)
    print(f"# seed 003 in simulation: rotary axis C, {out}")
    print(f"# as found on its own targets: E {ef:.3f} arcsec, max|e| {maxf:.3f}, largest up/down split {splitf:.3f}")
    print(f"{'model':<22}{'E before':>10}{'E after':>10}{'max|e| before':>15}{'max|e| after':>14}{'reduction':>11}"
          f"{'run s':>7}")
    for model in MODELS:
        left = out / f"as-left-{model}"
        t0 = time.perf_counter()
        guideway("acquire", "positioning", "--setup", DATA / "rotary-left.toml", "--out", left, *common,
                 "--seed", a.seed, "--live-compensation", found, "--live-model", model)
        took = time.perf_counter() - t0
        e1, max1, _ = figures(left)
        print(f"{model:<22}{e0:>10.3f}{e1:>10.3f}{max0:>15.3f}{max1:>14.3f}{100 * (1 - e1 / e0):>10.1f}%{took:>7.1f}")
    print("# E = max - min of the per-target, per-direction means (arcsec); before = uncompensated, same targets")
    return 0


if __name__ == "__main__":
    sys.exit(main())
