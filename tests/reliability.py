"""Trials of the reliability promises with real processes (docs/reliability.md): a run killed with SIGKILL
and resumed, and several writers started on the same run.  The default suite runs a few trials
(tests/test_one_writer.py, tests/test_kill_resume.py); the soak suite (``-m soak``,
tests/test_reliability_soak.py) repeats them many times and reports the counts."""

from __future__ import annotations

import contextlib
import random
import subprocess
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from saved_runs.store.reader import load_run

from .cli import ROOT, guideway, kill_when, spawn
from .setups import replace_once, straightness_setup_text
from .waiting import line_count, wait_for

COMMON = ("--simulate", "--auto", "--no-noise", "--seed", "5")
MANUAL = ("--simulate", "--no-noise", "--seed", "5")  # the terminal operator: Enter captures a station
KINDS = ("straightness", "return-pass", "positioning")
# the columns a noise-free simulated point has whenever it is taken (the air, and a positioning axis's
# thermal drift, change with the time of the capture)
STRAIGHTNESS_MEASURED = ["station", "pass", "x_mm", "lin_um", "stry_um", "strz_um", "pitch_urad", "yaw_urad",
                         "roll_urad", "sensor_mm"]
MEASURED = {"straightness": STRAIGHTNESS_MEASURED, "return-pass": STRAIGHTNESS_MEASURED,
            "positioning": ["run", "direction", "target_index", "target_mm"]}
STATIONS = 12  # straightness trials: 12 stations (24 steps with the return pass)
LONG_STATIONS = 80  # two-writer trials: long enough (about 5 s) that the second writer meets the first at work


def setup_text(kind: str, stations: int = STATIONS) -> str:
    """The set-up of a trial run of ``kind`` (straightness, return-pass, positioning)."""
    if kind == "positioning":
        text = (ROOT / "docs" / "setup-positioning.toml").read_text()
        text = replace_once(text, "end_mm = 1000.0", "end_mm = 400.0")
        return replace_once(text, "runs = 5 ", "runs = 2 ")  # 5 targets x 2 runs x 2 directions = 20 stops
    return straightness_setup_text(stations=stations, return_pass=kind == "return-pass")


def step_keys(kind: str, run_dir: Path) -> list[tuple[int, ...]]:
    """The identity of each point on disk, in file order: (pass, station) or (run, direction, target)."""
    pts = load_run(run_dir).points
    if kind == "positioning":
        return list(zip(pts["run"], pts["direction"], pts["target_index"], strict=True))
    return list(zip(pts["pass"], pts["station"], strict=True))


@dataclass(frozen=True)
class Counts:
    """A trial's outcome against the uninterrupted run: points lost, points duplicated, values changed."""

    lost: int
    duplicated: int
    changed: int

    def __add__(self, other: Counts) -> Counts:
        return Counts(self.lost + other.lost, self.duplicated + other.duplicated, self.changed + other.changed)


def compare(kind: str, run_dir: Path, reference: Path) -> Counts:
    """Lost and duplicated points of ``run_dir`` against ``reference`` (each step once), and the number of
    points whose measured values differ from the reference (noise-free simulation: none may; the columns
    that do not depend on when the point was taken)."""
    got, want = Counter(step_keys(kind, run_dir)), Counter(step_keys(kind, reference))
    lost = sum((want - got).values())
    duplicated = sum(n - 1 for n in got.values() if n > 1) + sum(n for k, n in got.items() if k not in want)
    a, b = load_run(run_dir).points, load_run(reference).points
    measured = MEASURED[kind]
    changed = len(a) if len(a) != len(b) else int((~(a[measured] == b[measured]).all(axis=1)).sum())
    return Counts(lost, duplicated, changed)


def reference_run(kind: str, base: Path, stations: int = STATIONS) -> tuple[Path, Path]:
    """The set-up file of ``kind`` (straightness: ``stations``) and the run it gives when never interrupted."""
    setup = base / f"{kind}.toml"
    setup.write_text(setup_text(kind, stations))
    ref = base / f"{kind}-ref"
    res = guideway("acquire", acquire_kind(kind), "--setup", setup, "--out", ref, *COMMON)
    assert res.returncode == 0, res.stderr
    return setup, ref


def acquire_kind(kind: str) -> str:
    return "positioning" if kind == "positioning" else "straightness"


def kill_at(run_dir: Path, points: int, args: list[str | Path], work: Path) -> bool:
    """Start ``guideway ARGS`` writing ``run_dir`` and SIGKILL it once ``points`` points are on disk.
    True if it was killed part way; False if it had ended its run before the kill landed."""
    proc = spawn(*args, tmp_dir=work / "tmp", stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: line_count(run_dir / "points.csv") > points or proc.poll() is not None, timeout_s=90,
                 what=f"{points} points")
    finally:
        proc.kill()
        proc.wait()
    assert line_count(run_dir / "points.csv") > points, f"the writer ended (exit {proc.returncode}) first"
    return load_run(run_dir).meta.get("status") != "complete"


def kill_resume_trial(kind: str, setup: Path, reference: Path, work: Path, seed: int) -> tuple[Counts, bool]:
    """``guideway acquire`` killed with SIGKILL after a random number of points, then ``--resume``; the
    counts of the resumed run against the uninterrupted one, and whether the kill landed part way."""
    steps = len(load_run(reference).points)
    # points on disk before the kill: anywhere in the first three quarters (a kill later than that often
    # lands after the end of a run this short)
    kill_after = random.Random(seed).randrange(1, steps * 3 // 4)
    run_dir = work / "killed"
    killed = kill_at(run_dir, kill_after, ["acquire", acquire_kind(kind), "--setup", setup, "--out", run_dir,
                                           *COMMON], work)
    if killed:
        res = guideway("acquire", "--resume", run_dir, *COMMON)
        assert res.returncode == 0, res.stderr
    assert load_run(run_dir).meta["status"] == "complete"
    return compare(kind, run_dir, reference), killed


def points_on_disk(run_dir: Path) -> int:
    return max(line_count(run_dir / "points.csv") - 1, 0)


def prefix_counts(kind: str, run_dir: Path, reference: Path) -> Counts:
    """A run stopped part way against the uninterrupted one: its points must be the reference's first
    points, each once, with the same values (lost = reference points before its last one that it lacks)."""
    got = step_keys(kind, run_dir)
    want = step_keys(kind, reference)
    duplicated = len(got) - len(set(got)) + sum(1 for k in set(got) if k not in want)
    last = max((want.index(k) for k in got if k in want), default=-1)
    lost = sum(1 for k in want[: last + 1] if k not in set(got))
    a, b = load_run(run_dir).points, load_run(reference).points
    measured = MEASURED[kind]
    n = min(len(a), len(b))
    changed = int((~(a[measured].iloc[:n].reset_index(drop=True) == b[measured].iloc[:n].reset_index(drop=True))
                   .all(axis=1)).sum())
    return Counts(lost, duplicated, changed)


@dataclass(frozen=True)
class Refusal:
    """Two writers on one run: which was refused (its stderr) and the pid of the one that went on."""

    stderr: str
    holder_pid: int
    loser: int  # 0: the first started, 1: the second


def _end(proc: subprocess.Popen[str]) -> None:
    """Kill ``proc`` if it still runs and close its pipes."""
    if proc.poll() is None:
        proc.kill()
    for f in (proc.stdin, proc.stdout, proc.stderr):
        if f is not None and not f.closed:
            with contextlib.suppress(OSError):
                f.close()
    proc.wait()


def two_writers_trial(first: list[str | Path], second: list[str | Path], work: Path, *,
                      run_dir: Path, first_points: int = 0, winner_points: int = 3) -> Refusal:
    """Two ``guideway acquire`` writers (terminal operator: each waits for Enter at every station, so a
    writer holds the run as long as the test wants) on the run ``run_dir``.

    ``first_points`` 0: both start together; else the second starts once the first has written that
    many points (and waits for the next Enter).  One must be refused (exit 2) while the other waits at a
    prompt; the other then captures ``winner_points`` more stations and is ended by the end of its input.
    """
    kw = {"stdin": subprocess.PIPE, "stdout": subprocess.DEVNULL, "stderr": subprocess.PIPE}
    procs: list[subprocess.Popen[str]] = []
    try:
        procs.append(spawn(*first, tmp_dir=work / "tmp0", **kw))
        if first_points:
            assert procs[0].stdin is not None
            procs[0].stdin.write("\n" * first_points)
            procs[0].stdin.flush()
            wait_for(lambda: points_on_disk(run_dir) >= first_points or procs[0].poll() is not None,
                     timeout_s=60, what=f"{first_points} points of the first writer")
            assert procs[0].poll() is None, "the first writer ended before the second was started"
        procs.append(spawn(*second, tmp_dir=work / "tmp1", **kw))
        wait_for(lambda: any(p.poll() is not None for p in procs), timeout_s=60,
                 what="one of the two writers to be refused")
        loser = 0 if procs[0].poll() is not None else 1
        winner = procs[1 - loser]
        err = procs[loser].communicate(timeout=30)[1]
        assert procs[loser].returncode == 2, f"exit {procs[loser].returncode}: {err}"
        assert winner.poll() is None, "both writers ended; the trial proves nothing"
        # a few more stations, then the end of its input aborts the run (the points are kept)
        winner_err = winner.communicate("\n" * winner_points, timeout=60)[1]
        assert winner.returncode == 1 and "aborted" in winner_err, winner_err  # ended at the end of its input
        return Refusal(err, winner.pid, loser)
    finally:
        for p in procs:
            _end(p)


def partial_run(kind: str, setup: Path, work: Path, points: int) -> Path:
    """A run of ``kind`` killed with SIGKILL after ``points`` points (to be resumed)."""
    run_dir = work / "partial"
    kill_when(lambda: line_count(run_dir / "points.csv") > points, "acquire", acquire_kind(kind), "--setup", setup,
              "--out", run_dir, *COMMON, tmp_dir=work / "tmp", what=f"{points} points")
    return run_dir
