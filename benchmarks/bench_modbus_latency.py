"""Modbus trigger-to-data latency of the interferometer driver.

Compares ``InterferometerController.trigger_and_read()`` (read status, write
the trigger, poll status, read 100-127, re-read status: 5 requests when the
emulator's measure time is 0) with one bare pymodbus
``read_holding_registers(100, count=28)`` on the same server.  Prints the
median over batches of the mean time per call, and their ratio.  Modbus TCP on
loopback; then Modbus RTU over the pty bridge at 115200 baud (line timing
modelled, 11 bits per character).

    python benchmarks/bench_modbus_latency.py [--batches 5] [--calls 200] [--rtu-calls 50] [--no-rtu]
"""

from __future__ import annotations

import argparse
import logging
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pymodbus import FramerType  # noqa: E402
from pymodbus.client import ModbusSerialClient, ModbusTcpClient  # noqa: E402

from drivers.interferometer import InterferometerController  # noqa: E402
from mocks.interferometer import InterferometerEmulator, start_controller  # noqa: E402
from mocks.world import Noise, World  # noqa: E402

DATA_START, DATA_COUNT = 100, 28


def per_call_ms(fn: Callable[[], object], batches: int, calls: int) -> list[float]:
    """Mean time per call (ms) of each batch."""
    fn()  # warm-up (connection, first trigger)
    out = []
    for _ in range(batches):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        out.append((time.perf_counter() - t0) / calls * 1e3)
    return out


def bench(transport: str, batches: int, calls: int) -> None:
    world = World(noise=Noise.off(), seed=1)
    server = start_controller(InterferometerEmulator(world, measure_time_s=0.0), transport=transport,
                              baudrate=115200)
    if transport == "tcp":
        bare: ModbusTcpClient | ModbusSerialClient = ModbusTcpClient("127.0.0.1", port=server.port, timeout=1,
                                                                     retries=0)
    else:
        bare = ModbusSerialClient(server.bridge.path_b, framer=FramerType.RTU,  # type: ignore[union-attr]
                                  baudrate=115200, parity="N", timeout=1, retries=0)
    try:
        # One opener at a time: pymodbus opens a serial port exclusively.
        ctl = InterferometerController.from_url(server.url, timeout_s=1.0)
        try:
            trig = per_call_ms(ctl.trigger_and_read, batches, calls)
        finally:
            ctl.close()
        bare.connect()
        read = per_call_ms(lambda: bare.read_holding_registers(DATA_START, count=DATA_COUNT, device_id=1),
                           batches, calls)
    finally:
        bare.close()
        server.stop()
    mt, mr = statistics.median(trig), statistics.median(read)
    label = "Modbus TCP loopback" if transport == "tcp" else "Modbus RTU pty 115200"
    print(f"{label}: trigger_and_read median {mt:.2f} ms/call (batches {', '.join(f'{x:.2f}' for x in trig)})")
    print(f"{label}: bare read 100-127 median {mr:.2f} ms/call (batches {', '.join(f'{x:.2f}' for x in read)})")
    print(f"{label}: ratio trigger_and_read / bare read = {mt / mr:.1f} "
          f"({batches} batches x {calls} calls)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batches", type=int, default=5)
    ap.add_argument("--calls", type=int, default=200)
    ap.add_argument("--rtu-calls", type=int, default=50)
    ap.add_argument("--no-rtu", action="store_true")
    args = ap.parse_args()
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    bench("tcp", args.batches, args.calls)
    if not args.no_rtu:
        bench("rtu", args.batches, args.rtu_calls)
    return 0


if __name__ == "__main__":
    sys.exit(main())
