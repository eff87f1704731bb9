"""The catalogue at fleet size, on SQLite and on a PostgreSQL server of this machine (started here as
the tests start theirs, tests/fleet/postgres_server.py):

* ``list`` with a filter (one machine's axis) on a catalogue of 10,000 runs: target < 200 ms;
* ``trend`` over the 1,000 runs of one axis (in the same 10,000): target < 1 s;
* ``add --scan`` of 1,000 run directories (run.json, points.csv and results/summary.json each, as
  ``guideway process`` leaves them: nothing to evaluate) into an empty catalogue: target < 10 s.

Each is timed in this process (the service the command calls) and, for list and trend, as the whole
command in a fresh process (interpreter start and imports included).  Prints every time and the median.

    python benchmarks/bench_catalog.py [--runs 5] [--sqlite-only]
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import uuid
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fleet.catalog.database import open_catalog  # noqa: E402
from fleet.catalog.entry import Entry  # noqa: E402
from fleet.catalog.runs import _row, _upsert, add_runs, list_entries, scan_run_dirs  # noqa: E402
from fleet.trend.of_catalog import axis_trend  # noqa: E402

CATALOG_RUNS = 10_000
TREND_RUNS = 1_000
SCAN_RUNS = 1_000
MACHINES = 45  # with 4 axes: 9,000 other runs beside the 1,000 of the trend axis


def _values(i: int) -> dict:
    v = 5.0 + i * 1e-3
    return {"minimum_zone": {"value_um": v, "u_um": 0.12}, "least_squares": {"value_um": v + 0.3, "u_um": 0.13},
            "endpoint": {"value_um": v + 0.5, "u_um": 0.14}}


def _created(i: int) -> str:
    day = i % 3650
    return f"{2016 + day // 365:04d}-{1 + (day % 365) // 31 % 12:02d}-{1 + day % 28:02d}T{i % 24:02d}:00:00Z"


def fill(url: str) -> None:
    """10,000 entries: 1,000 on machine "fleet-0" axis X (the trend), the rest over 45 machines x 4 axes."""
    rows = []
    for i in range(CATALOG_RUNS):
        machine, axis = ("fleet-0", "X") if i < TREND_RUNS else (f"fleet-{1 + i % MACHINES}", "XYZW"[i % 4])
        rows.append(_row(Entry(uid=uuid.uuid4().hex, path=f"/runs/{i:05d}", machine=machine, axis=axis,
                               kind="straightness", created=_created(i), status="complete",
                               content_hash="0" * 64, values=_values(i), verdict=None)))
    with open_catalog(url) as cat:
        for k in range(0, len(rows), 1000):
            _upsert(cat, rows[k:k + 1000])


def run_dirs(folder: Path, template: Path) -> None:
    """1,000 run directories cloned from ``template`` (a processed run) with their own uid and date."""
    meta = json.loads((template / "run.json").read_text())
    points = (template / "points.csv").read_bytes()
    summary = (template / "results" / "summary.json").read_bytes()
    for i in range(SCAN_RUNS):
        run = folder / f"run{i:04d}"
        (run / "results").mkdir(parents=True)
        (run / "run.json").write_text(json.dumps({**meta, "uid": uuid.uuid4().hex, "created": _created(i)}))
        (run / "points.csv").write_bytes(points)
        (run / "results" / "summary.json").write_bytes(summary)  # written last: fresh results


def drop(url: str) -> None:
    import sqlalchemy as sa

    engine = sa.create_engine(url.replace("postgresql://", "postgresql+psycopg://"))
    with engine.begin() as conn:
        for table in ("guideway_runs", "guideway_catalog"):
            conn.execute(sa.text(f"DROP TABLE IF EXISTS {table}"))
    engine.dispose()


def timed(fn: Callable[[], object], runs: int) -> list[float]:
    out = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return out


def report(name: str, times: list[float], target_s: float) -> None:
    med = statistics.median(times)
    print(f"  {name:<52} median {med * 1000:8.1f} ms  (target < {target_s * 1000:.0f} ms, "
          f"{'OK' if med < target_s else 'OVER'})  runs: {', '.join(f'{t * 1000:.1f}' for t in times)}")


def command(url: str, *args: str) -> Callable[[], object]:
    exe = shutil.which("guideway", path=str(Path(sys.executable).parent))
    argv = [exe] if exe else [sys.executable, "-m", "tui.cli"]
    return lambda: subprocess.run([*argv, *args, "--catalog", url], cwd=ROOT, check=True, capture_output=True)


def bench(label: str, url: str, template: Path, work: Path, runs: int) -> None:
    print(f"{label}:")
    fill(url)
    with open_catalog(url) as cat:
        n = len(list_entries(cat, machine="fleet-7", axis="Z"))
        report(f"list --machine --axis of {CATALOG_RUNS} ({n} match), service",
               timed(lambda: list_entries(cat, machine="fleet-7", axis="Z"), runs), 0.2)
        report(f"trend over {TREND_RUNS} runs, service",
               timed(lambda: axis_trend(cat, "fleet-0", "X", "minimum_zone", 9.0), runs), 1.0)
    report("guideway catalog list --machine --axis (whole command)",
           timed(command(url, "catalog", "list", "--machine", "fleet-7", "--axis", "Z", "--json"), runs), 0.2)
    report("guideway trend (whole command)",
           timed(command(url, "trend", "--machine", "fleet-0", "--axis", "X", "--value", "minimum_zone",
                         "--json"), runs), 1.0)
    folder = work / "scan"
    if not folder.exists():
        run_dirs(folder, template)
    times = []
    for _ in range(runs):
        drop(url)
        with open_catalog(url) as cat:
            t = time.perf_counter()
            outcomes = list(add_runs(cat, scan_run_dirs(folder)))
            times.append(time.perf_counter() - t)
        assert sum(o.action == "added" for o in outcomes) == SCAN_RUNS, {o.action for o in outcomes}
    report(f"add --scan of {SCAN_RUNS} run directories (empty catalogue)", times, 10.0)
    drop(url)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sqlite-only", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="guideway-bench-catalog-") as tmp:
        work = Path(tmp)
        from acquisition.simulated.synthetic import simulate_run
        from saved_runs.evaluation.evaluate import process_run_dir

        template, _ = simulate_run(ROOT / "docs" / "scenario-straightness.toml", work / "template")
        run, evaluation = process_run_dir(template)
        evaluation.write(run.path / "results")
        bench("SQLite (a file)", f"sqlite:///{work / 'catalog.sqlite'}", template, work, args.runs)
        if not args.sqlite_only:
            from tests.fleet.postgres_server import postgres_server

            with postgres_server() as url:
                bench("PostgreSQL (server on 127.0.0.1)", url, template, work, args.runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
