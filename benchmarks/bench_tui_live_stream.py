"""TUI live readings of a Micro-Epsilon ILD1420 streaming at 2 kHz: UI frame interval (< 100 ms) and
frames lost by the driver (0).

The simulated ILD1420 (2 kHz, 921.6 kBd, on a pty) and a simulated controller are opened as a rig;
the TUI's live monitor (acquisition.monitor.LiveMonitor, as in a run while the engine waits) reads
the stream in blocks and posts one reading per block to the app (headless, 80x24, the connect and
warm-up screen).  Frame interval = time between the frames the app writes while the values change
(the app's display calls); frames lost = frames the emulator sent minus the values the driver
handed out (the stream is started and stopped by the monitor, so both count the same frames) plus
frames the decoder saw damaged.  Prints each run, medians and the ratios to the targets.

    python benchmarks/bench_tui_live_stream.py [--seconds 10] [--runs 3] [--rate-khz 2]
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import time
from pathlib import Path

from acquisition.monitor import LiveMonitor
from acquisition.rig import Rig, open_controller
from acquisition.simulated.rig import start_simulated_rig
from drivers.me_ild1420 import ILD1420
from mocks.me_ild1420 import ILD1420Emulator, StreamPacer
from mocks.serial_endpoints import PtyEndpoint
from tui.app import GuidewayApp
from tui.messages import LiveReadingArrived
from tui.screens.run import ConnectScreen
from tui.session import RunPlanInfo, RunSession

FRAME_TARGET_S = 0.100


async def one_run(seconds: float, rate_khz: float) -> dict[str, float]:
    t_start = time.monotonic()
    emu = ILD1420Emulator(lambda _o=1: 5.0 + 0.001 * ((time.monotonic() - t_start) % 1.0), measuring_range_mm=10.0,
                          measrate_khz=rate_khz, output="NONE")
    endpoint = PtyEndpoint(emu, baudrate=921600)
    pacer = StreamPacer(emu, endpoint.write_unsolicited).start()
    sim = start_simulated_rig(seed=0, noise=False)
    sensor = ILD1420.from_url(endpoint.path, measuring_range_mm=10.0)
    rig = Rig(sensor, open_controller(sim.controller_url))
    app = GuidewayApp(runs_dir=Path("runs"))
    frames: list[float] = []
    posted: list[float] = []  # when the monitor thread posted each reading (the UI cannot paint more often)
    try:
        async with app.run_test(size=(80, 24)) as pilot:
            display = app._display

            def timed_display(screen, renderable) -> None:  # noqa: ANN001
                frames.append(time.perf_counter())
                display(screen, renderable)

            app._display = timed_display  # type: ignore[method-assign]
            session = RunSession(lambda _m: None, RunPlanInfo("straightness", 10, 10), None, Path("runs/x"),
                                 simulate=None)
            session.view.started = True
            app.session = session
            app._switch(ConnectScreen(session))
            await pilot.pause()

            def post(reading) -> None:  # noqa: ANN001
                posted.append(time.perf_counter())
                app.post_message(LiveReadingArrived(reading))

            monitor = LiveMonitor(rig, post, interval_s=0.05, restore_output=None)
            frames.clear()
            with monitor:
                await asyncio.sleep(seconds)
                t_stop = time.perf_counter()
            await pilot.pause()
    finally:
        rig.close()
        pacer.stop()
        endpoint.stop()
        sim.close()
    frames = [t for t in frames if t <= t_stop]  # while the monitor streamed
    gaps = [b - a for a, b in zip(frames, frames[1:], strict=False)]
    reading_gaps = [b - a for a, b in zip(posted, posted[1:], strict=False)]
    worst = max(range(len(reading_gaps)), key=reading_gaps.__getitem__)
    print(f"  longest reading gap after reading {worst + 1} of {len(posted)}, "
          f"{posted[worst] - posted[0]:.2f} s into the stream")
    return {"frames": len(frames), "median_gap": statistics.median(gaps), "max_gap": max(gaps),
            "p99_gap": sorted(gaps)[int(0.99 * (len(gaps) - 1))], "readings": len(posted),
            "max_reading_gap": max(reading_gaps),
            "sent": emu.frames_sent, "received": monitor.frames_received, "damaged": monitor.frames_lost}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--rate-khz", type=float, default=2.0)
    args = ap.parse_args()
    p99s, maxes, losts = [], [], []
    for i in range(args.runs):
        r = asyncio.run(one_run(args.seconds, args.rate_khz))
        lost = r["sent"] - r["received"] + r["damaged"]
        p99s.append(r["p99_gap"])
        maxes.append(r["max_gap"])
        losts.append(lost)
        print(f"run {i + 1}: {args.seconds:g} s at {args.rate_khz:g} kHz: {r['sent']:.0f} sensor frames sent, "
              f"{r['received']:.0f} received, lost {lost:.0f}; {r['readings']:.0f} live readings posted, "
              f"{r['frames']:.0f} UI frames, interval median {r['median_gap'] * 1000:.1f} ms, "
              f"p99 {r['p99_gap'] * 1000:.1f} ms, max {r['max_gap'] * 1000:.1f} ms (longest gap between two "
              f"readings posted by the monitor: {r['max_reading_gap'] * 1000:.1f} ms)")
    med_p99, med_max = statistics.median(p99s), statistics.median(maxes)
    print(f"TUI live ILD1420 stream: median p99 frame interval {med_p99 * 1000:.1f} ms, median max "
          f"{med_max * 1000:.1f} ms (target < {FRAME_TARGET_S * 1000:.0f} ms, ratio of the max "
          f"{med_max / FRAME_TARGET_S:.2f}); lost frames per run {', '.join(f'{x:.0f}' for x in losts)} (target 0)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
