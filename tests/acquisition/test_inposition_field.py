"""Positioning triggers against machines that behave like real ones (issue 9, "In-position"):

* PLC bits an earlier cycle left set (*in position*, *cycle finished*) do not end or start a new run;
* the stability trigger never attaches a reading to the wrong stop (the other approach of the same
  target, or a stop it missed), and refuses cycles it cannot follow;
* the generated part programs stop with a message when the in-position wait times out.
"""

from __future__ import annotations

import contextlib
import io
import re
from typing import Any

import pytest

from acquisition import messages as m
from acquisition.acquire import SimOptions, run_positioning
from acquisition.gcode import part_program
from acquisition.inposition import DONE, IN_POSITION, RUNNING, InPositionEvent, WaitInPosition, wait_in_position
from acquisition.operators import AutoOperator
from acquisition.plans.positioning import positioning_plan
from acquisition.setup.positioning import TriggerSetup, positioning_setup_from_dict
from drivers.interferometer import load_register_map
from saved_runs.errors import SetupError
from saved_runs.store.reader import load_run

from .plan_driver import Scripted, drive
from .test_positioning_workflow import example, ifm, psetup


# -- the wait handler against scripted PLC registers ----------------------------------------------------
class PLC:
    """Registers 200-204 from a script (the last entry repeats): (status bits, target, run, direction, count)."""

    def __init__(self, script: list[tuple[int, int, int, int, int]]) -> None:
        self.script = list(script)
        self.map = load_register_map()

    def read_registers(self, address: int, count: int) -> list[int]:
        assert (address, count) == self.map.span("inpos_status", "inpos_count")
        status, target, run, direction, n = self.script.pop(0) if len(self.script) > 1 else self.script[0]
        return [status, target, run, direction & 0xFFFF, n]


class Engine:
    abort_requested = False

    def __init__(self, plc: PLC) -> None:
        self.rig = type("R", (), {"controller": plc})()

    def idle(self) -> contextlib.AbstractContextManager[None]:  # no live reader shares this rig
        return contextlib.nullcontext()


def wait(script: list[tuple[int, int, int, int, int]], last_count: int = -1, armed: bool = False,
         timeout_s: float = 0.05) -> InPositionEvent | None:
    return wait_in_position(Engine(PLC(script)), WaitInPosition(last_count, timeout_s, poll_s=0.001,  # type: ignore[arg-type]
                                                                armed=armed))


def test_a_cycle_finished_bit_from_an_earlier_cycle_does_not_end_the_wait() -> None:
    ev = wait([(DONE, 0, 0, 0, 9)])
    assert ev is not None and ev.timed_out and not ev.cycle_done and not ev.armed


def test_cycle_finished_ends_the_wait_once_this_cycle_was_seen_running() -> None:
    ev = wait([(DONE, 0, 0, 0, 9), (RUNNING, 0, 0, 0, 9), (DONE, 0, 0, 0, 9)])
    assert ev is not None and ev.cycle_done
    assert wait([(DONE, 0, 0, 0, 9)], armed=True).cycle_done  # armed by an earlier wait of this run


def test_an_in_position_event_left_from_an_earlier_cycle_is_not_new_until_the_bit_was_clear() -> None:
    left = (IN_POSITION | DONE, 5, 5, -1, 57)
    ev = wait([left], last_count=57)
    assert ev is not None and ev.timed_out
    # the PLC clears b0 when the new program starts, then reports target 1 - with a counter it reset to 57
    ev = wait([left, (RUNNING, 0, 0, 0, 57), (IN_POSITION | RUNNING, 1, 1, 1, 57)], last_count=57)
    assert ev is not None and (ev.target_index, ev.run, ev.direction, ev.count) == (1, 1, 1, 57)


def test_a_run_ignores_the_bits_an_earlier_cycle_left_and_completes(tmp_path) -> None:
    # the PLC left in position (counter 57, the last stop) and cycle finished set; the program reaches
    # its first block 0.3 s after Cycle Start
    src = example(axis={"end_mm": 200.0, "runs": 1},
                  simulation={"plc_bits_left_set": True, "program_start_s": 0.3})
    s = positioning_setup_from_dict(src)
    stream = io.StringIO()
    op = AutoOperator(log_to=stream)
    res = run_positioning(s, tmp_path / "run", simulate=SimOptions(seed=1, noise=False), operator=op,
                          stream=stream)
    assert res.outcome.exit_status == "success", res.outcome.reason
    # nothing to ask: the stale event was not taken for a target, the stale b2 not for the end
    assert not [t for t in op.transcript if "Acknowledge it without capturing" in t or "No in-position" in t]
    pts = load_run(tmp_path / "run").points
    assert len(pts) == 2 * len(s.targets)
    assert pts[["target_index", "direction"]].to_numpy().tolist() == [
        [st.target_index, st.direction] for st in s.measured_stops()]
    text = stream.getvalue()
    assert "in-position bit left set by an earlier cycle (counter 57, target 1); ignored" in text
    assert "cycle-finished bit left set by an earlier cycle; ignored until this cycle runs" in text


# -- stability trigger ----------------------------------------------------------------------------------
def stability_setup():
    # stops: 95 (overrun), 100 (1 +), 150 (2 +), 155 (overrun), 150 (2 -), 100 (1 -)
    return psetup("stability", targets=(100.0, 150.0), overrun=5.0, feed_per_min=600.0,
                  trigger=TriggerSetup(mode="stability", dwell_s=1.0, stability_window=1.0, near=0.5, poll_s=0.1,
                                       timeout_s=30.0))


def run_script(positions: list[float]) -> list[Any]:
    """Drive the stability plan with readings at ``positions`` (0.1 s apart); every message it sent."""
    readings = (ifm(x, 0.1 * (k + 1)) for k, x in enumerate(positions))
    return drive(positioning_plan(stability_setup(), {}), Scripted(readings)).msgs


def still(x: float, n: int = 7) -> list[float]:
    return [x] * n


def test_stability_waits_for_the_reversal_before_the_second_approach_of_a_target() -> None:
    msgs = run_script([0.0, 95.0, *still(100.0), 125.0, *still(150.0, 20), 155.0, *still(150.0), 125.0,
                       *still(100.0)])
    rows = [x.data for x in msgs if isinstance(x, m.Record)]
    assert [(r["target_index"], r["direction"]) for r in rows] == [(1, 1), (2, 1), (2, -1), (1, -1)]
    # the axis stood at 150 for 2 s: its + capture came from the first readings there, its - capture
    # only after the reversal beyond 155 (reading number 1 + 1 + 7 + 1 + 20 + 1 = 31 and later)
    times = [r["time_s"] for r in rows]
    assert times[1] < 1.9 and times[2] > 3.1


def test_a_missed_stop_is_skipped_not_filled_with_the_next_one() -> None:
    # the tool never sees the axis rest at 150 going up: the next readings are beyond the overrun
    msgs = run_script([0.0, 95.0, *still(100.0), 125.0, 155.0, *still(150.0), 125.0, *still(100.0)])
    rows = [x.data for x in msgs if isinstance(x, m.Record)]
    assert [(r["target_index"], r["direction"]) for r in rows] == [(1, 1), (2, -1), (1, -1)]
    asked = [x for x in msgs if isinstance(x, m.Prompt)]
    assert [p.key for p in asked] == ["mismatch"] and asked[0].fault
    assert "target 2 (150 mm), run 1 up (+)" in asked[0].text and "below, then above" in asked[0].text
    skipped = [x.value for x in msgs if isinstance(x, m.Annotate) and x.key == "skipped"][-1]
    assert [(k["target_index"], k["direction"]) for k in skipped] == [(2, 1)]


@pytest.mark.parametrize(("axis", "trigger", "message"), [
    ({"overrun_mm": 1.0}, {}, "at each reversal the axis is beyond near_mm = 0.5 for 0.03 s"),
    ({"overrun_mm": 0.4}, {}, "beyond near_mm = 0.5 for 0 s"),
    ({"targets_mm": [0.0, 0.8, 250.0, 500.0, 750.0, 1000.0], "allow_nonconforming_targets": True}, {},
     "targets 0.8 mm apart lie inside each other's near_mm = 0.5 windows"),
    ({"feed_mm_min": 300.0}, {"poll_s": 0.6}, "poll_s 0.6 s is too long for dwell_s 2 s"),
])
def test_stability_refuses_cycles_it_cannot_follow(axis: dict, trigger: dict, message: str) -> None:
    src = example(axis={"end_mm": 1000.0, **axis}, trigger={"mode": "stability", **trigger})
    with pytest.raises(SetupError) as info:
        positioning_setup_from_dict(src)
    text = str(info.value)
    assert text.startswith('setup: [trigger] mode = "stability" cannot follow this cycle: ') and message in text
    assert "\n" not in text


def test_the_documented_stability_example_is_accepted() -> None:
    s = positioning_setup_from_dict(example(trigger={"mode": "stability"}))
    assert s.stability_problem() is None


# -- part programs: the in-position wait times out ---------------------------------------------------------
def test_linuxcnc_program_stops_with_a_message_when_the_acknowledge_times_out() -> None:
    s = positioning_setup_from_dict(example(axis={"end_mm": 300.0, "runs": 2}, gcode={"dialect": "linuxcnc"},
                                            trigger={"timeout_s": 90.0}))
    lines = part_program(s).splitlines()
    waits = [i for i, ln in enumerate(lines) if ln.startswith("M66 ")]
    assert len(waits) == len(s.measured_stops())
    numbers = []
    for k, (i, st) in enumerate(zip(waits, s.measured_stops(), strict=True), start=1):
        # M66 P0 L3 Q90: wait for digital input 0 HIGH, at most 90 s (#5399 = -1 on a timeout)
        assert lines[i] == "M66 P0 L3 Q90.0" and lines[i + 1] == "M65 P0"
        m_if = re.fullmatch(r"o(\d+) if \[#5399 LT 0\]", lines[i + 2])
        assert m_if, lines[i + 2]
        numbers.append(m_if[1])
        msg = re.fullmatch(r"\(MSG, (.*)\)", lines[i + 3])
        assert msg and "(" not in msg[1] and ")" not in msg[1]  # no nested parentheses in a comment
        arrow = "+" if st.direction > 0 else "-"
        assert f"no acknowledge within 90.0 s at run {st.run} {arrow} target {st.target_index}" in msg[1]
        assert lines[i + 4] == "M2" and lines[i + 5] == f"o{m_if[1]} endif"
        assert re.match(rf"N{k} G01 X", lines[i - 6])  # the block of this stop precedes its handshake
    assert len(set(numbers)) == len(numbers)  # one O number per if-block
    # LinuxCNC rules: no comment on an O-word line, lines of at most 256 characters, the program ends
    assert all("(" not in ln for ln in lines if ln.startswith("o"))
    assert max(map(len, lines)) <= 256 and lines[-1] == "M2"


def test_fanuc_program_raises_a_macro_alarm_when_the_acknowledge_times_out() -> None:
    s = positioning_setup_from_dict(example(axis={"end_mm": 300.0, "runs": 2}))
    lines = part_program(s).splitlines()
    calls = [i for i, ln in enumerate(lines) if ln == "M100"]
    assert len(calls) == len(s.measured_stops())
    for i in calls:
        # the ladder ends M100 with UI000 (#1000) = 0 after its timeout: #3000 = 1 stops the program with
        # macro alarm 3001 and the message (at most 26 characters, upper case)
        alarm = re.fullmatch(r"IF\[#1000EQ0\]THEN#3000=1\(([A-Z0-9 -]+)\)", lines[i + 1])
        assert alarm and len(alarm[1]) <= 26, lines[i + 1]
