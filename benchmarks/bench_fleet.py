"""The fleet overview at fleet size, on SQLite and on a PostgreSQL server of this machine (started here as the
tests start theirs, tests/fleet/postgres_server.py): a catalogue of 10,000 runs over 50 machines x 3 axes
(about 67 runs each over 8 years, each run recording two instruments), tolerances and intervals kept in the
catalogue for a third of the axes.

* the whole overview (every row's trend, crossing date, last step; the instruments), service: target < 1 s;
* the statements it sends (one for all entries, one for the tolerances, one for the intervals);
* ``guideway fleet --json``, ``guideway fleet --report``, ``guideway fleet check`` as whole commands in a
  fresh process (interpreter start and imports included).

Prints every time and the median.

    python benchmarks/bench_fleet.py [--runs 5] [--sqlite-only]
"""

from __future__ import annotations

import argparse
import math
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import uuid
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from fleet.catalog.database import open_catalog  # noqa: E402
from fleet.catalog.entry import Entry  # noqa: E402
from fleet.catalog.runs import write_entries  # noqa: E402
from fleet.catalog.settings import set_interval, set_tolerance  # noqa: E402
from fleet.overview.overview import fleet_overview  # noqa: E402
from fleet.trend.fit import parse_date  # noqa: E402

RUNS = 10_000
MACHINES = 50
AXES = "XYZ"


def entries() -> list[Entry]:
    """10,000 entries, round robin over the 150 axes, one every ~29 days per axis from 2018 on; wear 0-1.2 µm
    per year with a small ripple, u 0.1 µm, limit 8 µm from the runs' [tolerance]."""
    out = []
    start = datetime(2018, 1, 1, tzinfo=UTC)
    n_axes = MACHINES * len(AXES)
    for i in range(RUNS):
        k, j = i % n_axes, i // n_axes
        machine, axis = f"fleet-{k // len(AXES):02d}", AXES[k % len(AXES)]
        when = start + timedelta(days=29.0 * j + k * 0.1)
        v = 3.0 + (k % 13) * 0.1 * j / 12.6 + 0.05 * math.sin(i)
        instruments = [{"role": "interferometer", "model": "XL-80", "serial": f"S{k % 7}", "certificate": f"C{j}",
                        "due": (when + timedelta(days=365)).strftime("%Y-%m-%d")},
                       {"role": "sensor", "model": "ILD1420", "serial": f"T{k % 5}", "due": "2027-01-01"}]
        out.append(Entry(uid=uuid.uuid4().hex, path=f"/runs/{machine}/{axis}/{j:03d}", machine=machine, axis=axis,
                         kind="straightness", created=when.strftime("%Y-%m-%dT%H:%M:%SZ"), status="complete",
                         content_hash="0" * 64, verdict="pass",
                         values={"minimum_zone": {"value_um": v, "u_um": 0.1, "limit_um": 8.0},
                                 "least_squares": {"value_um": v + 0.3, "u_um": 0.1}},
                         facts={"operator": f"tech {j % 4}", "compensation": {"active": False},
                                "instruments": instruments, "decision_rule": None}))
    return out


def fill(url: str) -> None:
    with open_catalog(url) as cat:
        write_entries(cat, entries())
        for m in range(0, MACHINES, 3):
            set_tolerance(cat, f"fleet-{m:02d}", "X", "least_squares", 7.5)
            set_interval(cat, f"fleet-{m:02d}", "Y", 365)


def drop(url: str) -> None:
    import sqlalchemy as sa

    engine = sa.create_engine(url.replace("postgresql://", "postgresql+psycopg://"))
    with engine.begin() as conn:
        for table in ("guideway_runs", "guideway_catalog", "guideway_tolerances", "guideway_intervals"):
            conn.execute(sa.text(f"DROP TABLE IF EXISTS {table}"))
    engine.dispose()


def timed(fn: Callable[[], object], runs: int) -> list[float]:
    out = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return out


def report(name: str, times: list[float], target_s: float | None) -> None:
    med = statistics.median(times)
    target = "" if target_s is None else (f"(target < {target_s * 1000:.0f} ms, "
                                          f"{'OK' if med < target_s else 'OVER'})")
    print(f"  {name:<52} median {med * 1000:8.1f} ms  {target}  runs: {', '.join(f'{t * 1000:.1f}' for t in times)}")


def command(url: str, *args: str) -> Callable[[], object]:
    exe = shutil.which("guideway", path=str(Path(sys.executable).parent))
    argv = [exe] if exe else [sys.executable, "-m", "tui.cli"]
    # fleet check exits 1 when something needs attention: not a failure here
    return lambda: subprocess.run([*argv, *args, "--catalog", url], cwd=ROOT, capture_output=True)


def bench(label: str, url: str, work: Path, runs: int) -> None:
    import sqlalchemy as sa

    print(f"{label}:")
    if url.startswith("postgresql"):
        drop(url)
    fill(url)
    with open_catalog(url, create=False) as cat:
        statements: list[str] = []
        def count(conn, cursor, statement, *rest):  # noqa: ANN001, ANN202
            statements.append(statement)

        sa.event.listen(cat.engine, "before_cursor_execute", count)
        ov = fleet_overview(cat)
        sa.event.remove(cat.engine, "before_cursor_execute", count)
        selects = [s for s in statements if s.lstrip().upper().startswith("SELECT")]
        runs_selects = [s for s in selects if "guideway_runs" in s]
        print(f"  {len(ov.rows)} rows, {len(ov.instruments)} instruments; statements sent: {len(selects)} SELECT "
              f"({len(runs_selects)} of guideway_runs)")
        def cold() -> object:  # as a fresh process: no date parsed before
            parse_date.cache_clear()
            return fleet_overview(cat)

        report(f"overview of {RUNS} runs, service", timed(cold, runs), 1.0)
    report("guideway fleet --json (whole command)", timed(command(url, "fleet", "--json"), runs), None)
    report("guideway fleet --report (whole command)",
           timed(command(url, "fleet", "--report", str(work / "fleet.html")), runs), None)
    report("guideway fleet check --within 90 (whole command)",
           timed(command(url, "fleet", "check", "--within", "90"), runs), None)
    drop(url)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sqlite-only", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="guideway-bench-fleet-") as tmp:
        work = Path(tmp)
        bench("SQLite (a file)", f"sqlite:///{work / 'catalog.sqlite'}", work, args.runs)
        if not args.sqlite_only:
            from tests.fleet.postgres_server import postgres_server

            with postgres_server() as url:
                bench("PostgreSQL (server on 127.0.0.1)", url, work, args.runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
