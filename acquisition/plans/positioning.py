"""ISO 230-2 positioning workflow (linear and rotary axes).

1. Open the run; the operator brings the axis to the datum position and the
   interferometer is zeroed there (``reading = datum + interferometer``).
2. The machine runs the part program of the cycle (``guideway gcode``); each
   measured stop (target i, run j, direction) is captured when

   * ``in-position``: the PLC reports the axis in position at that target
     (registers 200-204); the tool triggers, records and acknowledges;
   * ``stability``: the interferometer position stays within the stability
     window near the target for half the programmed dwell (polled triggered
     captures, so the capture falls inside the dwell), after the axis came
     there along the cycle's path (:class:`ApproachTracker`: a reading is never
     attached to another stop of the same target, or to a stop it missed);
   * ``manual``: the operator presses Cycle Start (M00 at each target) and
     confirms when the axis has stopped.

3. Every capture is validated (status flags, finite values, within
   ``max_deviation`` of its target); the point is recorded with the progress.

A resumed run (:class:`~acquisition.plans.straightness.ResumePoint`, with
``next_index`` counting measured stops) continues with the next stop.
"""

from __future__ import annotations

import math
from collections.abc import Generator
from typing import Any

from drivers.readings import InterferometerReading

from ..inposition import AcknowledgeInPosition, InPositionState, ReadAngle, ReadInPosition, WaitInPosition
from ..messages import (
    Annotate,
    CloseRun,
    Instruct,
    Log,
    Message,
    OpenRun,
    Prompt,
    Record,
    Stillness,
    TriggerInterferometer,
    Wait,
    ZeroInterferometer,
)
from ..setup.cycles import Stop
from ..setup.positioning import PositioningSetup
from ..stillness import LOOK, STABLE, StillnessWindow, position_channel
from .straightness import ResumePoint

ARROW = {1: "up (+)", -1: "down (-)"}


def positioning_row(s: Stop, reading: float, t0: float, ifm: InterferometerReading, unit: str,
                    not_still: bool = False) -> dict[str, Any]:
    """One row of a positioning run's points.csv (docs/run-format.md); ``not_still``: the operator captured
    it although the axis was not found still (marked 1)."""
    return {
        "run": s.run, "direction": s.direction, "target_index": s.target_index,
        f"target_{unit}": s.position, f"reading_{unit}": reading, "time_s": ifm.timestamp_s - t0,
        "stry_um": ifm.stry_um, "strz_um": ifm.strz_um, "pitch_urad": ifm.pitch_urad,
        "yaw_urad": ifm.yaw_urad, "roll_urad": ifm.roll_urad,
        "air_temp_c": ifm.air_temp_c, "air_pressure_hpa": ifm.air_pressure_hpa,
        "humidity_pct": ifm.humidity_pct, "material_temp_c": ifm.material_temp_c,
        "not_still": int(not_still),
    }


def _where(s: Stop, unit: str) -> str:
    return f"target {s.target_index} ({s.position:g} {unit}), run {s.run} {ARROW[s.direction]}"


def _read(setup: PositioningSetup) -> Generator[Message, Any, tuple[InterferometerReading, float]]:
    """Trigger one capture; return it with the reading in axis coordinates (mm or deg)."""
    ifm = yield TriggerInterferometer()
    if setup.axis_type == "rotary":
        angle = yield ReadAngle()
        return ifm, setup.datum + angle
    return ifm, setup.datum + ifm.position_mm


def reading_problem(ifm: InterferometerReading, reading: float, s: Stop, setup: PositioningSetup) -> str | None:
    """Why a capture cannot be used, or None."""
    u = setup.unit
    if not ifm.ok:
        st = ifm.status
        return (f"{_where(s, u)}: interferometer data not valid (beam OK={st.beam_ok}, error={st.error_code} "
                f"{st.error_text}); check the beam")
    if not math.isfinite(reading):
        return f"{_where(s, u)}: the reading is not a number"
    if abs(reading - s.position) > setup.max_deviation:
        return (f"{_where(s, u)}: reading {reading:.4f} {u} is {reading - s.position:+.4f} {u} from the target "
                f"(limit {setup.max_deviation:g} {u}); is the axis at the right target?")
    return None


SIDE_WORDS = {-1: "below", 1: "above"}


def _sides(positions: list[float], target: float, near: float) -> list[int]:
    """The sides of the window [target - near, target + near] the positions lie on, in order,
    repeats merged (-1 below, +1 above; positions inside the window leave no mark)."""
    out: list[int] = []
    for p in positions:
        side = -1 if p < target - near else 1 if p > target + near else 0
        if side and (not out or out[-1] != side):
            out.append(side)
    return out


class ApproachTracker:
    """Stability trigger: which stop of the cycle a still reading belongs to.

    Between the last capture (or the datum) and the next measured stop the axis follows the
    cycle's path through the stops in between (overruns, stops skipped).  Seen from the window
    [target - near, target + near] of the stop expected next, that path lies on a sequence of
    sides (below, above; repeats merged): the last one is the approach direction.  The readings
    polled since the last capture must show exactly that sequence before a still reading inside
    the window is that stop (state ``ready``); a prefix of it means the axis is still on its way
    (``wait``, e.g. still dwelling at the previous stop of the same target); anything else means
    it went where the cycle does not (a missed stop: ``mismatch``).  A resumed run has no known
    start: there the last side seen must be the approach side.
    """

    def __init__(self, setup: PositioningSetup, *, resumed: bool = False) -> None:
        self.stops = setup.stops()
        self.measured = [j for j, st in enumerate(self.stops) if st.target_index]
        self.near = setup.trigger.near
        self.anchor: int | None = None if resumed else -1  # stop index of the last capture; -1 the datum
        self.anchor_pos = setup.datum
        self.positions: list[float] = []  # valid readings since the last capture
        self._cache: tuple[int, int, list[int]] = (-1, 0, [])

    def expected(self, i: int) -> list[int]:
        """Sides the path from the last capture to measured stop ``i`` leaves."""
        s = self.stops[self.measured[i]]
        if self.anchor is None:
            return [-s.direction]
        path = [self.anchor_pos] + [st.position for st in self.stops[self.anchor + 1:self.measured[i]]]
        return _sides(path, s.position, self.near)

    def observed(self, i: int) -> list[int]:
        """Sides of the window of measured stop ``i`` the readings since the last capture lay on."""
        key, n, obs = self._cache
        if key != i:
            n, obs = 0, []
        target = self.stops[self.measured[i]].position
        for side in _sides(self.positions[n:], target, self.near):
            if not obs or obs[-1] != side:
                obs.append(side)
        self._cache = (i, len(self.positions), obs)
        return obs

    def observe(self, position: float) -> None:
        self.positions.append(position)

    def state(self, i: int) -> str:
        """``ready``, ``wait`` or ``mismatch`` for measured stop ``i`` (see the class docstring)."""
        obs, exp = self.observed(i), self.expected(i)
        if self.anchor is None:
            return "ready" if obs and obs[-1] == exp[-1] else "wait"
        if obs == exp:
            return "ready"
        return "wait" if obs == exp[:len(obs)] else "mismatch"

    def mismatch(self, i: int) -> str:
        """Why the readings do not fit measured stop ``i`` (one line)."""
        s = self.stops[self.measured[i]]
        seen = ", then ".join(SIDE_WORDS[x] for x in self.observed(i)) or "nowhere else"
        way = ", then ".join(SIDE_WORDS[x] for x in self.expected(i))
        return (f"since the last capture the axis was {seen} of this target, but the cycle comes to it {way} "
                f"(approach {ARROW[s.direction]}): a stop was missed or another program runs")

    def captured(self, i: int) -> None:
        """The axis stood at measured stop ``i``: the path to the next stop starts there."""
        self.anchor = self.measured[i]
        self.anchor_pos = self.stops[self.anchor].position
        self.positions = []
        self._cache = (-1, 0, [])


def _stable_capture(setup: PositioningSetup, i: int, tracker: ApproachTracker
                    ) -> Generator[Message, Any, tuple[InterferometerReading, float] | str | None]:
    """Poll until a reading is measured stop ``i``: reached along the cycle's path, then within the
    window for the dwell time near the target.  The capture; a mismatch (str) when the axis went
    where the cycle does not; None after the timeout."""
    tr = setup.trigger
    s = setup.measured_stops()[i]
    window = StillnessWindow(tr.stability_window, tr.dwell_s / 2)  # the rule of the TUI's stability light too
    waited = 0.0
    while True:
        ifm, pos = yield from _read(setup)
        if ifm.ok and math.isfinite(pos):
            tracker.observe(pos)
            state = tracker.state(i)
            if state == "mismatch":
                return tracker.mismatch(i)
        else:
            state = "wait"
        if state == "ready" and abs(pos - s.position) <= tr.near:
            if window.add(ifm.timestamp_s, (position_channel(pos, setup.axis_type),)) == STABLE:
                return ifm, pos
        else:
            window.clear()
        waited += max((yield Wait(tr.poll_s)), tr.poll_s)
        if waited > tr.timeout_s:
            return None


def _rests_near(setup: PositioningSetup, s: Stop, limit_s: float) -> Generator[Message, Any, bool]:
    """Poll for up to ``limit_s``: True as soon as the axis rests near the target of stop ``s`` (within
    ``near``, the position within the stability window for half the dwell), False if it does not."""
    tr = setup.trigger
    window = StillnessWindow(tr.stability_window, tr.dwell_s / 2)
    waited = 0.0
    while True:
        ifm, pos = yield from _read(setup)
        if ifm.ok and math.isfinite(pos) and abs(pos - s.position) <= tr.near:
            if window.add(ifm.timestamp_s, (position_channel(pos, setup.axis_type),)) == STABLE:
                return True
        else:
            window.clear()
        if waited >= limit_s:
            return False
        waited += max((yield Wait(tr.poll_s)), tr.poll_s)


def still_before_capture(setup: PositioningSetup, s: Stop) -> Generator[Message, Any, bool]:
    """Manual trigger, after the operator's ``capture``: is the axis still at the target (the rule of the
    stability trigger and the TUI's light)?  True if it is (or nobody judges, messages.Stillness), or once
    it has come to rest when the operator chose to wait; False when the operator captures anyway (the
    point is marked ``not_still``)."""
    seen = yield Stillness()
    if seen is None or seen == STABLE:
        return True
    tr, u = setup.trigger, setup.unit
    if seen == LOOK:
        if (yield from _rests_near(setup, s, tr.dwell_s / 2 + 2 * tr.poll_s)):
            return True
        seen = "not at rest"
    unit = "arcsec" if setup.axis_type == "rotary" else "um"
    answer = yield Prompt(
        f"The axis is not still at {_where(s, u)}: {seen} (still = within {tr.stability_window:g} {unit} for "
        f"{tr.dwell_s / 2:g} s). Wait until it is still, capture now (the point is marked not_still in "
        f"points.csv), or abort?", ("wait", "capture", "abort"), default="wait", key="still")
    if answer == "capture":
        yield Log(f"{_where(s, u)}: captured while not still ({seen}); marked not_still")
        return False
    while not (yield from _rests_near(setup, s, tr.timeout_s)):
        yield Prompt(f"The axis did not settle near {_where(s, u)} within {tr.timeout_s:g} s. Keep waiting, or "
                     f"abort.", ("wait", "abort"), key="stability", fault=f"axis not stable near {_where(s, u)}")
    return True


def positioning_plan(setup: PositioningSetup, metadata: dict[str, Any],
                     resume: ResumePoint | None = None) -> Generator[Message, Any, None]:
    """Yield the messages of a complete (or resumed) positioning run."""
    stops = setup.measured_stops()
    u, mode, tr = setup.unit, setup.trigger.mode, setup.trigger
    if resume is None:
        t0 = yield OpenRun("positioning", metadata)
        yield Annotate("start_time_s", t0)
        yield Instruct("move_to_datum",
                       f"Move axis {setup.axis_name} to the datum {setup.datum:g} {u} and align the laser; "
                       f"then confirm to zero the interferometer.", {}, key="datum")
        yield ZeroInterferometer()
        i = 0
    else:
        yield OpenRun("positioning", metadata, resume_uid=resume.uid)
        t0, i = resume.t0, resume.next_index
        if i < len(stops):
            yield Prompt(f"Resuming at {_where(stops[i], u)}; restart the part program at that target. "
                         f"The interferometer must not have been re-zeroed. Continue?", ("continue", "abort"),
                         key="resume")
    skipped: list[dict[str, Any]] = list(resume.skipped) if resume else []
    last_count, armed = -1, False
    tracker = ApproachTracker(setup, resumed=resume is not None)
    if mode == "in-position" and i < len(stops):
        left = yield ReadInPosition()
        if isinstance(left, InPositionState):
            armed = not left.done  # a b2 already set belongs to an earlier cycle until this one runs
            if left.in_position:
                last_count = left.count
                yield Log(f"in-position bit left set by an earlier cycle (counter {left.count}, target "
                          f"{left.target_index}); ignored")
            if left.done:
                yield Log("cycle-finished bit left set by an earlier cycle; ignored until this cycle runs")
    if mode in ("in-position", "stability") and i < len(stops):
        yield Instruct("cycle_start", "Start the part program of this cycle (guideway gcode) with Cycle Start.",
                       {}, choices=("started", "abort"), key="start")
    while i < len(stops):
        s = stops[i]
        event = None
        not_still = False
        if mode == "in-position":
            event = yield WaitInPosition(last_count, tr.timeout_s, armed=armed)
            if event is not None:
                armed = armed or event.armed
            if event is None or event.cycle_done or event.timed_out:
                why = "the program has finished" if event is not None and event.cycle_done else (
                    f"nothing within {tr.timeout_s:g} s")
                yield Prompt(f"No in-position signal for {_where(s, u)} ({why}). Check that the part program runs, "
                             f"then keep waiting, or abort.", ("wait", "abort"), key="inposition",
                             fault=f"no in-position signal for {_where(s, u)}")
                continue
            got = (event.target_index, event.run, event.direction)
            if got != (s.target_index, s.run, s.direction):
                yield Prompt(f"The machine reports target {got[0]}, run {got[1]}, direction {got[2]:+d}; the plan "
                             f"expects {_where(s, u)}. Is the part program of this set-up running? Acknowledge "
                             f"it without capturing (the machine moves on), or abort.", ("acknowledge", "abort"),
                             key="mismatch", fault=f"in-position event for the wrong target (expected {_where(s, u)})")
                yield AcknowledgeInPosition(event.count)
                last_count = event.count
                continue
            ifm, reading = yield from _read(setup)
        elif mode == "manual":
            answer = yield Instruct(
                "cycle_start", f"Press Cycle Start; when the axis has stopped at {_where(s, u)}, capture.",
                {"target_index": s.target_index, "run": s.run, "direction": s.direction},
                choices=("capture", "skip", "pause", "abort"), key="target")
            if answer == "skip":
                skipped.append({"run": s.run, "direction": s.direction, "target_index": s.target_index,
                                "reason": "skipped by the operator"})
                yield Annotate("skipped", list(skipped))
                i += 1
                continue
            not_still = not (yield from still_before_capture(setup, s))
            ifm, reading = yield from _read(setup)
        else:
            got_stable = yield from _stable_capture(setup, i, tracker)
            if got_stable is None:
                yield Prompt(f"The axis did not settle near {_where(s, u)} within {tr.timeout_s:g} s. Keep "
                             f"waiting, or abort.", ("wait", "abort"), key="stability",
                             fault=f"axis not stable near {_where(s, u)}")
                continue
            if isinstance(got_stable, str):
                yield Prompt(f"{_where(s, u)}: {got_stable}. Skip this point (recorded; the next one is looked "
                             f"for), or abort?", ("skip", "abort"), key="mismatch",
                             fault=f"{_where(s, u)}: {got_stable}")
                skipped.append({"run": s.run, "direction": s.direction, "target_index": s.target_index,
                                "reason": got_stable})
                yield Annotate("skipped", list(skipped))
                i += 1
                continue
            ifm, reading = got_stable
            tracker.captured(i)
        problem = reading_problem(ifm, reading, s, setup)
        if problem is not None:
            answer = yield Prompt(f"{problem} Retry the capture, skip this point (recorded), or abort?",
                                  ("retry", "skip", "abort"), default="retry", key="invalid", fault=problem)
            if answer == "retry":  # (in-position: the PLC still waits for this acknowledge)
                continue
            skipped.append({"run": s.run, "direction": s.direction, "target_index": s.target_index,
                            "reason": problem})
            yield Annotate("skipped", list(skipped))
        else:
            yield Record(positioning_row(s, reading, t0, ifm, u, not_still))
            yield Annotate("progress", {"index": i, "run": s.run, "direction": s.direction,
                                        "target_index": s.target_index})
            # the raw reading, not a deviation: it still carries the air index and the material
            # expansion (acquisition.live.LiveDeviation gives the compensated deviation)
            yield Log(f"run {s.run} {ARROW[s.direction]:8s} target {s.target_index:3d}  {s.position:10.4f} {u}  "
                      f"raw reading {reading:.5f} {u}")
        if event is not None:
            yield AcknowledgeInPosition(event.count)
            last_count = event.count
        i += 1
    yield CloseRun("all targets captured" + (f" ({len(skipped)} skipped)" if skipped else ""))


def positioning_resume_point(meta: dict[str, Any], rows: list[dict[str, Any]], stops: list[Stop]) -> ResumePoint:
    """Resume after the last measured stop with a point on disk or recorded as skipped."""
    index = {(s.run, s.direction, s.target_index): i for i, s in enumerate(stops)}
    keys = [(int(r["run"]), int(r["direction"]), int(r["target_index"])) for r in rows]
    keys += [(int(s["run"]), int(s["direction"]), int(s["target_index"])) for s in meta.get("skipped", [])]
    done = [index[k] for k in keys if k in index]
    return ResumePoint(str(meta.get("uid", "")), float(meta.get("start_time_s", 0.0)), max(done, default=-1) + 1,
                       {}, tuple(meta.get("skipped", [])))
