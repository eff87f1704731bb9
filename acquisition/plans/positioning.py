"""ISO 230-2 positioning workflow (linear and rotary axes).

1. Open the run; the operator brings the axis to the datum position and the
   interferometer is zeroed there (``reading = datum + interferometer``).
2. The machine runs the part program of the cycle (``guideway gcode``); each
   measured stop (target i, run j, direction) is captured when

   * ``in-position``: the PLC reports the axis in position at that target
     (registers 200-204); the tool triggers, records and acknowledges;
   * ``stability``: the interferometer position stays within the stability
     window near the target for half the programmed dwell (polled triggered
     captures, so the capture falls inside the dwell);
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

from ..inposition import AcknowledgeInPosition, ReadAngle, WaitInPosition
from ..iso230 import Stop
from ..messages import (
    Annotate,
    CloseRun,
    Instruct,
    Log,
    Message,
    OpenRun,
    Prompt,
    Record,
    TriggerInterferometer,
    Wait,
    ZeroInterferometer,
)
from ..positioning_setup import PositioningSetup
from .straightness import ResumePoint

ARROW = {1: "up (+)", -1: "down (-)"}


def positioning_row(s: Stop, reading: float, t0: float, ifm: InterferometerReading, unit: str) -> dict[str, Any]:
    """One row of a positioning run's points.csv (docs/run-format.md)."""
    return {
        "run": s.run, "direction": s.direction, "target_index": s.target_index,
        f"target_{unit}": s.position, f"reading_{unit}": reading, "time_s": ifm.timestamp_s - t0,
        "stry_um": ifm.stry_um, "strz_um": ifm.strz_um, "pitch_urad": ifm.pitch_urad,
        "yaw_urad": ifm.yaw_urad, "roll_urad": ifm.roll_urad,
        "air_temp_c": ifm.air_temp_c, "air_pressure_hpa": ifm.air_pressure_hpa,
        "humidity_pct": ifm.humidity_pct, "material_temp_c": ifm.material_temp_c,
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


def _stable_capture(setup: PositioningSetup, s: Stop
                    ) -> Generator[Message, Any, tuple[InterferometerReading, float] | None]:
    """Poll until the position stays within the window for the dwell time near the target."""
    tr = setup.trigger
    window = tr.stability_window / (3600.0 if setup.axis_type == "rotary" else 1000.0)
    hist: list[tuple[float, float]] = []
    waited = 0.0
    while True:
        ifm, pos = yield from _read(setup)
        if ifm.ok and abs(pos - s.position) <= tr.near:
            hist.append((ifm.timestamp_s, pos))
            while max(p for _, p in hist) - min(p for _, p in hist) > window:
                hist.pop(0)
            if len(hist) >= 2 and hist[-1][0] - hist[0][0] >= tr.dwell_s / 2:
                return ifm, pos
        else:
            hist.clear()
        waited += max((yield Wait(tr.poll_s)), tr.poll_s)
        if waited > tr.timeout_s:
            return None


def _leave(setup: PositioningSetup, s: Stop) -> Generator[Message, Any, None]:
    """Stability trigger: wait until the axis has left the target it was just captured at."""
    waited = 0.0
    while waited <= setup.trigger.timeout_s:
        ifm, pos = yield from _read(setup)
        if ifm.ok and abs(pos - s.position) > setup.trigger.near:
            return
        waited += max((yield Wait(setup.trigger.poll_s)), setup.trigger.poll_s)


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
    if mode in ("in-position", "stability") and i < len(stops):
        yield Instruct("cycle_start", "Start the part program of this cycle (guideway gcode) with Cycle Start.",
                       {}, choices=("started", "abort"), key="start")
    last_count = -1
    while i < len(stops):
        s = stops[i]
        event = None
        if mode == "in-position":
            event = yield WaitInPosition(last_count, tr.timeout_s)
            if event is None or event.cycle_done:
                why = "the program has finished" if event is not None else f"nothing within {tr.timeout_s:g} s"
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
            ifm, reading = yield from _read(setup)
        else:
            got_stable = yield from _stable_capture(setup, s)
            if got_stable is None:
                yield Prompt(f"The axis did not settle near {_where(s, u)} within {tr.timeout_s:g} s. Keep "
                             f"waiting, or abort.", ("wait", "abort"), key="stability",
                             fault=f"axis not stable near {_where(s, u)}")
                continue
            ifm, reading = got_stable
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
            yield Record(positioning_row(s, reading, t0, ifm, u))
            yield Annotate("progress", {"index": i, "run": s.run, "direction": s.direction,
                                        "target_index": s.target_index})
            # the raw reading, not a deviation: it still carries the air index and the material
            # expansion (acquisition.live.LiveDeviation gives the compensated deviation)
            yield Log(f"run {s.run} {ARROW[s.direction]:8s} target {s.target_index:3d}  {s.position:10.4f} {u}  "
                      f"raw reading {reading:.5f} {u}")
        if event is not None:
            yield AcknowledgeInPosition(event.count)
            last_count = event.count
        nxt = stops[i + 1] if i + 1 < len(stops) else None
        if mode == "stability" and nxt is not None and abs(nxt.position - s.position) <= tr.near:
            yield from _leave(setup, s)  # the next target is here too: first see the axis go away
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
