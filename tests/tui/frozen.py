"""Fixed screen states for the snapshot tests: a session that never runs, with readings, a warm-up,
points and questions that do not change with time (no clock, uid or temporary path on screen)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from acquisition.messages import Instruct, Prompt
from acquisition.monitor import LiveReading
from acquisition.plans.straightness import point_record, straightness_plan
from acquisition.setup.files import setup_from_dict
from drivers.readings import AveragedDisplacement, ControllerStatus, InterferometerReading
from tests.tui.sessions import POSITIONING, STRAIGHTNESS
from tui.app import plan_info
from tui.messages import LiveReadingArrived, OperatorQuestion, RunDocument
from tui.session import RunSession

ROOT = Path(__file__).resolve().parents[2]
RUNS = Path("tests/data/tui-runs")  # relative: the snapshots run with the repository as working directory

STATUS = ControllerStatus(ready=True, busy=False, data_valid=True, error=False, beam_ok=True, sequence=41,
                          error_code=0, error_text="", raw_status=0x0015)


def ifm(position_mm: float = 200.0021, stry_um: float = -2.745) -> InterferometerReading:
    return InterferometerReading(position_mm=position_mm, stry_um=stry_um, strz_um=0.512, pitch_urad=-3.21,
                                 yaw_urad=1.07, roll_urad=0.44, air_temp_c=20.412, air_pressure_hpa=1012.81,
                                 humidity_pct=45.1, material_temp_c=20.205, sequence=41, status=STATUS,
                                 timestamp_s=0.0)


def datum_instruction() -> Instruct:
    """The plan's own first instruction (the datum placement)."""
    plan = straightness_plan(setup_from_dict(STRAIGHTNESS), {})
    plan.send(None)  # OpenRun
    plan.send(0.0)  # Annotate start_time_s
    msg = plan.send(None)
    assert isinstance(msg, Instruct)
    return msg


def straightness_session(stage: str) -> RunSession:
    setup = setup_from_dict(STRAIGHTNESS)
    s = RunSession(lambda _m: None, plan_info(setup), STRAIGHTNESS, RUNS / "new", simulate=None)
    v = s.view
    v.started, v.state = True, "running"
    v.reading = LiveReading(0.0, sensor_mm=0.01234, sensor_status="ok", sensor_mean_mm=0.01234, sensor_count=1,
                            interferometer=ifm())
    v.live_history.extend(0.0123 + 0.0002 * ((i * 7) % 5) / 5 for i in range(60))
    v.log.extend(["simulated sensor     : keyence-lkg on SENSOR (pty)", "simulated controller : modbus-tcp://HOST",
                  "warm-up: waiting for drift below 0.5 um (interferometer) and 0.5 um (sensor) over 2 readings"])
    if stage == "warmup":
        v.question, v.ticket = datum_instruction(), 1
        v.warmup = {"state": "drifting", "elapsed_s": 14.0, "readings": 7, "window": 5, "drift_ifm_um": 0.31,
                    "drift_sensor_um": 0.72, "max_drift_ifm_um": 0.5, "max_drift_sensor_um": 0.5, "timeout_s": 1800.0}
        return s
    # three points as the plan records them (the live profile computes their heights), then station 3 asked
    # for, the block there and still for the [auto] still_s (2 s of 0.25 s captures: the light is STABLE)
    for k, (stry_um, sensor_mm) in enumerate([(0.0, 0.01234), (-1.372, 0.01221), (-2.745, 0.01207)]):
        row = point_record(k, 100.0 * k, 0.0, ifm(position_mm=100.0 * k, stry_um=stry_um),
                           AveragedDisplacement(sensor_mm, 0.0, 5, 0, 0.0))
        s.apply(RunDocument("event", {"data": row}))
    v.heights.update(s.live().profile.heights)  # (what acquire's own LiveProfile posts as HeightArrived)
    s.apply(OperatorQuestion(Instruct("place_block", "Move the block to station 3 (x = 300 mm), against the side "
                                      "face; capture when it is still.", {"station": 3, "pass": 0},
                                      choices=("capture", "redo", "skip", "pause", "abort"), key="station"), 1))
    for i in range(9):
        s.apply(LiveReadingArrived(LiveReading(
            0.0, sensor_mm=0.01193, sensor_status="ok", sensor_mean_mm=0.01193, sensor_count=1,
            interferometer=dataclasses.replace(ifm(position_mm=300.0021, stry_um=-4.118), timestamp_s=0.25 * i))))
    v.log.extend(["station   2  x =    200.0 mm  stry =   -2.745 um  sensor = +0.01207 mm"])
    return s


ROTARY = {"kind": "positioning", "machine": "test bench", "operator": "pilot",
          "axis": {"name": "C", "type": "rotary", "start_deg": 0.0, "end_deg": 360.0, "runs": 2},
          "trigger": {"mode": "in-position", "dwell_s": 0.0}}


def rotary_session() -> RunSession:
    """A rotary run at target 3 (90 deg): the controller reports the angle from the datum, not a position."""
    setup = setup_from_dict(ROTARY)
    s = RunSession(lambda _m: None, plan_info(setup), ROTARY, RUNS / "new", simulate=None)
    v = s.view
    v.started, v.state = True, "running"
    # the axis 0.000712 deg (2.6 arcsec) beyond the next stop (run 1 up, the 4th target)
    v.reading = LiveReading(0.0, interferometer=ifm(position_mm=0.0, stry_um=0.0),
                            angle_deg=setup.measured_stops()[3].position - setup.datum + 0.000712)
    for i, (t, d) in enumerate(zip(setup.targets[:3], (0.0, 3.1, 2.6), strict=True), start=1):
        v.deviations[(1, 1, i)] = (t, d)
    v.deviation_label = "angular, not air-compensated"
    v.points = 3
    v.rows.append({"run": 1, "direction": 1, "target_index": 3, "target_deg": 90.0, "reading_deg": 90.000722})
    v.question = Instruct("cycle_start", "Start the part program of this cycle (guideway gcode) with Cycle Start.",
                          {}, choices=("started", "abort"), key="start")
    s.apply(LiveReadingArrived(v.reading))
    return s


def positioning_session() -> RunSession:
    setup = setup_from_dict(POSITIONING)
    s = RunSession(lambda _m: None, plan_info(setup), POSITIONING, RUNS / "new", simulate=None)
    v = s.view
    v.started, v.state = True, "running"
    devs = [(0.0, 0.0), (48.7, 1.9), (101.3, 3.2), (152.1, 2.4), (200.0, 4.1)]
    for i, (t, d) in enumerate(devs, start=1):
        v.deviations[(1, 1, i)] = (t, d)
        v.deviations[(1, -1, i)] = (t, d - 2.8)
    v.deviation_label = "environment-compensated"
    v.points = 7  # the next stop: run 1, down, the 3rd target
    v.rows.append({"run": 1, "direction": -1, "target_index": 4, "target_mm": 152.1, "reading_mm": 152.1024,
                   "air_temp_c": 20.412, "air_pressure_hpa": 1012.81, "humidity_pct": 45.1, "material_temp_c": 20.205})
    v.question = Instruct("cycle_start", "Start the part program of this cycle (guideway gcode) with Cycle Start.",
                          {}, choices=("started", "abort"), key="start")
    near = setup.measured_stops()[7].position + 0.0042  # the axis 4.2 um beyond it (raw)
    s.apply(LiveReadingArrived(LiveReading(0.0, interferometer=ifm(position_mm=near, stry_um=0.0))))
    return s


JUMP = Prompt("station 3 (pass 0) vs station 2 (pass 0): straightness jumped by 61.2 um (limit 50 um). "
              "Redo the capture or accept the reading?", ("redo", "accept", "abort"), default="redo", key="jump")
FAULT_TEXT = ("displacement sensor (keyence-lkg on SENSOR): no reply ending in b'\\r' within 0.5 s (got b''); "
              "check the cable, baud rate and protocol setting")
FAULT = Prompt(f"Device fault: {FAULT_TEXT}. Check the device, its cable and power, then retry (the tool "
               "reconnects and repeats the step), or abort the run.", ("retry", "abort"), key="fault",
               fault=FAULT_TEXT)
