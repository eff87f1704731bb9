"""Long command-line work shows its progress on a terminal, and nothing else changes (issue 25).

Each command runs as a separate process (tests/cli.py ``spawn``) with stderr on a pseudo-terminal
(os.openpty): the progress display (rich.progress: the stage's description, done/total) appears there.
With stderr a pipe, or with ``--json``, the command writes what it writes without a display: no
escape sequence, no stage text, and its stdout is byte for byte the stdout of the run on a terminal
(the display never touches a piped stdout).
"""

from __future__ import annotations

import fcntl
import os
import re
import select
import struct
import subprocess
import termios
from pathlib import Path

import pytest

from .cli import ROOT, spawn

EXAMPLE_MACHINE = ROOT / "docs" / "machine-example.toml"
ESC = b"\x1b"


def on_terminal(*args: str | os.PathLike[str], tmp_dir: Path, timeout_s: float = 120.0) -> tuple[int, bytes, bytes]:
    """(exit code, stdout, what reached the terminal) of ``guideway ARGS`` with stderr on a pty, stdout a pipe."""
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 160, 0, 0))  # 24 x 160 characters
    try:
        proc = spawn(*args, tmp_dir=tmp_dir, stdout=subprocess.PIPE, stderr=slave)
    finally:
        os.close(slave)
    screen = b""
    with proc:
        try:
            while True:  # read the terminal until the child closes it (a full pty would block its writes)
                ready, _, _ = select.select([master], [], [], timeout_s)
                assert ready, f"guideway {args[0]}: no output for {timeout_s} s"
                try:
                    chunk = os.read(master, 1 << 16)
                except OSError:  # EIO: the child's end is closed
                    chunk = b""
                if not chunk:
                    break
                screen += chunk
            out = proc.stdout.read().encode() if proc.stdout else b""
            proc.wait(timeout=timeout_s)
        finally:
            os.close(master)
            if proc.poll() is None:
                proc.kill()
    return proc.returncode, out, screen


def piped(*args: str | os.PathLike[str], tmp_dir: Path) -> tuple[int, bytes, bytes]:
    with spawn(*args, tmp_dir=tmp_dir, stdout=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
        out, err = proc.communicate(timeout=120)
    return proc.returncode, out.encode(), err.encode()


def text_of(screen: bytes) -> str:
    """The terminal's bytes without escape sequences and carriage returns."""
    return re.sub(rb"\x1b\[[0-9;?]*[A-Za-z]", b"", screen).replace(b"\r", b"\n").decode("utf-8", "replace")


@pytest.fixture(autouse=True)
def _terminal_type(monkeypatch: pytest.MonkeyPatch) -> None:
    # a terminal that draws (rich draws nothing live on TERM=dumb or unknown)
    monkeypatch.setenv("TERM", "xterm-256color")
    monkeypatch.setenv("COLUMNS", "160")  # rich would take the width of the test runner's own terminal first
    monkeypatch.delenv("NO_COLOR", raising=False)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three simulated straightness runs of one machine and axis (docs/scenario-straightness.toml)."""
    folder = tmp_path_factory.mktemp("runs")
    for seed in (1, 2, 3):
        code, _, err = piped("simulate", ROOT / "docs" / "scenario-straightness.toml", "--seed", str(seed),
                             "--out", folder / f"run{seed}", tmp_dir=folder / "tmp")
        assert code == 0, err
    return folder


def test_process_shows_its_monte_carlo_trials_on_a_terminal(runs: Path, tmp_path: Path) -> None:
    code, out, screen = on_terminal("process", runs / "run1", tmp_dir=tmp_path)
    assert code == 0, screen
    shown = text_of(screen)
    # the default trials for 16 x 2 points: 10 000 (saved_runs/evaluation/straightness.py, MC_TRIALS)
    assert "(Monte Carlo trials)" in shown and "10000/10000" in shown, shown
    assert "writing results" in shown, shown
    code2, out2, err2 = piped("process", runs / "run1", tmp_dir=tmp_path)
    assert code2 == 0 and out2 == out and err2 == b""
    assert b"results written to" in out


def test_process_json_on_a_terminal_draws_nothing(runs: Path, tmp_path: Path) -> None:
    code, out, screen = on_terminal("process", runs / "run1", "--json", "--no-write", tmp_dir=tmp_path)
    assert code == 0 and screen == b"", screen
    assert piped("process", runs / "run1", "--json", "--no-write", tmp_dir=tmp_path) == (0, out, b"")


def test_diagnose_shows_earlier_runs_and_channels(runs: Path, tmp_path: Path) -> None:
    args = ("diagnose", runs / "run1", "--noise-from", runs / "run2", runs / "run3")
    code, out, screen = on_terminal(*args, tmp_dir=tmp_path)
    assert code == 0, screen
    shown = text_of(screen)
    assert "2 earlier run(s), then each channel" in shown, shown
    # a straightness run has two channels (height and lin, docs/diagnosis.md): 2 earlier runs + 2 channels
    assert "4/4" in shown, shown
    code2, out2, err2 = piped(*args, tmp_dir=tmp_path)
    assert code2 == 0 and out2 == out and ESC not in err2 and b"each channel" not in err2
    code3, out3, screen3 = on_terminal(*args, "--json", tmp_dir=tmp_path)
    assert code3 == 0 and ESC not in screen3 and b"each channel" not in screen3
    assert out3 == piped(*args, "--json", tmp_dir=tmp_path)[1]


def test_catalog_scan_shows_the_runs_added(runs: Path, tmp_path: Path) -> None:
    shown_cat, piped_cat = tmp_path / "a.db", tmp_path / "b.db"
    code, out, screen = on_terminal("catalog", "add", "--scan", runs, "--catalog", f"sqlite:///{shown_cat}",
                                    tmp_dir=tmp_path)
    assert code == 0, screen
    shown = text_of(screen)
    assert f"scanning {runs.name}" in shown and "adding 3 run(s)" in shown and "3/3" in shown, shown
    code2, out2, err2 = piped("catalog", "add", "--scan", runs, "--catalog", f"sqlite:///{piped_cat}",
                              tmp_dir=tmp_path)
    assert code2 == 0 and err2 == b""
    assert out2.replace(str(piped_cat).encode(), b"CAT") == out.replace(str(shown_cat).encode(), b"CAT")
    assert out.count(b"added: ") == 3


def test_volumetric_grid_shows_its_files(tmp_path: Path) -> None:
    code, out, screen = on_terminal("volumetric", EXAMPLE_MACHINE, "--out", tmp_path / "a", "--grid", "4",
                                    tmp_dir=tmp_path)
    assert code == 0, screen
    shown = text_of(screen)
    assert "evaluating 64 poses" in shown and "4/4" in shown, shown  # 4 per axis over X, Y, Z; 4 files
    code2, out2, err2 = piped("volumetric", EXAMPLE_MACHINE, "--out", tmp_path / "b", "--grid", "4", tmp_dir=tmp_path)
    assert code2 == 0 and ESC not in err2 and b"poses" not in err2
    assert out2.replace(b"/b", b"/X") == out.replace(b"/a", b"/X")


# -- the callbacks below the front end: counts rise to their total, and the results do not change -----------
def test_monte_carlo_progress_counts_every_trial_and_changes_nothing(runs: Path) -> None:
    from saved_runs.evaluation.evaluate import process_run_dir

    seen: list[tuple[int, int]] = []
    _, quiet = process_run_dir(runs / "run1", mc_trials=3000)
    _, counted = process_run_dir(runs / "run1", mc_trials=3000, progress=lambda d, t: seen.append((d, t)))
    assert seen and seen[-1] == (3000, 3000) and all(t == 3000 for _, t in seen)
    assert [d for d, _ in seen] == sorted({d for d, _ in seen})  # strictly rising
    assert counted.to_dict() == quiet.to_dict()


def test_diagnose_progress_counts_earlier_runs_then_channels(runs: Path) -> None:
    from saved_runs.diagnosis.diagnose import diagnose_run

    seen: list[tuple[int, int]] = []
    quiet = diagnose_run(runs / "run1", noise_from=[runs / "run2"])
    counted = diagnose_run(runs / "run1", noise_from=[runs / "run2"], progress=lambda d, t: seen.append((d, t)))
    # 1 earlier run + the height and lin channels = 3 steps, each counted once, from 0
    assert seen == [(0, 3), (1, 3), (2, 3), (3, 3)]
    assert counted.to_dict() == quiet.to_dict()


def test_catalog_progress_counts_the_runs(runs: Path, tmp_path: Path) -> None:
    from fleet.catalog.database import open_catalog
    from fleet.catalog.runs import add_runs, scan_run_dirs

    seen: list[tuple[int, int]] = []
    with open_catalog(f"sqlite:///{tmp_path / 'c.db'}", create=True) as cat:
        outcomes = list(add_runs(cat, scan_run_dirs(runs), progress=lambda d, t: seen.append((d, t))))
    assert [o.action for o in outcomes] == ["added"] * 3
    assert seen == [(0, 3), (1, 3), (2, 3), (3, 3)]
