"""Gauge-block straightness workflow (seed 001).

1. Open the run; the operator places the block at station 0 (the datum).
2. Warm-up (optional): interferometer and sensor readings every ``interval_s``
   until their peak-to-peak drift over a window stays below the limits; after
   ``timeout_s`` the operator waits on, overrides (recorded) or aborts.
3. Datum: zero the interferometer; station 0's averaged sensor reading is the
   start reading.
4. Per step (pass, station): the operator places the block at x = k * L against
   the side face and answers ``capture`` (or ``redo`` the previous step,
   ``skip`` this one, ``pause``, ``abort``).  Capture = triggered interferometer
   reading + averaged sensor reading, validated (status flags, finite values,
   sensor stability, plausible ranges; retried up to ``capture_attempts`` times,
   then the operator decides), then a jump check against the previous step
   (the operator accepts or redoes), then the point is recorded and the
   progress written.
5. Optional return pass: the same stations backwards (``pass`` = 1).

A resumed run (:class:`ResumePoint`) skips 1-3 and continues after the last
completed step; the interferometer datum must not have been reset meanwhile.

Hands-free (``guideway acquire --auto`` with real devices, set-up ``[auto]``):
step 4 does not ask; the plan polls the interferometer until the block is at
the station (|lin| within ``max_lin_um``) and still (:func:`arrival`), then
captures.  After ``station_timeout_s`` it asks (keep waiting, skip, abort).
"""

from __future__ import annotations

import math
from collections.abc import Generator, Sequence
from dataclasses import dataclass, field
from typing import Any

from drivers.readings import AveragedDisplacement, InterferometerReading
from saved_runs.evaluation.limits import ValidationSetup

from ..messages import (
    Annotate,
    CloseRun,
    Instruct,
    Log,
    Message,
    OpenRun,
    Progress,
    Prompt,
    ReadSensor,
    Record,
    Requested,
    Retract,
    Stillness,
    TriggerInterferometer,
    Wait,
    ZeroInterferometer,
)
from ..setup.straightness import StraightnessSetup, WarmupSetup
from ..stillness import LOOK, STABLE, StillnessWindow, straightness_channels

Step = tuple[int, int]  # (pass, station)


def point_record(
    k: int, x_mm: float, t0: float, ifm: InterferometerReading, sensor: AveragedDisplacement,
    pass_: int = 0, not_still: bool = False,
) -> dict[str, Any]:
    """One row of points.csv (run format v2) from the two readings; ``pass_`` 0 forward, 1 return;
    ``not_still``: the operator captured it although the block was not found still (marked 1)."""
    return {
        "station": k,
        "x_mm": x_mm,
        "time_s": ifm.timestamp_s - t0,
        "lin_um": (ifm.position_mm - x_mm) * 1000.0,
        "stry_um": ifm.stry_um,
        "strz_um": ifm.strz_um,
        "pitch_urad": ifm.pitch_urad,
        "yaw_urad": ifm.yaw_urad,
        "roll_urad": ifm.roll_urad,
        "sensor_mm": sensor.mean_mm,
        "air_temp_c": ifm.air_temp_c,
        "air_pressure_hpa": ifm.air_pressure_hpa,
        "humidity_pct": ifm.humidity_pct,
        "material_temp_c": ifm.material_temp_c,
        "pass": pass_,
        "not_still": int(not_still),
    }


def capture_problem(ifm: InterferometerReading, sensor: AveragedDisplacement, k: int, x_mm: float,
                    v: ValidationSetup) -> str | None:
    """Why a capture at station k cannot be used (one line), or None if it passes every check."""
    if not ifm.ok:
        st = ifm.status
        return (f"station {k}: interferometer data not valid (beam OK={st.beam_ok}, error={st.error_code} "
                f"{st.error_text}); check the beam")
    if not sensor.ok:
        bad = ", ".join(s.value for s in sensor.statuses) or "no valid sample"
        return f"station {k}: displacement sensor reading invalid ({bad}); check the sensor range and target"
    env = (ifm.air_temp_c, ifm.air_pressure_hpa, ifm.humidity_pct, ifm.material_temp_c)
    if not all(math.isfinite(e) for e in env):
        return f"station {k}: environment values not finite; check the environment sensors"
    if sensor.count > 1 and sensor.std_mm * 1000.0 > v.max_sensor_std_um:
        return (f"station {k}: sensor not stable (std {sensor.std_mm * 1000:.2f} um over {sensor.count} "
                f"samples, limit {v.max_sensor_std_um:g} um); keep the block still")
    lo, hi = v.sensor_range_mm
    if not lo <= sensor.mean_mm <= hi:
        return f"station {k}: sensor reading {sensor.mean_mm:+.4f} mm outside the plausible range [{lo:g}, {hi:g}] mm"
    for name in ("stry_um", "strz_um"):
        if abs(getattr(ifm, name)) > v.max_straightness_um:
            return f"station {k}: {name} = {getattr(ifm, name):+.1f} um beyond +/-{v.max_straightness_um:g} um"
    for name in ("pitch_urad", "yaw_urad", "roll_urad"):
        if abs(getattr(ifm, name)) > v.max_angle_urad:
            return f"station {k}: {name} = {getattr(ifm, name):+.1f} urad beyond +/-{v.max_angle_urad:g} urad"
    lin_um = (ifm.position_mm - x_mm) * 1000.0
    if abs(lin_um) > v.max_lin_um:
        return (f"station {k}: block at {ifm.position_mm:.3f} mm, {lin_um:+.0f} um from x = {x_mm:g} mm "
                f"(limit {v.max_lin_um:g} um); is it at the right station?")
    return None


def jump_problem(row: dict[str, Any], prev: dict[str, Any] | None, v: ValidationSetup) -> str | None:
    """A step change against the previous step's point larger than the limits, or None."""
    if prev is None:
        return None
    d_ifm = max(abs(row["stry_um"] - prev["stry_um"]), abs(row["strz_um"] - prev["strz_um"]))
    d_sensor = abs(row["sensor_mm"] - prev["sensor_mm"]) * 1000.0
    where = f"station {row['station']} (pass {row['pass']}) vs station {prev['station']} (pass {prev['pass']})"
    if d_ifm > v.jump_ifm_um:
        return f"{where}: straightness jumped by {d_ifm:.1f} um (limit {v.jump_ifm_um:g} um)"
    if d_sensor > v.jump_sensor_um:
        return f"{where}: sensor jumped by {d_sensor:.1f} um (limit {v.jump_sensor_um:g} um)"
    return None


@dataclass(frozen=True)
class ResumePoint:
    """Where an interrupted run continues: its uid, start time and what is already done."""

    uid: str
    t0: float
    next_index: int  # index into StraightnessSetup.steps()
    points: dict[Step, dict[str, Any]] = field(default_factory=dict)
    skipped: tuple[dict[str, Any], ...] = ()


def resume_point(meta: dict[str, Any], rows: list[dict[str, Any]], steps: Sequence[Step]) -> ResumePoint:
    """Work out the resume point from run.json and the points on disk.

    The points are the authority (each is fsynced before the run moves on); run.json's
    ``skipped`` adds the steps skipped without a point.  ``steps`` is looked up, never copied
    (:class:`~acquisition.setup.straightness.Steps` computes its index).
    """
    points = {(int(r["pass"]), int(r["station"])): r for r in rows}
    skipped = tuple(meta.get("skipped", []))
    done = [steps.index(s) for s in points if s in steps]
    done += [steps.index((int(s["pass"]), int(s["station"]))) for s in skipped
             if (int(s["pass"]), int(s["station"])) in steps]
    t0 = float(meta.get("start_time_s", 0.0))
    return ResumePoint(str(meta.get("uid", "")), t0, max(done, default=-1) + 1, points, skipped)


def window_drift(ifm_hist: list[tuple[float, float]], sen_hist: list[float], window: int) -> tuple[float, float]:
    """Peak-to-peak drift (um) of the interferometer (the larger of straightness Y and Z) and of
    the sensor over the last ``window`` readings (fewer at the start; NaN before two)."""
    if len(sen_hist) < 2:
        return math.nan, math.nan
    win_i, win_s = ifm_hist[-window:], sen_hist[-window:]
    return max(max(c) - min(c) for c in zip(*win_i, strict=True)), max(win_s) - min(win_s)


def drift_text(w: WarmupSetup, readings: int, drift_ifm: float, drift_sensor: float, elapsed: float) -> str:
    """The warm-up line shown after every reading: drift so far against the limits."""
    if not math.isfinite(drift_ifm):
        return f"warm-up {elapsed:.0f} s: reading {readings} of at least {w.window}"
    ok = "within" if drift_ifm <= w.max_drift_ifm_um and drift_sensor <= w.max_drift_sensor_um else "above"
    span = min(readings, w.window)
    return (f"warm-up {elapsed:.0f} s: drift over the last {span} of {w.window} readings: interferometer "
            f"{drift_ifm:.2f} / {w.max_drift_ifm_um:g} um, sensor {drift_sensor:.2f} / {w.max_drift_sensor_um:g} um "
            f"({ok} the limits)")


def warmup(w: WarmupSetup, samples: int) -> Generator[Message, Any, dict[str, Any]]:
    """Watch interferometer and sensor drift until stable or overridden; return run.json ``warmup``.
    After every reading the drift so far is logged against the limits."""
    ifm_hist: list[tuple[float, float]] = []
    sen_hist: list[float] = []
    elapsed = since_prompt = 0.0
    drift_ifm = drift_sensor = math.nan

    def progress(state: str) -> dict[str, Any]:  # the display's view of the warm-up (Progress "warmup")
        return {"state": state, "elapsed_s": elapsed, "readings": len(sen_hist), "window": w.window,
                "drift_ifm_um": drift_ifm, "drift_sensor_um": drift_sensor, "max_drift_ifm_um": w.max_drift_ifm_um,
                "max_drift_sensor_um": w.max_drift_sensor_um, "timeout_s": w.timeout_s}

    yield Log(f"warm-up: waiting for drift below {w.max_drift_ifm_um:g} um (interferometer) and "
              f"{w.max_drift_sensor_um:g} um (sensor) over {w.window} readings")
    while True:
        ifm = yield TriggerInterferometer()
        sen = yield ReadSensor(samples)
        if ifm.ok and sen.ok:
            ifm_hist.append((ifm.stry_um, ifm.strz_um))
            sen_hist.append(sen.mean_mm * 1000.0)
        drift_ifm, drift_sensor = window_drift(ifm_hist, sen_hist, w.window)
        yield Log(drift_text(w, len(sen_hist), drift_ifm, drift_sensor, elapsed))
        if len(sen_hist) >= w.window and drift_ifm <= w.max_drift_ifm_um and drift_sensor <= w.max_drift_sensor_um:
            stable, overridden = True, False
            break
        yield Progress("warmup", progress("drifting"))
        if (yield Requested("override")):  # the operator overrides before the timeout (TUI key o)
            stable, overridden = False, True
            break
        if since_prompt >= w.timeout_s:
            answer = yield Prompt(
                f"Warm-up not stable after {elapsed:.0f} s (drift {drift_ifm:.2f} um interferometer, "
                f"{drift_sensor:.2f} um sensor). Keep waiting, override (recorded in the run) or abort?",
                ("wait", "override", "abort"), default="wait", key="warmup")
            if answer == "override":
                stable, overridden = False, True
                break
            since_prompt = 0.0
        waited = yield Wait(w.interval_s)
        elapsed += waited
        since_prompt += max(waited, w.interval_s)  # count planned time so a zero-latency run still times out
    yield Progress("warmup", progress("stable" if stable else "overridden"))
    drift = {"ifm_um": drift_ifm, "sensor_um": drift_sensor, "window": w.window, "readings": len(sen_hist)}
    drift = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in drift.items()}
    yield Log(f"warm-up {'stable' if stable else 'overridden by the operator'} after {elapsed:.0f} s")
    return {"stable": stable, "overridden": overridden, "duration_s": elapsed, "drift": drift}


def _sentence(text: str) -> str:
    return text if text.endswith((".", "?", "!")) else text + "."


def _place_text(p: int, k: int, x: float, first_return: bool) -> str:
    if first_return:
        return (f"Return pass: leave the block at station {k} (x = {x:g} mm), against the side face; "
                f"capture when it is still.")
    where = "Return pass: move" if p == 1 else "Move"
    return f"{where} the block to station {k} (x = {x:g} mm), against the side face; capture when it is still."


def arrival(setup: StraightnessSetup, p: int, k: int, x: float) -> Generator[Message, Any, bool]:
    """Hands-free: poll the interferometer until the block rests at station k; False if the operator
    skips the station after the timeout.

    At the station: |position - x| within ``[validation] max_lin_um``.  At rest: position,
    straightness Y and Z stay within ``[auto] still_um`` (peak to peak) over ``still_s``; a reading
    off the station, or not valid, starts the window again.
    """
    a, v = setup.auto, setup.validation
    where = f"station {k}{' (return)' if p else ''} (x = {x:g} mm)"
    yield Log(f"hands-free: waiting for the block at {where}")
    # (position um, stry um, strz um) still for still_s: the rule of the TUI's stability light too
    window = StillnessWindow(a.still_um, a.still_s)
    t_first: float | None = None
    waited = 0.0
    while True:
        ifm = yield TriggerInterferometer()
        lin_um = (ifm.position_mm - x) * 1000.0
        t_first = ifm.timestamp_s if t_first is None else t_first
        if ifm.ok and math.isfinite(lin_um) and abs(lin_um) <= v.max_lin_um:
            if window.add(ifm.timestamp_s, straightness_channels(ifm)) == STABLE:
                return True
        else:
            window.clear()
        waited += max((yield Wait(a.poll_s)), a.poll_s)
        if max(waited, ifm.timestamp_s - t_first) >= a.station_timeout_s:
            answer = yield Prompt(
                f"The block did not come to rest at {where} within {a.station_timeout_s:g} s (last reading "
                f"{lin_um:+.0f} um from it). Keep waiting, skip this station (recorded), or abort?",
                ("wait", "skip", "abort"), default="wait", key="arrival",
                fault=f"block not at rest at {where} within {a.station_timeout_s:g} s")
            if answer == "skip":
                return False
            waited, t_first = 0.0, None


def _rests_within(setup: StraightnessSetup, x: float, limit_s: float) -> Generator[Message, Any, bool]:
    """Poll the interferometer for up to ``limit_s``: True as soon as the block rests at x (the rule of
    :func:`arrival`), False if it does not within the time."""
    a, v = setup.auto, setup.validation
    window = StillnessWindow(a.still_um, a.still_s)
    t_first: float | None = None
    waited = 0.0
    while True:
        ifm = yield TriggerInterferometer()
        t_first = ifm.timestamp_s if t_first is None else t_first
        lin_um = (ifm.position_mm - x) * 1000.0
        if ifm.ok and math.isfinite(lin_um) and abs(lin_um) <= v.max_lin_um:
            if window.add(ifm.timestamp_s, straightness_channels(ifm)) == STABLE:
                return True
        else:
            window.clear()
        if max(waited, ifm.timestamp_s - t_first) >= limit_s:
            return False
        waited += max((yield Wait(a.poll_s)), a.poll_s)


def still_before_capture(setup: StraightnessSetup, p: int, k: int, x: float) -> Generator[Message, Any, str]:
    """After the operator's ``capture``: is the block still (the rule of the stability light and of
    ``--auto``, :mod:`acquisition.stillness`)?  ``"still"``; ``"not_still"`` when the operator captures
    anyway (the point is marked ``not_still``); ``"skip"`` when, waiting for it, the operator skips.

    The operator says what its live view showed (:class:`Stillness`); one without a live view (``look``)
    has the plan poll the interferometer for the rule's time first; one that does not judge (None) is
    not asked.  A block not still is a question: wait until it is (then capture), capture now, abort.
    """
    seen = yield Stillness()
    if seen is None or seen == STABLE:
        return "still"
    a = setup.auto
    if seen == LOOK:
        if (yield from _rests_within(setup, x, a.still_s + 2 * a.poll_s)):
            return "still"
        seen = "not at rest"
    where = f"station {k}{' (return)' if p else ''} (x = {x:g} mm)"
    answer = yield Prompt(
        f"The block is not still at {where}: {seen} (still = within {a.still_um:g} um for {a.still_s:g} s). "
        f"Wait until it is still, capture now (the point is marked not_still in points.csv), or abort?",
        ("wait", "capture", "abort"), default="wait", key="still")
    if answer == "capture":
        yield Log(f"{where}: captured while not still ({seen}); marked not_still")
        return "not_still"
    return "still" if (yield from arrival(setup, p, k, x)) else "skip"


def _capture(setup: StraightnessSetup, k: int, x: float) -> Generator[Message, Any, tuple | None]:
    """Trigger + averaged sensor reading, validated; None if the operator skips the station."""
    v = setup.validation
    attempt = 0
    while True:
        ifm = yield TriggerInterferometer()
        sensor = yield ReadSensor(setup.samples_per_reading)
        problem = capture_problem(ifm, sensor, k, x, v)
        if problem is None:
            return ifm, sensor
        attempt += 1
        yield Log(f"{problem} (attempt {attempt} of {v.capture_attempts})")
        if attempt < v.capture_attempts:
            continue
        answer = yield Prompt(f"{_sentence(problem)} Retry the capture, skip this station (recorded), or abort?",
                              ("retry", "skip", "abort"), default="retry", key="invalid", fault=problem)
        if answer == "skip":
            return None
        attempt = 0


def straightness_plan(setup: StraightnessSetup, metadata: dict[str, Any],
                      resume: ResumePoint | None = None, *, hands_free: bool = False) -> Generator[Message, Any, None]:
    """Yield the messages of a complete (or resumed) straightness run; ``hands_free``: wait for the
    block at each station instead of asking (:func:`arrival`)."""
    steps = setup.steps()
    points: dict[Step, dict[str, Any]] = {}
    skipped: list[dict[str, Any]] = []
    if resume is None:
        t0 = yield OpenRun("straightness", metadata)
        yield Annotate("start_time_s", t0)
        yield Instruct("place_block",
                       "Place the block at station 0 (x = 0 mm), against the side face; then confirm.",
                       {"station": 0, "pass": 0}, key="datum")
        if setup.warmup.enabled:
            yield Annotate("warmup", (yield from warmup(setup.warmup, setup.samples_per_reading)))
        yield ZeroInterferometer()
        yield Log("datum set: interferometer zeroed at station 0")
        i = 0
    else:
        yield OpenRun("straightness", metadata, resume_uid=resume.uid)
        t0, i = resume.t0, resume.next_index
        points.update(resume.points)
        skipped.extend(resume.skipped)
        if i < len(steps):
            p, k = steps[i]
            yield Prompt(f"Resuming the run at station {k} (pass {p}), {len(points)} points on disk. The "
                         f"interferometer must not have been re-zeroed since the run started. Continue?",
                         ("continue", "abort"), key="resume")
    jump_redos = 0
    while i < len(steps):
        p, k = steps[i]
        x = setup.station_x_mm(k)
        not_still = False
        if (p, k) != (0, 0) and hands_free:
            if not (yield from arrival(setup, p, k, x)):
                skipped.append({"station": k, "pass": p, "reason": "the block did not arrive; skipped"})
                yield Annotate("skipped", list(skipped))
                yield Annotate("progress", {"pass": p, "station": k})
                i += 1
                continue
        elif (p, k) != (0, 0):
            can_redo = i > 1  # the datum station is never redone (it would move the datum)
            choices = ("capture", "redo", "skip", "pause", "abort") if can_redo else ("capture", "skip", "pause",
                                                                                      "abort")
            first_return = p == 1 and k == setup.stations - 1
            answer = yield Instruct("place_block", _place_text(p, k, x, first_return), {"station": k, "pass": p},
                                    choices=choices, key="station")
            if answer == "redo":
                pp, pk = steps[i - 1]
                if (pp, pk) in points:
                    yield Retract({"station": pk, "pass": pp})
                    del points[(pp, pk)]
                skipped = [s for s in skipped if (s["pass"], s["station"]) != (pp, pk)]
                yield Annotate("skipped", list(skipped))
                yield Log(f"redo: back to station {pk} (pass {pp})")
                i -= 1
                continue
            if answer == "skip":
                skipped.append({"station": k, "pass": p, "reason": "skipped by the operator"})
                yield Annotate("skipped", list(skipped))
                yield Annotate("progress", {"pass": p, "station": k})
                yield Log(f"station {k} (pass {p}) skipped")
                i += 1
                continue
            settled = yield from still_before_capture(setup, p, k, x)
            if settled == "skip":
                skipped.append({"station": k, "pass": p, "reason": "the block did not come to rest; skipped"})
                yield Annotate("skipped", list(skipped))
                yield Annotate("progress", {"pass": p, "station": k})
                i += 1
                continue
            not_still = settled == "not_still"
        got = yield from _capture(setup, k, x)
        if got is None:
            skipped.append({"station": k, "pass": p, "reason": "capture failed validation; skipped"})
            yield Annotate("skipped", list(skipped))
            yield Annotate("progress", {"pass": p, "station": k})
            i += 1
            continue
        ifm, sensor = got
        row = point_record(k, x, t0, ifm, sensor, p, not_still)
        jump = jump_problem(row, points.get(steps[i - 1]) if i > 0 else None, setup.validation)
        if jump is not None:
            redo_default = jump_redos < setup.validation.capture_attempts
            answer = yield Prompt(f"{_sentence(jump)} Redo the capture or accept the reading?",
                                  ("redo", "accept", "abort"),
                                  default="redo" if redo_default else "accept", key="jump")
            if answer == "redo":
                jump_redos += 1
                continue
            yield Log(f"jump accepted by the operator: {jump}")
        jump_redos = 0
        yield Record(row)
        points[(p, k)] = row
        yield Annotate("progress", {"pass": p, "station": k})
        yield Log(f"station {k:3d}{' (return)' if p else ''}  x = {x:8.1f} mm  stry = {ifm.stry_um:+8.3f} um  "
                  f"sensor = {sensor.mean_mm:+.5f} mm{'  (not still)' if not_still else ''}")
        i += 1
    n_skip = len(skipped)
    yield CloseRun("all stations captured" + (f" ({n_skip} skipped)" if n_skip else ""))
