"""Key press to capture start in the TUI with simulated devices (target < 100 ms).

A simulated straightness session runs in the Textual app (headless, 80x24, live readings on);
at each station the benchmark presses Space and takes the time until the run's worker thread
starts the capture (its first device call, the interferometer trigger).  That interval holds
the key's way through the UI, the TUI operator's hand-over to the engine thread and the engine
taking the devices back from the live monitor (at most one live reading).  Prints every
session's median, the median over sessions and the ratio to the target.

    python benchmarks/bench_tui_capture_latency.py [--runs 3] [--stations 8]
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

from acquisition.messages import Instruct
from tui.app import GuidewayApp

TARGET_S = 0.100


async def one_session(out: Path, stations: int) -> list[float]:
    source = {"kind": "straightness", "block": {"length_mm": 100.0, "stations": stations, "samples_per_reading": 2},
              "geometry": {"mirror_mm": [50.0, 110.0, 0.0], "sensor_mm": [150.0, 0.0, 40.0]},
              "warmup": {"enabled": False}}
    app = GuidewayApp(setup_source=source, out=out, runs_dir=out.parent, simulate=True)
    starts: list[float] = []
    latencies: list[float] = []
    async with app.run_test(size=(80, 24)) as pilot:
        while not getattr(app.screen, "ready", False):  # the set-up form is built after the first frame
            await pilot.pause(0.01)
        await pilot.press("f5")
        while app.session is None or app.session.engine is None:
            await pilot.pause(0.01)
        session = app.session
        rig = session.engine.rig
        trigger = rig.trigger_and_read

        def timed_trigger():  # noqa: ANN202
            if threading.current_thread().name == "guideway-run":
                starts.append(time.perf_counter())
            return trigger()

        rig.trigger_and_read = timed_trigger  # type: ignore[method-assign]
        while True:
            while session.view.question is None and session.active:
                await pilot.pause(0.005)
            q = session.view.question
            if q is None:
                break
            if isinstance(q, Instruct) and q.key == "station":
                await asyncio.sleep(0.15)  # let a live reading be under way, as at a real station
                n = len(starts)
                t0 = time.perf_counter()
                await pilot.press("space")
                while len(starts) == n:
                    await asyncio.sleep(0.001)
                latencies.append(starts[n] - t0)
            else:
                await pilot.press("space" if isinstance(q, Instruct) else "enter")
            while session.view.question is q:
                await pilot.pause(0.005)
    return latencies


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--stations", type=int, default=8)
    args = ap.parse_args()
    medians = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.runs):
            lat = asyncio.run(one_session(Path(tmp) / f"run{i}", args.stations))
            medians.append(statistics.median(lat))
            print(f"session {i + 1}: {len(lat)} captures, key to capture start median {medians[-1] * 1000:.1f} ms, "
                  f"max {max(lat) * 1000:.1f} ms")
    med = statistics.median(medians)
    print(f"TUI key press to capture start: median {med * 1000:.1f} ms over {args.runs} sessions "
          f"(target < {TARGET_S * 1000:.0f} ms, ratio {med / TARGET_S:.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
