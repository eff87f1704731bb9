"""Wall time of `guideway demo` with 20 stations, including device start-up.

Runs the installed command (or `python -m tui.cli` if it is not on PATH) N
times in fresh processes and prints every time, the median and the ratio to
the 15 s target.

    python benchmarks/bench_demo.py [--runs 5] [--stations 20]
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_S = 15.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--stations", type=int, default=20)
    args = ap.parse_args()
    exe = shutil.which("guideway", path=str(Path(sys.executable).parent))
    cmd = [exe] if exe else [sys.executable, "-m", "tui.cli"]
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.runs):
            out = Path(tmp) / f"run{i}"
            t0 = time.perf_counter()
            subprocess.run([*cmd, "demo", "--out", str(out), "--stations", str(args.stations), "--seed", str(i)],
                           check=True, stdout=subprocess.DEVNULL, cwd=Path(__file__).resolve().parents[1])
            times.append(time.perf_counter() - t0)
            print(f"run {i + 1}: {times[-1]:.2f} s")
    med = statistics.median(times)
    print(f"guideway demo, {args.stations} stations: median {med:.2f} s over {args.runs} runs "
          f"(min {min(times):.2f}, max {max(times):.2f}); target {TARGET_S:.0f} s, ratio {med / TARGET_S:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
