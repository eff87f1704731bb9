"""Peak memory and time of ``guideway process`` on 200, 10 000 and 100 000-station straightness runs.

The runs are written by ``guideway simulate`` from a scenario (docs/scenario-straightness.toml with
the station count set, forward pass only, a 3 um wave and no slope; the block is 100 mm long, shorter
above 1000 stations so the travel stays within 100 m: the simulated world's roll and horizontal
straightness grow with the travel and a 10 km guideway would pass the default validation limits)
into ``--work`` (kept there: the 100 000-station run takes a minute or
two to generate, later calls reuse it).  Each measurement is one ``guideway process RUN_DIR`` in a
fresh process with its default evaluation (exact decoupling, Monte Carlo with the default number of
trials, results/ written: profile.csv, profile.png, summary.json); its peak resident set size comes
from ``os.wait4`` (that child's own ``ru_maxrss``), its time from the wall clock.  Median of
``--runs`` runs per size (peak: the largest seen).

``--source DIR`` runs the tool from another checkout of the code (e.g. an ``git archive`` of an
older commit unpacked in DIR) with this environment's interpreter, for before / after figures.

    python benchmarks/bench_process_memory.py [--runs 3] [--sizes 200,10000,100000] [--work DIR] [--source DIR]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIMIT_MB = 300.0  # docs/reliability.md, "Memory"
RUNNER = "import sys; sys.path.insert(0, sys.argv.pop(1)); from tui.cli import main; sys.exit(main())"


def guideway(source: Path, *args: str) -> list[str]:
    return [sys.executable, "-c", RUNNER, str(source), *args]


def make_run(stations: int, work: Path) -> Path:
    """The simulated run of ``stations`` stations under ``work`` (generated once)."""
    run = work / f"run-{stations}-v2"
    if (run / "run.json").is_file() and '"complete"' in (run / "run.json").read_text():
        return run
    shutil.rmtree(run, ignore_errors=True)
    text = (ROOT / "docs" / "scenario-straightness.toml").read_text()
    text = re.sub(r"(?m)^stations = \d+", f"stations = {stations}", text)
    text = re.sub(r"(?m)^length_mm = \S+", f"length_mm = {min(100.0, 100_000.0 / stations):g}", text)
    text = re.sub(r"(?m)^return_pass = true", "return_pass = false", text)
    text = re.sub(r"(?m)^slope_urad = .*", "slope_urad = 0.0", text)
    scenario = work / f"scenario-{stations}.toml"
    scenario.write_text(text)
    subprocess.run(guideway(ROOT, "simulate", str(scenario), "--out", str(run)), check=True,
                   stdout=subprocess.DEVNULL)
    return run


def measure(source: Path, run: Path) -> tuple[float, float]:
    """(seconds, peak RSS MB) of one ``guideway process RUN``."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(guideway(source, "process", str(run)), stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode() if proc.stderr else ""
    if proc.returncode != 0:
        raise SystemExit(f"guideway process {run} exited {proc.returncode}: {err.strip()}")
    return seconds, usage.ru_maxrss / 1024.0  # Linux: KiB


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--sizes", default="200,10000,100000")
    ap.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()) / "guideway-bench-process")
    ap.add_argument("--source", type=Path, default=ROOT, help="checkout whose code is measured (default: this one)")
    args = ap.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    print(f"code: {args.source.resolve()}; runs in {args.work}")
    print(f"{'stations':>9} {'trials':>7} {'median s':>9} {'min s':>7} {'max s':>7} {'peak RSS MB':>12}")
    worst = 0.0
    for n in (int(s) for s in args.sizes.split(",")):
        run = make_run(n, args.work)
        rs = [measure(args.source, run) for _ in range(args.runs)]
        ts = [r[0] for r in rs]
        peak = max(r[1] for r in rs)
        worst = max(worst, peak)
        trials = max(1000, min(10_000, 2_000_000 // n))  # saved_runs.evaluation.straightness.default_mc_trials
        print(f"{n:>9} {trials:>7} {statistics.median(ts):>9.2f} {min(ts):>7.2f} {max(ts):>7.2f} {peak:>12.0f}")
    print(f"largest peak RSS {worst:.0f} MB (limit {LIMIT_MB:.0f} MB, ratio {worst / LIMIT_MB:.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
