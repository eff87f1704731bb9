"""Start-up of the command line: wall time and peak memory of `guideway --help` (every sub-command
registered), and which heavy libraries it loads (none: NumPy, pandas, SciPy, Matplotlib and Textual
take most of a second to import; tests/test_architecture.py holds the list empty).

Runs the installed command (or `python -m tui.cli`) N times in fresh processes; prints every time,
the median and the ratio to the 0.3 s target.

    python benchmarks/bench_cli_help.py [--runs 7]
"""

from __future__ import annotations

import argparse
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

TARGET_S = 0.3
HEAVY = ("numpy", "pandas", "scipy", "matplotlib", "textual")
ROOT = Path(__file__).resolve().parents[1]


def loaded_heavy() -> list[str]:
    code = ("import contextlib, io, sys\nfrom tui.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
            "    main(['--help'])\n"
            f"print(' '.join(sorted({{m.split('.')[0] for m in sys.modules}} & {set(HEAVY)!r})))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    return out.stdout.split()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    args = ap.parse_args()
    exe = shutil.which("guideway", path=str(Path(sys.executable).parent))
    cmd = [exe] if exe else [sys.executable, "-m", "tui.cli"]
    times = []
    for i in range(args.runs):
        t0 = time.perf_counter()
        subprocess.run([*cmd, "--help"], check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
        times.append(time.perf_counter() - t0)
        print(f"run {i + 1}: {times[-1] * 1000:.0f} ms")
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # the largest child, kB on Linux
    med = statistics.median(times)
    heavy = loaded_heavy()
    print(f"guideway --help: median {med * 1000:.0f} ms over {args.runs} runs (min {min(times) * 1000:.0f}, "
          f"max {max(times) * 1000:.0f}); peak RSS {peak_mb:.0f} MB; heavy libraries loaded: "
          f"{', '.join(heavy) or 'none'}; target {TARGET_S:g} s, ratio {med / TARGET_S:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
