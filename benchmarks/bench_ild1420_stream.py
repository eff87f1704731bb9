"""Continuous ILD1420 streaming at 2 kHz over a pty (921.6 kBd): frames and reader CPU.

The emulator (with its stream pacer and the pty endpoint thread) runs in this
process; the driver reads in its own thread.  "Reader CPU" is that thread's
CPU time (``time.thread_time()``) over the wall time, in % of one core: the
driver's decoding and the pyserial reads, nothing of the emulator.  The
process total (emulator included) is printed for context.

Frames expected = frames the emulator sent between ``OUTPUT RS422`` and
``OUTPUT NONE`` (and the nominal rate x duration); received = values in the
blocks plus the final block from ``stop_stream()``; lost = expected - received;
garbled = resynchronisations the decoder reported.  Targets: 0 lost, 0
garbled, reader CPU < 30 % of one core.

    python benchmarks/bench_ild1420_stream.py [--seconds 60] [--rate-khz 2] [--runs 1]
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import threading
import time

from drivers.me_ild1420 import ILD1420
from mocks.me_ild1420 import ILD1420Emulator, StreamPacer
from mocks.serial_endpoints import PtyEndpoint

CPU_TARGET_PCT = 30.0


def one_run(seconds: float, rate_khz: float, block_s: float) -> dict[str, float]:
    t_start = time.monotonic()

    def surface(_out: int) -> float:  # a slow 1 mm wave around mid-range
        return 5.0 + 0.5 * math.sin(2 * math.pi * 0.5 * (time.monotonic() - t_start))

    emu = ILD1420Emulator(surface, measuring_range_mm=10.0, measrate_khz=rate_khz, output="NONE")
    endpoint = PtyEndpoint(emu, baudrate=921600)
    pacer = StreamPacer(emu, endpoint.write_unsolicited).start()
    dev = ILD1420.from_url(endpoint.path, measuring_range_mm=10.0)
    out: dict[str, float] = {}

    def reader() -> None:
        cpu0, wall0 = time.thread_time(), time.monotonic()
        dev.start_stream()
        blocks = []
        while time.monotonic() - wall0 < seconds:
            blocks.append(dev.read_stream(duration_s=block_s))
        final = dev.stop_stream()
        assert final is not None
        blocks.append(final)
        out["reader_cpu_s"] = time.thread_time() - cpu0
        out["wall_s"] = time.monotonic() - wall0
        out["received"] = sum(b.frames_ok for b in blocks)
        out["garbled"] = sum(b.resyncs for b in blocks)
        out["decoder_lost"] = sum(b.frames_lost for b in blocks)
        out["bad_status"] = sum(1 for b in blocks for s in b.statuses if s.value != "ok")

    proc0 = time.process_time()
    try:
        thread = threading.Thread(target=reader, name="ild1420-reader")
        thread.start()
        thread.join()
    finally:
        dev.close()
        pacer.stop()
        endpoint.stop()
    out["process_cpu_s"] = time.process_time() - proc0
    out["expected"] = emu.frames_sent
    out["nominal"] = rate_khz * 1000 * seconds
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--rate-khz", type=float, default=2.0)
    ap.add_argument("--block-s", type=float, default=0.1, help="duration of each read_stream() block")
    ap.add_argument("--runs", type=int, default=1)
    args = ap.parse_args()
    cpu_pcts, losts = [], []
    for i in range(args.runs):
        r = one_run(args.seconds, args.rate_khz, args.block_s)
        lost = r["expected"] - r["received"]
        cpu_pct = 100 * r["reader_cpu_s"] / r["wall_s"]
        proc_pct = 100 * r["process_cpu_s"] / r["wall_s"]
        cpu_pcts.append(cpu_pct)
        losts.append(lost)
        print(f"run {i + 1}: {r['wall_s']:.1f} s at {args.rate_khz:g} kHz: frames expected {r['expected']:.0f} "
              f"(nominal {r['nominal']:.0f}), received {r['received']:.0f}, lost {lost:.0f} "
              f"(decoder count {r['decoder_lost']:.0f}), garbled {r['garbled']:.0f}, "
              f"invalid values {r['bad_status']:.0f}; reader CPU {cpu_pct:.1f} % of one core "
              f"(process incl. emulator {proc_pct:.1f} %)")
    med = statistics.median(cpu_pcts)
    print(f"ILD1420 stream, {args.seconds:g} s x {args.runs} run(s): median reader CPU {med:.1f} % of one core "
          f"(target < {CPU_TARGET_PCT:.0f} %, ratio {med / CPU_TARGET_PCT:.2f}); "
          f"lost frames per run {', '.join(f'{x:.0f}' for x in losts)} (target 0)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
