"""Round-trip time of one polled Keyence LK-G reading (``M1``) over a real pty.

The emulator runs in its own process, as a real controller would (``guideway
sim serve --no-noise``: no shared interpreter lock with the driver), and
models line timing at 115200 baud: the reply's last byte arrives when request
+ reply would have crossed the wire.  So the floor is the wire time of the
request and reply bytes at 10 bits per character (8N1).  Prints the median
round trip of every repeat, the median of those medians, the wire time and
their ratio (target <= 1.1: driver, transport and pty add less than 10 %),
and the fastest poll (what is left without scheduling delays on a busy machine).
``--in-process`` runs the emulator thread in this process instead (the
set-up of the tests and the demo) for comparison.

    python benchmarks/bench_polled_roundtrip.py [--polls 200] [--repeats 5] [--in-process]
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import statistics
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from drivers.keyence_lkg import KeyenceLKG  # noqa: E402
from mocks.keyence_lkg import KeyenceLKGEmulator  # noqa: E402
from mocks.serial_endpoints import PtyEndpoint  # noqa: E402

TARGET_RATIO = 1.1
BAUD = 115200  # the rate `guideway sim serve` models for keyence-lkg
REQUEST = b"M1\r"  # the LK-G poll of output 1 (protocols.md 1.1)
ROOT = Path(__file__).resolve().parents[1]


@contextlib.contextmanager
def served_sensor(in_process: bool) -> Iterator[str]:
    """Path of a pty with an LK-G emulator behind it, for the duration of the block."""
    if in_process:
        endpoint = PtyEndpoint(KeyenceLKGEmulator(lambda _out: 0.12345, decimals=5), baudrate=BAUD)
        try:
            yield endpoint.path
        finally:
            endpoint.stop()
        return
    proc = subprocess.Popen([sys.executable, "-m", "tui.cli", "sim", "serve", "--no-noise"], cwd=ROOT,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()  # "sensor: keyence-lkg:PATH baud=115200 (pty ...)"
        if not line.startswith("sensor: keyence-lkg:") or f"baud={BAUD}" not in line:
            raise SystemExit(f"unexpected first line from guideway sim serve: {line!r}")
        yield line.split()[1].removeprefix("keyence-lkg:")
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=30)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--polls", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--in-process", action="store_true", help="emulator thread in this process")
    args = ap.parse_args()
    medians, minima = [], []
    with served_sensor(args.in_process) as path:
        dev = KeyenceLKG.from_url(path, baudrate=BAUD)
        try:
            reply_len = len(dev.read_once().raw)  # warm-up; the raw frame includes its CR
            wire_s = (len(REQUEST) + reply_len) * 10 / BAUD
            for rep in range(args.repeats):
                times = []
                for _ in range(args.polls):
                    t0 = time.perf_counter()
                    dev.read_once()
                    times.append(time.perf_counter() - t0)
                medians.append(statistics.median(times))
                minima.append(min(times))
                print(f"repeat {rep + 1}: median {medians[-1] * 1e3:.3f} ms "
                      f"(min {min(times) * 1e3:.3f}, max {max(times) * 1e3:.3f}) over {args.polls} polls")
        finally:
            dev.close()
    med = statistics.median(medians)
    where = "in-process emulator" if args.in_process else "emulator process"
    print(f"LK-G M1 poll over pty at {BAUD} baud ({where}): median round trip {med * 1e3:.3f} ms; "
          f"wire time of {len(REQUEST)} + {reply_len} bytes {wire_s * 1e3:.3f} ms; "
          f"ratio {med / wire_s:.3f} (target <= {TARGET_RATIO}); fastest poll {min(minima) * 1e3:.3f} ms, "
          f"ratio {min(minima) / wire_s:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
