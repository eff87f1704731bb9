"""Polling rate of the LK-G and HL-G1 drivers against their emulators over a real
pty (wire time emulated at the baud rate), and the codecs' decode time.

Prints each run, the median polls per second and its ratio to the line's limit
(request + reply bytes at 10 bits per character, no device processing time).

    python benchmarks/bench_sensor_poll.py [--runs 5] [--polls 200] [--baud 115200]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from drivers.keyence_lkg import KeyenceLKG  # noqa: E402
from drivers.keyence_lkg import protocol as lkg  # noqa: E402
from drivers.panasonic_hlg1 import PanasonicHLG1  # noqa: E402
from drivers.panasonic_hlg1 import protocol as hlg  # noqa: E402
from drivers.transport import open_serial  # noqa: E402
from mocks.keyence_lkg import KeyenceLKGEmulator  # noqa: E402
from mocks.panasonic_hlg1 import PanasonicHLG1Emulator  # noqa: E402
from mocks.serial_endpoints import PtyEndpoint  # noqa: E402

SENSORS = {
    # name: (emulator, driver class, bytes on the wire per poll: request + reply)
    "keyence-lkg M1": (lambda: KeyenceLKGEmulator(lambda _o: 0.25), KeyenceLKG, len(b"M1\r") + len(b"M1,+0.25000\r")),
    "panasonic-hlg1 RMB": (lambda: PanasonicHLG1Emulator(lambda _o: 0.25), PanasonicHLG1,
                           len(b"%01#RMB5D\r") + len(b"%01$RMB+000250005670000XX\r")),
}


def polls_per_second(make_emulator, driver_cls, polls: int, baud: int) -> float:  # noqa: ANN001
    endpoint = PtyEndpoint(make_emulator(), baudrate=baud)
    dev = driver_cls(open_serial(endpoint.path, baudrate=baud), endpoint=endpoint.path)
    try:
        dev.read_once()
        t0 = time.perf_counter()
        for _ in range(polls):
            dev.read_once()
        return polls / (time.perf_counter() - t0)
    finally:
        dev.close()
        endpoint.stop()


def decode_us(decode, frame: bytes, n: int = 20000) -> float:  # noqa: ANN001
    t0 = time.perf_counter()
    for _ in range(n):
        decode(frame)
    return (time.perf_counter() - t0) / n * 1e6


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--polls", type=int, default=200)
    ap.add_argument("--baud", type=int, default=115200)
    args = ap.parse_args()
    for name, (make, cls, nbytes) in SENSORS.items():
        rates = []
        for i in range(args.runs):
            rates.append(polls_per_second(make, cls, args.polls, args.baud))
            print(f"{name} run {i + 1}: {rates[-1]:.0f} polls/s")
        limit = args.baud / (10 * nbytes)
        med = statistics.median(rates)
        print(f"{name} over a pty at {args.baud} baud: median {med:.0f} polls/s over {args.runs} runs "
              f"(min {min(rates):.0f}, max {max(rates):.0f}); line limit {limit:.0f}/s, ratio {med / limit:.2f}")
    body = "%01$RMB+0002500" + "05670000"
    frame = (body + hlg.bcc(body.encode()).decode() + "\r").encode()
    for name, fn, fr in [("lkg.decode_measure", lambda f: lkg.decode_measure(f, 1), b"M1,+01.2345\r"),
                         ("hlg.decode_all_outputs", lambda f: hlg.decode_all_outputs(f, 1), frame)]:
        times = [decode_us(fn, fr) for _ in range(args.runs)]
        print(f"{name}: median {statistics.median(times):.2f} us per frame over {args.runs} runs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
