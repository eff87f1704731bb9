"""Acquisition engine benchmarks.

1. Engine overhead per point, excluding device I/O: the complete straightness
   plan (validation, jump check, progress) run by the engine against in-memory
   devices that return prepared readings, with a subscriber that discards the
   documents.  Target < 1 ms per point.  Also shown: the same with the run store
   writing to disk (fsync per point), for information.
2. A 200-station simulated straightness run with zero-latency emulators (the
   sensor's serial-line transfer time switched off; real pty and Modbus TCP
   transports, real drivers, run store with fsync), from emulator start to the
   closed run directory.  Target < 2 s.

Prints every repetition, the median and the ratio to the target.

    python benchmarks/bench_acquire.py [--runs 5] [--points 2000] [--stations 200] [--samples 5]
"""

from __future__ import annotations

import argparse
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from acquisition.acquire import SimOptions, run_straightness  # noqa: E402
from acquisition.demo import demo_setup  # noqa: E402
from acquisition.engine import RunEngine  # noqa: E402
from acquisition.operators import AutoOperator  # noqa: E402
from acquisition.plans import straightness_plan  # noqa: E402
from acquisition.rig import Rig  # noqa: E402
from drivers.readings import AveragedDisplacement, ControllerStatus, InterferometerReading  # noqa: E402
from saved_runs.store.writer import RunStore  # noqa: E402

OVERHEAD_TARGET_MS = 1.0
RUN_TARGET_S = 2.0
OK = ControllerStatus(True, False, True, False, True, 1, 0, "", 0b10101)


class MemoryController:
    """Readings prepared in advance: no I/O at all."""

    def __init__(self, n: int, step_mm: float) -> None:
        self.readings = [InterferometerReading(k * step_mm, 0.01 * k, 0.0, 0.1, 0.0, 0.0, 20.0, 1013.0, 45.0,
                                               20.0, k, OK, 1000.0 + k) for k in range(n)]
        self.k = 0

    def zero(self) -> ControllerStatus:
        return OK

    def trigger_and_read(self) -> InterferometerReading:
        r = self.readings[self.k]
        self.k += 1
        return r

    def close(self) -> None:
        pass


class MemorySensor:
    reading = AveragedDisplacement(0.001, 0.0001, 5, 0, 0.0)

    def read_averaged(self, samples: int) -> AveragedDisplacement:
        return self.reading

    def close(self) -> None:
        pass


def engine_overhead_ms(points: int, store_dir: Path | None) -> float:
    setup = demo_setup(stations=points, samples=5)
    rig = Rig(MemorySensor(), MemoryController(points, setup.block_length_mm))  # type: ignore[arg-type]
    subs = (RunStore(store_dir, setup.header()),) if store_dir is not None else (lambda name, doc: None,)
    engine = RunEngine(rig, AutoOperator(), subs)
    t0 = time.perf_counter()
    out = engine.run(straightness_plan(setup, {}))
    dt = time.perf_counter() - t0
    assert out.exit_status == "success" and out.num_events == points, out
    return dt / points * 1000.0


def simulated_run_s(stations: int, samples: int, out: Path, seed: int) -> float:
    t0 = time.perf_counter()
    res = run_straightness(demo_setup(stations=stations, samples=samples), out,
                           simulate=SimOptions(seed=seed, noise=True, wire_time=False), auto=True,
                           stream=io.StringIO())
    dt = time.perf_counter() - t0
    assert res.outcome.exit_status == "success", res.outcome
    return dt


def report(name: str, values: list[float], unit: str, target: float) -> None:
    med = statistics.median(values)
    print(f"{name}: median {med:.3f} {unit} over {len(values)} runs (min {min(values):.3f}, max {max(values):.3f}); "
          f"target {target:g} {unit}, ratio {med / target:.2f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--points", type=int, default=2000, help="points per engine-overhead run")
    ap.add_argument("--stations", type=int, default=200)
    ap.add_argument("--samples", type=int, default=5, help="sensor samples per reading in the simulated run")
    args = ap.parse_args()
    mem, disk, runs = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.runs):
            mem.append(engine_overhead_ms(args.points, None))
            disk.append(engine_overhead_ms(args.points, Path(tmp) / f"store{i}"))
            print(f"run {i + 1}: engine {mem[-1]:.4f} ms/point, engine + run store {disk[-1]:.3f} ms/point")
        for i in range(args.runs):
            runs.append(simulated_run_s(args.stations, args.samples, Path(tmp) / f"sim{i}", i))
            print(f"run {i + 1}: {args.stations}-station simulated run {runs[-1]:.2f} s")
    report("engine overhead per point (no device I/O)", mem, "ms", OVERHEAD_TARGET_MS)
    report("engine + run store (fsync) per point, for information", disk, "ms", OVERHEAD_TARGET_MS)
    report(f"{args.stations}-station simulated run, zero-latency emulators, {args.samples} samples/reading",
           runs, "s", RUN_TARGET_S)
    return 0


if __name__ == "__main__":
    sys.exit(main())
