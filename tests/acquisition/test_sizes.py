"""Sizes beyond the documented maxima (acquisition/setup/maxima.py, docs/acquisition.md "Sizes")
are refused with one line and exit 2 before anything is allocated; plans are computed lazily."""

from __future__ import annotations

import re
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest

from acquisition.setup.cycles import cycle
from acquisition.setup.files import setup_from_dict, setup_problems
from acquisition.setup.maxima import RUNS_MAX, STATIONS_MAX, TARGETS_MAX
from acquisition.setup.straightness import StraightnessSetup
from saved_runs.errors import SetupError
from saved_runs.toml_file import read_toml

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
MEMORY_LIMIT_BYTES = 3 * 1024**3  # a process that tried to build 1e12 steps would hit this at once


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))


def guideway(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """The command line in its own process, its address space capped (a 24 GB growth fails fast)."""
    return subprocess.run([sys.executable, "-m", "tui.cli", *args], capture_output=True, text=True, timeout=120,
                          cwd=cwd, preexec_fn=_limited, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})


def one_line_exit_2(res: subprocess.CompletedProcess[str], *words: str) -> str:
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2, res.stderr[-2000:]
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr[-2000:]
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


def test_the_station_maximum_allows_the_benchmarked_run_size() -> None:
    assert STATIONS_MAX >= 100_000  # a 100,000-station run is processed in benchmarks/


def test_a_set_up_file_with_1e12_stations_is_one_line(tmp_path: Path) -> None:
    text = (DOCS / "setup-straightness.toml").read_text()
    text, n = re.subn(r"(?m)^stations = 20\b", "stations = 1000000000000", text)
    assert n == 1
    (tmp_path / "huge.toml").write_text(text)
    res = guideway("acquire", "straightness", "--setup", "huge.toml", "--out", "run", "--simulate", "--auto",
                   cwd=tmp_path)
    one_line_exit_2(res, "huge.toml", "[block] stations", "1000000000000", f"maximum of {STATIONS_MAX}")
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("value", ["1e12", "1000000000000", str(STATIONS_MAX + 1)])
def test_demo_with_too_many_stations_is_one_line(tmp_path: Path, value: str) -> None:
    t0 = time.monotonic()
    res = guideway("demo", "--stations", value, "--out", "run", cwd=tmp_path)
    one_line_exit_2(res, "--stations", f"maximum of {STATIONS_MAX}")
    assert time.monotonic() - t0 < 60 and not (tmp_path / "run").exists()


def test_demo_with_too_many_samples_is_one_line(tmp_path: Path) -> None:
    one_line_exit_2(guideway("demo", "--samples", "1e9", "--out", "run", cwd=tmp_path), "--samples", "maximum")


def test_simulate_of_a_scenario_with_1e12_stations_is_one_line(tmp_path: Path) -> None:
    text = (DOCS / "scenario-straightness.toml").read_text()
    text, n = re.subn(r"(?m)^stations = \d+", "stations = 1000000000000", text)
    assert n == 1
    (tmp_path / "scenario.toml").write_text(text)
    one_line_exit_2(guideway("simulate", "scenario.toml", "--out", "run", cwd=tmp_path), "scenario.toml",
                    "[block] stations", f"maximum of {STATIONS_MAX}")


def _straightness(**block: object) -> dict:
    source = read_toml(DOCS / "setup-straightness.toml")
    source["block"] = {k: v for k, v in source["block"].items() if k != "stations"} | block
    return source


def test_the_maximum_itself_is_taken_and_one_more_refused() -> None:
    assert setup_from_dict(_straightness(stations=STATIONS_MAX)).stations == STATIONS_MAX
    with pytest.raises(SetupError, match=r"\[block\] stations = 100001"):
        setup_from_dict(_straightness(stations=STATIONS_MAX + 1))


def test_a_travel_of_tiny_blocks_is_refused_by_the_stations_it_makes() -> None:
    source = _straightness(travel_length_mm=1000.0)
    source["block"]["length_mm"] = 1e-9  # 1e12 steps of a nanometre
    with pytest.raises(SetupError, match="stations"):
        setup_from_dict(source)


@pytest.mark.parametrize(("axis", "words"), [
    ({"end_mm": 1e12}, "end_mm - start_mm"),  # ISO 230-2 would want 4e9 targets: refused before drawing them
    ({"end_mm": 500.0, "runs": RUNS_MAX + 1}, "runs"),
    ({"targets_mm": [float(i) for i in range(TARGETS_MAX + 1)]}, "targets_mm"),
    ({"type": "rotary", "end_deg": 360.0, "targets_per_rev": 10**9}, "targets_per_rev"),
])
def test_positioning_sizes_beyond_the_maxima_are_refused(axis: dict, words: str) -> None:
    t0 = time.monotonic()
    with pytest.raises(SetupError, match="maximum") as exc:
        setup_from_dict({"kind": "positioning", "axis": axis})
    assert words in str(exc.value) and time.monotonic() - t0 < 5


def test_straightness_steps_are_computed_not_listed() -> None:
    from processing.geometry import BlockGeometry

    geo = BlockGeometry(mirror_mm=(50.0, 110.0, 0.0), sensor_mm=(150.0, 0.0, 40.0))
    for n, back in ((2, False), (5, True), (7, False)):
        steps = StraightnessSetup(block_length_mm=100.0, stations=n, geometry=geo, return_pass=back).steps()
        expected = [(0, k) for k in range(n)] + ([(1, k) for k in reversed(range(n))] if back else [])
        assert list(steps) == expected and len(steps) == len(expected)
        assert [steps.index(s) for s in expected] == list(range(len(expected)))
        assert steps[-1] == expected[-1] and steps[1:3] == expected[1:3]
    big = StraightnessSetup(block_length_mm=100.0, stations=STATIONS_MAX, geometry=geo, return_pass=True).steps()
    assert not isinstance(big, list) and sys.getsizeof(big) < 1000
    assert len(big) == 2 * STATIONS_MAX and big[STATIONS_MAX] == (1, STATIONS_MAX - 1)
    assert (1, 0) in big and (2, 0) not in big and (0, STATIONS_MAX) not in big


def test_cycles_are_computed_as_iso_230_2_describes_them() -> None:
    targets, runs, o = (0.0, 10.5, 21.0, 33.2), 3, 2.0
    # standard cycle: per run, overrun below, every target up, overrun above, every target down
    linear = []
    for j in range(1, runs + 1):
        linear.append((-o, 0, j, 1))
        linear += [(t, i, j, 1) for i, t in enumerate(targets, start=1)]
        linear.append((33.2 + o, 0, j, -1))
        linear += [(t, i, j, -1) for i, t in reversed(list(enumerate(targets, start=1)))]
    # step cycle (Annex B): at each target, every run up and down before the next target
    step = [(p, i, j, d) for i, t in enumerate(targets, start=1) for j in range(1, runs + 1)
            for p, i, j, d in ((t - o, 0, j, 1), (t, i, j, 1), (t + o, 0, j, -1), (t, i, j, -1))]
    for kind, expected in (("linear", linear), ("step", step)):
        got = [(s.position, s.target_index, s.run, s.direction) for s in cycle(kind, targets, runs, o)]
        assert got == expected
        measured = [(s.position, s.target_index, s.run, s.direction)
                    for s in cycle(kind, targets, runs, o, measured=True)]
        assert measured == [e for e in expected if e[1]]
    assert not isinstance(cycle("linear", targets, runs, o), list)


def test_every_problem_of_a_set_up_is_listed_and_acquire_still_stops_at_the_first() -> None:
    source = read_toml(DOCS / "setup-straightness.toml")
    source["block"]["stations"] = 99999999999
    source["warmup"]["window"] = 1
    source["validation"]["sensor_range_mm"] = [5.0, 1.0]
    source["colour"] = "red"
    problems = setup_problems(source, "set-up")
    assert len(problems) == 4, problems
    assert [p for p in problems if "[block] stations" in p] and [p for p in problems if "[warmup] window" in p]
    assert [p for p in problems if "sensor_range_mm" in p] and [p for p in problems if "'colour'" in p]
    with pytest.raises(SetupError) as exc:
        setup_from_dict(source, "set-up")
    assert str(exc.value) == problems[0] and "\n" not in str(exc.value)
    assert setup_problems(read_toml(DOCS / "setup-straightness.toml")) == []
