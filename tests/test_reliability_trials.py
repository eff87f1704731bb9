"""Nothing lost, one writer per run, repeated (docs/reliability.md, "Soak figures").

``guideway acquire`` killed with SIGKILL after a random number of points and resumed must give every
planned point exactly once, with the values of the run that was never interrupted (noise-free
simulation), for each run kind: straightness, straightness with the return pass, positioning.  Two
writers started on the same run must end with one refused and the other's points intact.

The default suite runs one trial of each; ``./scripts/test -m soak`` runs ``SOAK_KILLS`` kill/resume
trials per run kind and ``SOAK_WRITERS`` trials of each two-writer case, and prints the counts
(``GUIDEWAY_SOAK_KILLS`` / ``GUIDEWAY_SOAK_WRITERS`` change them).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from .reliability import (
    KINDS,
    MANUAL,
    Counts,
    kill_resume_trial,
    partial_run,
    prefix_counts,
    two_writers_trial,
)

SOAK_KILLS = int(os.environ.get("GUIDEWAY_SOAK_KILLS", "50"))
SOAK_WRITERS = int(os.environ.get("GUIDEWAY_SOAK_WRITERS", "20"))
NOTHING = Counts(0, 0, 0)
SOAK_TIMEOUT_S = 3600  # one soak test: many trials of a few seconds each (the default per-test limit is 120 s)


def report(capsys: pytest.CaptureFixture[str], line: str) -> None:
    """A soak figure, shown whatever pytest captures (docs/reliability.md quotes these lines)."""
    with capsys.disabled():
        print(f"\n[soak] {line}", flush=True)


@pytest.mark.parametrize("kind", ["straightness", "positioning"])  # the return pass: test_acquire_simulated.py
def test_killed_and_resumed_run_loses_and_repeats_nothing(tmp_path: Path, kind: str,
                                                          reliability_references: dict[str, tuple[Path, Path]]) -> None:
    setup, ref = reliability_references[kind]
    counts, killed = kill_resume_trial(kind, setup, ref, tmp_path, seed=7)
    assert killed and counts == NOTHING


@pytest.mark.soak
@pytest.mark.timeout(SOAK_TIMEOUT_S)
@pytest.mark.parametrize("kind", KINDS)
def test_kill_resume_soak(tmp_path: Path, kind: str, capsys: pytest.CaptureFixture[str],
                          reliability_references: dict[str, tuple[Path, Path]]) -> None:
    setup, ref = reliability_references[kind]
    total = NOTHING
    bad = []
    kills = trials = 0
    while kills < SOAK_KILLS and trials < 2 * SOAK_KILLS:  # SOAK_KILLS runs killed part way and resumed
        work = tmp_path / f"trial{trials}"
        counts, killed = kill_resume_trial(kind, setup, ref, work, seed=1000 + trials)
        trials += 1
        kills += killed
        if counts != NOTHING:
            bad.append((trials, counts))
        total += counts
        shutil.rmtree(work, ignore_errors=True)
    report(capsys, f"kill -9 / resume, {kind}: {kills} runs killed part way and resumed ({trials - kills} more ended "
           f"before the kill landed); points lost {total.lost}, duplicated {total.duplicated}, values changed "
           f"{total.changed}")
    assert total == NOTHING, bad
    assert kills == SOAK_KILLS


WRITER_CASES = ("two resumes", "resume while running", "race for a new --out")


def writer_trial(case: str, setup: Path, ref: Path, work: Path) -> Counts:
    """One two-writer trial of ``case``: one writer refused at once, the other's points intact."""
    if case == "two resumes":
        run_dir = partial_run("straightness", setup, work, points=2)
        args = ["acquire", "--resume", run_dir, *MANUAL]
        refusal = two_writers_trial(args, args, work, run_dir=run_dir)
    elif case == "resume while running":
        run_dir = work / "run"
        refusal = two_writers_trial(["acquire", "straightness", "--setup", setup, "--out", run_dir, *MANUAL],
                                    ["acquire", "--resume", run_dir, *MANUAL], work, run_dir=run_dir, first_points=3)
    else:
        run_dir = work / "new"
        args = ["acquire", "straightness", "--setup", setup, "--out", run_dir, *MANUAL]
        refusal = two_writers_trial(args, args, work, run_dir=run_dir)
    assert "is in use" in refusal.stderr and f"pid {refusal.holder_pid} " in refusal.stderr, refusal.stderr
    assert "--resume" not in refusal.stderr and "continue with" not in refusal.stderr
    return prefix_counts("straightness", run_dir, ref)


@pytest.mark.soak
@pytest.mark.timeout(SOAK_TIMEOUT_S)
@pytest.mark.parametrize("case", WRITER_CASES)
def test_two_writers_soak(tmp_path: Path, case: str, capsys: pytest.CaptureFixture[str],
                          reliability_references: dict[str, tuple[Path, Path]]) -> None:
    setup, ref = reliability_references["straightness"]
    total = NOTHING
    for i in range(SOAK_WRITERS):
        work = tmp_path / f"trial{i}"
        total += writer_trial(case, setup, ref, work)  # fails at once if the second writer was not refused
        shutil.rmtree(work, ignore_errors=True)
    report(capsys, f"two writers, {case}: {SOAK_WRITERS} trials, second writer refused in {SOAK_WRITERS}; points lost "
           f"{total.lost}, duplicated {total.duplicated}, values changed {total.changed}")
    assert total == NOTHING
