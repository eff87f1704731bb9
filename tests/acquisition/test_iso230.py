"""ISO 230-2 targets and cycles (standards.md 1.4) and the part programs that
run them, checked against the standard's rules and by reading the program back."""

from __future__ import annotations

import math
import re

import pytest

from acquisition.gcode import part_program
from acquisition.setup.cycles import Stop, linear_cycle, linear_targets, rotary_targets, step_cycle
from acquisition.setup.positioning import PositioningSetup, TriggerSetup
from saved_runs.errors import SetupError


@pytest.mark.parametrize(("start", "end", "count"), [(0.0, 1000.0, 5), (0.0, 1200.0, 6), (0.0, 300.0, 5),
                                                      (-50.0, 1950.0, 10), (0.0, 3000.0, 13)])
def test_linear_target_count(start: float, end: float, count: int) -> None:
    # <= 2000 mm: at least five per metre and five in total; above: about every 250 mm
    t = linear_targets(start, end, seed=1)
    assert len(t) == count
    if end - start <= 2000:
        assert len(t) >= 5 * (end - start) / 1000 and len(t) >= 5


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_linear_targets_are_irregular_and_inside_the_travel(seed: int) -> None:
    start, end = 100.0, 1300.0
    t = linear_targets(start, end, seed=seed)
    m = len(t)
    p = (end - start) / (m - 1)
    r = [t[i] - (start + i * p) for i in range(m)]
    assert all(b > a for a, b in zip(t, t[1:], strict=False))
    assert start <= t[0] and t[-1] <= end
    assert max(abs(x) for x in r) <= 0.3 * p + 1e-9
    assert len({round(x, 3) for x in r}) == m  # a different offset at every target
    assert abs(t[0] - start) <= 0.02 * p + 1e-9 and abs(end - t[-1]) <= 0.02 * p + 1e-9
    assert linear_targets(start, end, seed=seed) == t  # same seed, same targets


def test_rotary_targets_include_the_principal_positions() -> None:
    t = rotary_targets(0.0, 360.0, seed=4, per_rev=8)
    assert {0.0, 90.0, 180.0, 270.0} <= set(t) and 360.0 not in t
    assert len(t) >= 8 and all(0 <= x < 360 for x in t)
    intermediate = [x for x in t if x % 90]
    assert len({round(x % 90, 3) for x in intermediate}) == len(intermediate)  # irregular
    part = rotary_targets(0.0, 180.0, per_rev=12)
    assert {0.0, 90.0, 180.0} <= set(part) and len(part) >= 6


def test_bad_ranges() -> None:
    with pytest.raises(SetupError, match="end_mm > start_mm"):
        linear_targets(10.0, 10.0)
    with pytest.raises(SetupError, match="rotary axis range"):
        rotary_targets(0.0, 400.0)


def test_linear_cycle_is_the_standard_cycle() -> None:
    t = (0.0, 10.0, 20.0)
    assert linear_cycle(t, 2, 1.0) == [
        Stop(-1.0, 0, 1, 1), Stop(0.0, 1, 1, 1), Stop(10.0, 2, 1, 1), Stop(20.0, 3, 1, 1),
        Stop(21.0, 0, 1, -1), Stop(20.0, 3, 1, -1), Stop(10.0, 2, 1, -1), Stop(0.0, 1, 1, -1),
        Stop(-1.0, 0, 2, 1), Stop(0.0, 1, 2, 1), Stop(10.0, 2, 2, 1), Stop(20.0, 3, 2, 1),
        Stop(21.0, 0, 2, -1), Stop(20.0, 3, 2, -1), Stop(10.0, 2, 2, -1), Stop(0.0, 1, 2, -1),
    ]


@pytest.mark.parametrize("make", [linear_cycle, step_cycle])
def test_every_approach_is_genuine_and_complete(make) -> None:
    t = linear_targets(0.0, 800.0, seed=3)
    stops = make(t, 5, 5.0)
    for prev, s in zip(stops, stops[1:], strict=False):
        if s.target_index:  # approached from the stated direction
            assert (s.position - prev.position) * s.direction > 0
    measured = [(s.target_index, s.run, s.direction) for s in stops if s.target_index]
    assert sorted(measured) == sorted((i, j, d) for i in range(1, len(t) + 1) for j in range(1, 6) for d in (1, -1))
    assert min(s.position for s in stops) == t[0] - 5.0 and max(s.position for s in stops) == t[-1] + 5.0


def test_step_cycle_finishes_a_target_before_the_next() -> None:
    stops = [s for s in step_cycle((0.0, 10.0), 2, 1.0) if s.target_index]
    assert [(s.target_index, s.run, s.direction) for s in stops] == [
        (1, 1, 1), (1, 1, -1), (1, 2, 1), (1, 2, -1), (2, 1, 1), (2, 1, -1), (2, 2, 1), (2, 2, -1)]


def setup(mode: str = "in-position", dialect: str = "fanuc", cycle: str = "linear") -> PositioningSetup:
    return PositioningSetup(axis_name="X", axis_type="linear", targets=(0.0, 250.5, 498.25, 750.0, 1000.0),
                            runs=2, cycle=cycle, overrun=5.0, feed_per_min=3000.0,
                            trigger=TriggerSetup(mode=mode, dwell_s=1.5), dialect=dialect)


def moves(program: str) -> list[float]:
    """The X positions of every G01 move, read back from the program text."""
    return [float(m) for m in re.findall(r"G0?1 X(-?[\d.]+)", program)]


@pytest.mark.parametrize("dialect", ["fanuc", "linuxcnc"])
@pytest.mark.parametrize("cycle", ["linear", "step"])
def test_program_runs_exactly_the_cycle(dialect: str, cycle: str) -> None:
    s = setup(dialect=dialect, cycle=cycle)
    prog = part_program(s)
    assert moves(prog) == [st.position for st in s.stops()]
    n = len(s.measured_stops())
    assert re.findall(r"^N(\d+) ", prog, re.M) == [str(k) for k in range(1, n + 1)]
    if dialect == "fanuc":
        lines = prog.splitlines()
        assert lines[0] == "%" and lines[1].startswith("O1000") and lines[-2:] == ["M30", "%"]
        assert prog.count("G04 X1.5") == n and prog.count("M100") == n
        assert "F3000.0" in prog.splitlines()[4]
    else:
        assert prog.rstrip().endswith("M2") and prog.count("G4 P1.5") == n
        assert prog.count("M64 P0") == n and prog.count("M66 P0 L3") == n
    first_target = s.measured_stops()[0]
    assert f"#500={first_target.target_index}" in prog or f"M68 E0 Q{first_target.target_index}" in prog


@pytest.mark.parametrize(("mode", "present", "absent"),
                         [("manual", "M00", "M100"), ("stability", "G04", "M00")])
def test_program_hand_over_per_trigger_mode(mode: str, present: str, absent: str) -> None:
    prog = part_program(setup(mode))
    assert present in prog and absent not in prog
    assert math.isclose(prog.count(present), len(setup(mode).measured_stops()))
