"""How long the Results screen leaves the UI without an answer while it opens a saved run and evaluates it,
and the time to the evaluation and (``d``) to the diagnosis (tests/data/tui-runs/positioning-x against
docs/model-positioning.toml).

Each run is a fresh process (imports count), driving the app headless at 80x24 with Textual's pilot.  A
timer ticks every 10 ms on the UI's event loop; the longest gap between ticks from opening the results to
the evaluation shown is the longest the screen could not answer a key (the evaluation stack, seconds of
imports, is loaded in the screens' workers, not on the UI thread).  Prints every run and the medians.

    python benchmarks/bench_tui_results.py [--runs 5]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUN = ROOT / "tests" / "data" / "tui-runs" / "positioning-x"


async def _wait(pilot, condition, timeout_s: float = 120.0) -> None:  # noqa: ANN001
    deadline = time.perf_counter() + timeout_s
    while not condition():
        if time.perf_counter() > deadline:
            raise RuntimeError("timed out")
        await pilot.pause(0.005)


async def one() -> dict[str, float]:
    from tui.app import GuidewayApp

    app = GuidewayApp(runs_dir=RUN.parent, start="runs")
    ticks: list[float] = []
    async with app.run_test(size=(80, 24)) as pilot:
        await pilot.pause()
        app.set_interval(0.01, lambda: ticks.append(time.perf_counter()))
        await pilot.pause(0.05)
        t0 = time.perf_counter()
        app.open_results(RUN)
        await _wait(pilot, lambda: getattr(app.screen, "evaluation", None) is not None)
        evaluated = time.perf_counter() - t0
        during = [t0, *(t for t in ticks if t > t0), time.perf_counter()]
        stalled = max(b - a for a, b in zip(during, during[1:], strict=False))
        t1 = time.perf_counter()
        await pilot.press("d")
        await _wait(pilot, lambda: getattr(app.screen, "result", None) is not None or getattr(app.screen, "error", ""))
        diagnosed = time.perf_counter() - t1
    return {"longest_stall_s": stalled, "evaluation_s": evaluated, "diagnosis_s": diagnosed}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(asyncio.run(one())))
        return 0
    results = []
    for i in range(args.runs):
        out = subprocess.run([sys.executable, __file__, "--one"], capture_output=True, text=True, cwd=ROOT,
                             check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        results.append(r)
        print(f"run {i + 1}: " + ", ".join(f"{k} {v:.3f}" for k, v in r.items()))
    for key in results[0]:
        print(f"median {key}: {statistics.median(r[key] for r in results):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
