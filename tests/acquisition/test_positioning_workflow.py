"""Positioning workflow: the plan as message sequences, then complete simulated
runs (in-position, manual and stability triggers; linear and rotary) whose
readings are compared with the simulated axis and its error model."""

from __future__ import annotations

import io
import re
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from acquisition import messages as m
from acquisition.acquire import SimOptions, run_positioning
from acquisition.inposition import AcknowledgeInPosition, InPositionEvent, WaitInPosition
from acquisition.plans.positioning import positioning_plan, positioning_resume_point
from acquisition.setup.positioning import (
    PositioningSetup,
    SimulatedAxisSetup,
    TriggerSetup,
    positioning_setup_from_dict,
)
from drivers.interferometer import InterferometerController
from drivers.readings import ControllerStatus, InterferometerReading
from processing.air_index import air_index
from processing.columns import POSITIONING_LINEAR, POSITIONING_ROTARY
from saved_runs.errors import SetupError
from saved_runs.store.reader import load_run

from .plan_driver import Scripted, drive
from .sim_clock import simulated_clock

ROOT = Path(__file__).resolve().parents[2]
OK = ControllerStatus(True, False, True, False, True, 1, 0, "", 0b10101)


def ifm(position_mm: float, t: float = 0.0) -> InterferometerReading:
    return InterferometerReading(position_mm, 0.0, 0.0, 0.0, 0.0, 0.0, 20.0, 1013.0, 45.0, 20.0, 1, OK, t)


def psetup(mode: str = "in-position", **kw: Any) -> PositioningSetup:
    base: dict[str, Any] = {"axis_name": "X", "axis_type": "linear", "targets": (0.0, 100.0, 200.0), "runs": 1,
                            "overrun": 2.0, "trigger": TriggerSetup(mode=mode, dwell_s=1.0, timeout_s=5.0, poll_s=0.1)}
    return PositioningSetup(**{**base, **kw})


class Machine:
    """Scripted responder: in-position events from a list; the axis sits at the event's target."""

    def __init__(self, events: list[InPositionEvent | None], targets: tuple[float, ...], offset_mm: float = 0.001):
        self.events = list(events)
        self.targets = targets
        self.at = 0.0
        self.offset = offset_mm
        self.msgs: list[Any] = []
        self.answers: dict[str, list[str]] = {}

    def __call__(self, msg: Any) -> Any:
        self.msgs.append(msg)
        if isinstance(msg, m.OpenRun):
            return 0.0
        if isinstance(msg, WaitInPosition):
            ev = self.events.pop(0)
            if ev is not None and ev.target_index:
                self.at = self.targets[ev.target_index - 1]
            return ev
        if isinstance(msg, m.TriggerInterferometer):
            return ifm(self.at + self.offset)
        if isinstance(msg, m.Instruct | m.Prompt):
            q = self.answers.get(msg.key)
            return q.pop(0) if q else msg.choices[0]
        return None


def test_in_position_sequence_and_acknowledge() -> None:
    s = psetup()
    events = [InPositionEvent(k + 1, st.target_index, st.run, st.direction) for k, st in enumerate(s.measured_stops())]
    mach = drive(positioning_plan(s, {}), Machine(events, s.targets))
    kinds = [type(x).__name__ for x in mach.msgs if not isinstance(x, m.Log | m.Annotate)]
    per_point = ["WaitInPosition", "TriggerInterferometer", "Record", "AcknowledgeInPosition"]
    assert kinds == ["OpenRun", "Instruct", "ZeroInterferometer", "ReadInPosition", "Instruct"] + per_point * 6 + [
        "CloseRun"]
    rows = [x.data for x in mach.msgs if isinstance(x, m.Record)]
    assert [(r["target_index"], r["direction"]) for r in rows] == [(1, 1), (2, 1), (3, 1), (3, -1), (2, -1), (1, -1)]
    assert rows[1]["target_mm"] == 100.0 and rows[1]["reading_mm"] == pytest.approx(100.001)
    assert set(rows[0]) == set(POSITIONING_LINEAR)
    acks = [x.count for x in mach.msgs if isinstance(x, AcknowledgeInPosition)]
    waits = [x.last_count for x in mach.msgs if isinstance(x, WaitInPosition)]
    assert acks == [1, 2, 3, 4, 5, 6] and waits == [-1, 1, 2, 3, 4, 5]


def test_wrong_target_is_acknowledged_without_capture_and_timeouts_ask() -> None:
    s = psetup()
    st = s.measured_stops()
    events = [None, InPositionEvent(7, 3, 1, 1)] + [InPositionEvent(10 + k, x.target_index, x.run, x.direction)
                                                     for k, x in enumerate(st)]
    mach = drive(positioning_plan(s, {}), Machine(events, s.targets))
    keys = [x.key for x in mach.msgs if isinstance(x, m.Prompt)]
    assert keys == ["inposition", "mismatch"]
    assert [x.count for x in mach.msgs if isinstance(x, AcknowledgeInPosition)][0] == 7
    assert len([x for x in mach.msgs if isinstance(x, m.Record)]) == 6


def test_reading_far_from_target_is_rejected() -> None:
    s = psetup()
    events = [InPositionEvent(k + 1, x.target_index, x.run, x.direction) for k, x in enumerate(s.measured_stops())]
    mach = Machine(events, s.targets, offset_mm=1.5)  # 1.5 mm off: beyond max_deviation 1 mm
    mach.answers["invalid"] = ["skip"] * 6
    drive(positioning_plan(s, {}), mach)
    asked = [x for x in mach.msgs if isinstance(x, m.Prompt) and x.key == "invalid"]
    assert len(asked) == 6 and "+1.5000 mm from the target" in asked[0].text
    assert not [x for x in mach.msgs if isinstance(x, m.Record)]


def test_manual_trigger_asks_per_target_and_records_skips() -> None:
    s = psetup("manual")
    mach = Machine([], s.targets)
    placed = iter([0.0, 100.0, 200.0, 200.0, 100.0, 0.0])

    def respond(msg: Any) -> Any:
        if isinstance(msg, m.Instruct) and msg.key == "target":
            mach.at = next(placed)
            if msg.params["target_index"] == 2 and msg.params["direction"] == -1:
                mach.msgs.append(msg)
                return "skip"
        return mach(msg)

    drive(positioning_plan(s, {}), respond)
    rows = [x.data for x in mach.msgs if isinstance(x, m.Record)]
    assert [(r["target_index"], r["direction"]) for r in rows] == [(1, 1), (2, 1), (3, 1), (3, -1), (1, -1)]
    skipped = [x.value for x in mach.msgs if isinstance(x, m.Annotate) and x.key == "skipped"][-1]
    assert skipped == [{"run": 1, "direction": -1, "target_index": 2, "reason": "skipped by the operator"}]


def test_stability_trigger_waits_for_a_still_axis() -> None:
    s = psetup("stability", targets=(100.0, 150.0), overrun=5.0, feed_per_min=600.0,
               trigger=TriggerSetup(mode="stability", dwell_s=1.0, stability_window=1.0, near=0.5, poll_s=0.1))
    # readings (time s, position mm) while the axis approaches and settles at target 1 (100 mm)
    script = [(0.0, 95.0), (0.1, 99.8), (0.2, 100.0040), (0.3, 100.0012), (0.4, 100.0010), (0.5, 100.0011),
              (0.6, 100.0013), (0.7, 100.0012), (0.8, 100.0010), (0.9, 100.0011)]
    plan = positioning_plan(s, {})

    responder = Scripted(ifm(x, t) for t, x in script)
    reply: Any = None
    while not isinstance(msg := plan.send(reply), m.Record):
        reply = responder(msg)
    row = msg.data
    plan.close()
    # 95.0 is not near; 99.8 and 100.0040 drop out of the 1 um window; from 100.0012 at 0.3 s the
    # position stays within 1 um, and at 0.8 s it has done so for dwell / 2 = 0.5 s
    assert row["target_index"] == 1 and row["reading_mm"] == 100.0010 and row["time_s"] == 0.8


def test_resume_point_counts_measured_stops() -> None:
    s = psetup()
    rows = [{"run": 1, "direction": 1, "target_index": k} for k in (1, 2, 3)]
    rp = positioning_resume_point({"uid": "u", "skipped": [{"run": 1, "direction": -1, "target_index": 3}]}, rows,
                                  s.measured_stops())
    assert rp.next_index == 4 and s.measured_stops()[4].target_index == 2


# -- complete simulated runs --------------------------------------------------------------------
def example(**over: Any) -> dict:
    d = tomllib.loads((ROOT / "docs" / "setup-positioning.toml").read_text())
    for table, values in over.items():
        d[table].update(values)
    return d


def test_in_position_run_reads_the_simulated_axis_exactly(tmp_path: Path) -> None:
    src = example(axis={"end_mm": 800.0, "runs": 3})
    s = positioning_setup_from_dict(src)
    res = run_positioning(s, tmp_path / "run", simulate=SimOptions(seed=2, noise=False), auto=True,
                          setup_source=src, stream=io.StringIO())
    assert res.outcome.exit_status == "success", res.outcome.reason
    run = load_run(tmp_path / "run")
    pts = run.points
    assert len(pts) == 2 * 3 * len(s.targets) and list(pts.columns) == list(POSITIONING_LINEAR)
    assert set(pts["direction"]) == {1, -1} and sorted(set(pts["run"])) == [1, 2, 3]
    x20 = np.array([a for i, a in res.sim.axis.captured if i >= 0])  # i = -1: the datum  # type: ignore[union-attr]
    # what a controller counting vacuum wavelengths reads (standards.md §3.5): the axis expanded at its
    # material temperature, times the air index of the conditions it logged with the point
    env = run.meta["setup"]["environment"]
    assert env["refractive_index_assumed"] == 1.0 and env["dead_path_mm"] == 0.0 and run.meta["status"] == "complete"
    n_air = air_index(pts["air_temp_c"], pts["air_pressure_hpa"] * 100, pts["humidity_pct"], co2_ppm=env["co2_ppm"],
                      wavelength_nm=env["wavelength_nm"])
    expected = x20 * (1 + env["expansion_ppm_per_k"] * 1e-6 * (pts["material_temp_c"] - 20.0)) * n_air / 1.0
    np.testing.assert_allclose(pts["reading_mm"], expected, rtol=0, atol=1e-7)  # logged as FLOAT32
    assert (np.abs(pts["reading_mm"] - x20) > 1e-3).any()  # the air and the steel are really in the readings
    assert run.meta["axis_type"] == "linear" and run.meta["setup"]["targets_mm"] == list(s.targets)


def test_backlash_shows_as_the_reversal_value(tmp_path: Path) -> None:
    # only backlash, noise off: x_up - x_down = -backlash at every target (the axis stops short by
    # half the lost motion in the approach direction)
    # (a controller that reports compensated readings: reading_mm is the axis at 20 C)
    src = example(axis={"end_mm": 500.0, "runs": 2}, environment={"readings_compensated": True},
                  simulation={"pitch_amplitude": 0.0, "slope_per_m": 0.0, "periodic": 0.0,
                              "thermal_per_m_per_h": 0.0, "backlash": 3.0})
    s = positioning_setup_from_dict(src)
    run_positioning(s, tmp_path / "run", simulate=SimOptions(seed=0, noise=False), auto=True, stream=io.StringIO())
    pts = load_run(tmp_path / "run").points
    dev_um = (pts["reading_mm"] - pts["target_mm"]) * 1000
    up = dev_um[pts["direction"] == 1].groupby(pts["target_index"]).mean()
    down = dev_um[pts["direction"] == -1].groupby(pts["target_index"]).mean()
    np.testing.assert_allclose(up - down, -3.0, atol=1e-6)


def test_rotary_manual_run(tmp_path: Path) -> None:
    src = {"kind": "positioning", "axis": {"type": "rotary", "name": "C", "runs": 2},
           "trigger": {"mode": "manual"}}
    s = positioning_setup_from_dict(src)
    assert s.simulation == SimulatedAxisSetup()
    res = run_positioning(s, tmp_path / "run", simulate=SimOptions(seed=1, noise=False), auto=True,
                          setup_source=src, stream=io.StringIO())
    assert res.outcome.exit_status == "success", res.outcome.reason
    run = load_run(tmp_path / "run")
    assert list(run.points.columns) == list(POSITIONING_ROTARY) and run.meta["axis_type"] == "rotary"
    assert {0.0, 90.0, 180.0, 270.0} <= set(run.points["target_deg"])
    dev_arcsec = (run.points["reading_deg"] - run.points["target_deg"]) * 3600
    assert 0.5 < dev_arcsec.abs().max() < 10  # the simulated errors are a few arcsec
    truth = np.array([a for i, a in res.sim.axis.captured if i >= 0])  # type: ignore[union-attr]
    np.testing.assert_allclose(run.points["reading_deg"], truth, atol=1e-9)


def test_stability_trigger_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the axis's dwell and the readings' timestamps on one simulated clock that moves one poll per reading
    # (tests/acquisition/sim_clock.py): the axis stays at a target for 40 readings, the plan needs the
    # position still over 20 of them, however slowly a loaded machine takes them.  Readings compensated by
    # the controller, so a point's reading is the simulated axis position itself
    src = example(axis={"end_mm": 400.0, "runs": 1}, environment={"readings_compensated": True},
                  trigger={"mode": "stability", "dwell_s": 0.4, "poll_s": 0.01, "timeout_s": 60.0})
    s = positioning_setup_from_dict(src)
    # and a starved CPU, made certain: three readings are held up longer than the whole dwell
    # (at the wall clock the axis would have left those stops unseen: "a stop was missed")
    read, taken = InterferometerController._read_consistent, []

    def held_up(self: InterferometerController, st: Any) -> Any:
        taken.append(1)
        if len(taken) in (5, 30, 95):
            time.sleep(2 * s.trigger.dwell_s)
        return read(self, st)

    monkeypatch.setattr(InterferometerController, "_read_consistent", held_up)
    with simulated_clock(monkeypatch, step_s=s.trigger.poll_s) as clock:
        res = run_positioning(s, tmp_path / "run", simulate=SimOptions(seed=3, noise=False), auto=True,
                              stream=io.StringIO())
    assert res.outcome.exit_status == "success", res.outcome.reason
    assert clock.readings > 20 * len(s.measured_stops()) and len(taken) > 95  # the simulated clock ran the dwell
    run = load_run(tmp_path / "run")
    pts = run.points
    assert len(pts) == 2 * len(s.targets) and not run.meta.get("skipped")
    # every point is a capture taken while the axis stood at that very stop (ground truth of the simulated
    # axis: the stop index and position of each capture); the other approach of the same target differs
    # by the 3 um backlash, so a reading attached to the wrong stop would not match
    stops = s.stops()
    for row in pts.itertuples():
        j = next(k for k, st in enumerate(stops) if (st.run, st.direction, st.target_index)
                 == (row.run, row.direction, row.target_index))
        at_stop = [a for k, a in res.sim.axis.captured if k == j]  # type: ignore[union-attr]
        assert any(abs(a - row.reading_mm) < 1e-9 for a in at_stop), (row, at_stop[:3])


def test_aborted_run_resumes_where_the_machine_program_stopped(tmp_path: Path) -> None:
    from acquisition.operators import AutoOperator

    src = example(axis={"end_mm": 500.0, "runs": 2}, trigger={"mode": "manual"})
    s = positioning_setup_from_dict(src)
    ref = run_positioning(s, tmp_path / "ref", simulate=SimOptions(seed=4, noise=False), auto=True,
                          setup_source=src, stream=io.StringIO())
    assert ref.outcome.exit_status == "success"

    class AbortAtEighth(AutoOperator):
        def __init__(self) -> None:
            super().__init__()
            self.targets = 0

        def instruct(self, msg: m.Instruct) -> str:
            if msg.key == "target":
                self.targets += 1
                if self.targets == 8:
                    return "abort"
            return super().instruct(msg)

    out = tmp_path / "run"
    aborted = run_positioning(s, out, simulate=SimOptions(seed=4, noise=False), setup_source=src,
                              stream=io.StringIO(), operator=AbortAtEighth())
    assert aborted.outcome.exit_status == "abort" and len(load_run(out).points) == 7
    # resume without the set-up file: run.json holds it; the simulated program restarts at target 8
    resumed = run_positioning(None, out, simulate=SimOptions(), auto=True, resume=True, stream=io.StringIO())
    assert resumed.outcome.exit_status == "success", resumed.outcome.reason
    a, b = load_run(tmp_path / "ref").points, load_run(out).points
    cols = ["run", "direction", "target_index", "target_mm", "reading_mm"]
    assert len(b) == len(a) and load_run(out).meta["status"] == "complete"
    np.testing.assert_allclose(b[cols].to_numpy(), a[cols].to_numpy(), atol=1e-9)


def test_setup_rules_and_errors() -> None:
    long = positioning_setup_from_dict({"axis": {"end_mm": 3000.0}})
    assert long.long_axis and long.runs == 1 and len(long.targets) == 13  # about every 250 mm, one run
    normal = positioning_setup_from_dict({"axis": {"end_mm": 1000.0}})
    assert not normal.long_axis and normal.runs == 5 and normal.trigger.mode == "in-position"
    explicit = positioning_setup_from_dict({"axis": {"targets_mm": [0, 10, 20, 30, 40]}})
    assert explicit.targets == (0.0, 10.0, 20.0, 30.0, 40.0)
    assert positioning_setup_from_dict(example()).to_run_setup()["environment"]["expansion_ppm_per_k"] == 11.5
    for data, message in [
        ({"axis": {"end_mm": 100.0}, "trigger": {"mode": "laser"}}, "mode must be one of"),
        ({"axis": {}}, "give end_mm"),
        ({"axis": {"targets_mm": [0, 20, 10]}}, "strictly increasing"),
        ({"axis": {"end_mm": 100.0, "cycle": "spiral"}}, "cycle must be one of"),
        ({"axis": {"end_mm": 100.0}, "gcode": {"dialect": "heidenhain"}}, "dialect must be one of"),
        ({"axis": {"end_mm": 100.0, "speed": 3}}, "unknown key 'speed' in [axis]"),
        ({"axis": {"type": "rotary", "end_deg": 400.0}}, "rotary axis range"),
    ]:
        with pytest.raises(SetupError, match=re.escape(message)) as info:
            positioning_setup_from_dict(data)
        assert "\n" not in str(info.value)
