"""The complete straightness workflow as message sequences (no devices): skip,
redo, jump check, validation, warm-up, return pass and resume; then the
engine's pause / fault-pause / reconnect behaviour with fake devices."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import pytest

from acquisition import messages as m
from acquisition.engine import RunEngine, RunState
from acquisition.operators import AutoOperator
from acquisition.plans.straightness import ResumePoint, capture_problem, resume_point, straightness_plan
from acquisition.rig import Rig
from acquisition.setup.straightness import StraightnessSetup, WarmupSetup
from drivers.errors import ConnectionLost
from drivers.readings import AveragedDisplacement, ControllerStatus, InterferometerReading, MeasurementStatus
from processing.geometry import BlockGeometry
from saved_runs.evaluation.limits import ValidationSetup

from .plan_driver import drive

GEOM = BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0))
OK = ControllerStatus(True, False, True, False, True, 1, 0, "", 0b10101)
BEAM_LOST = ControllerStatus(True, False, False, True, False, 1, 1, "beam interrupted", 0b01001)


def setup(n: int = 5, **kw: Any) -> StraightnessSetup:
    return StraightnessSetup(block_length_mm=100.0, stations=n, geometry=GEOM, samples_per_reading=3, **kw)


def reading(position_mm: float, stry_um: float = 0.0, status: ControllerStatus = OK, t: float = 0.0
            ) -> InterferometerReading:
    return InterferometerReading(position_mm, stry_um, 0.0, 0.0, 0.0, 0.0, 20.0, 1013.0, 45.0, 20.0, 1, status, t)


def good_sensor(v_mm: float = 0.0) -> AveragedDisplacement:
    return AveragedDisplacement(v_mm, 0.0001, 3, 0, 0.0)


BAD_SENSOR = AveragedDisplacement(math.nan, math.nan, 0, 3, 0.0, (MeasurementStatus.OVER_RANGE_HIGH,))


class Bench:
    """Answers a plan's messages like a rig: the block is where the last Instruct put it.

    ``stry`` maps (station, capture number at that station) to a straightness value;
    ``answers`` maps (message key, station) to a list of answers used in turn.
    """

    def __init__(self, answers: dict[tuple[str, int], list[str]] | None = None,
                 stry: Callable[[int, int], float] = lambda k, n: 0.1 * k,
                 sensor: Callable[[int, int], AveragedDisplacement] = lambda k, n: good_sensor(0.001 * k)) -> None:
        self.station = 0
        self.captures: dict[int, int] = {}
        self.sensor_reads: dict[int, int] = {}
        self.answers = answers or {}
        self.stry = stry
        self.sensor = sensor
        self.msgs: list[Any] = []
        self.points: list[dict] = []  # what a run store would hold (records minus retractions)
        self.meta: dict[str, Any] = {}

    def answer(self, key: str, default: str) -> str:
        queue = self.answers.get((key, self.station))
        return queue.pop(0) if queue else default

    def __call__(self, msg: Any) -> Any:
        self.msgs.append(msg)
        if isinstance(msg, m.OpenRun):
            return 1000.0
        if isinstance(msg, m.Instruct):
            self.station = msg.params["station"]
            return self.answer(msg.key, msg.choices[0])
        if isinstance(msg, m.Prompt):
            return self.answer(msg.key, msg.default or msg.choices[0])
        if isinstance(msg, m.TriggerInterferometer):
            n = self.captures.get(self.station, 0)
            self.captures[self.station] = n + 1
            return reading(100.0 * self.station, self.stry(self.station, n), t=1000.0 + self.station)
        if isinstance(msg, m.ReadSensor):
            n = self.sensor_reads.get(self.station, 0)
            self.sensor_reads[self.station] = n + 1
            return self.sensor(self.station, n)
        if isinstance(msg, m.Record):
            self.points.append(msg.data)
        if isinstance(msg, m.Retract):
            last = self.points[-1]
            assert all(last[k] == v for k, v in msg.match.items())
            self.points.pop()
        if isinstance(msg, m.Annotate):
            self.meta[msg.key] = msg.value
        if isinstance(msg, m.Wait):
            return msg.seconds
        return None


def stations(points: list[dict]) -> list[tuple[int, int]]:
    return [(p["pass"], p["station"]) for p in points]


def of(bench: Bench, kind: type) -> list[Any]:
    return [x for x in bench.msgs if isinstance(x, kind)]


def test_skip_is_recorded_and_the_run_goes_on() -> None:
    b = drive(straightness_plan(setup(5), {}), Bench({("station", 2): ["skip"]}))
    assert stations(b.points) == [(0, 0), (0, 1), (0, 3), (0, 4)]
    assert b.meta["skipped"] == [{"station": 2, "pass": 0, "reason": "skipped by the operator"}]
    assert b.meta["progress"] == {"pass": 0, "station": 4}
    assert "1 skipped" in of(b, m.CloseRun)[0].reason


def test_redo_withdraws_the_previous_point_and_captures_it_again() -> None:
    b = drive(straightness_plan(setup(5), {}), Bench({("station", 3): ["redo"]},
                                                    stry=lambda k, n: 0.1 * k + n))  # n: capture count
    assert stations(b.points) == [(0, k) for k in range(5)]
    assert [r.match for r in of(b, m.Retract)] == [{"station": 2, "pass": 0}]
    assert b.points[2]["stry_um"] == pytest.approx(0.2 + 1)  # the second capture at station 2
    assert [i.params["station"] for i in of(b, m.Instruct)] == [0, 1, 2, 3, 2, 3, 4]


def test_redo_of_a_skipped_station_unskips_it() -> None:
    b = drive(straightness_plan(setup(5), {}), Bench({("station", 2): ["skip"], ("station", 3): ["redo"]}))
    assert stations(b.points) == [(0, k) for k in range(5)]
    assert b.meta["skipped"] == [] and of(b, m.Retract) == []


def test_datum_station_is_never_redone() -> None:
    b = drive(straightness_plan(setup(3), {}), Bench())
    first_station_instruct = [i for i in of(b, m.Instruct) if i.key == "station"][0]
    assert first_station_instruct.params["station"] == 1 and "redo" not in first_station_instruct.choices


def test_jump_asks_and_redo_recaptures() -> None:
    # station 2 reads 100 um off on its first capture only: the check must catch it (limit 50 um)
    b = drive(straightness_plan(setup(4), {}),
              Bench(stry=lambda k, n: 100.0 if (k, n) == (2, 0) else 0.1 * k))
    jumps = [p for p in of(b, m.Prompt) if p.key == "jump"]
    assert len(jumps) == 1 and "jumped by 99.9 um" in jumps[0].text and jumps[0].default == "redo"
    assert b.points[2]["stry_um"] == pytest.approx(0.2)
    assert stations(b.points) == [(0, k) for k in range(4)]


def test_jump_accepted_keeps_the_reading() -> None:
    b = drive(straightness_plan(setup(4), {}),
              Bench({("jump", 2): ["accept"]}, stry=lambda k, n: 100.0 if k == 2 else 0.1 * k))
    assert b.points[2]["stry_um"] == 100.0
    # station 3 jumps back by 99.7 um against station 2: asked again (default redo, then accept)
    assert len([p for p in of(b, m.Prompt) if p.key == "jump"]) >= 2


def test_invalid_capture_is_retried_then_the_operator_decides() -> None:
    v = ValidationSetup(capture_attempts=3)
    bench = Bench({("invalid", 2): ["skip"]},
                  sensor=lambda k, n: BAD_SENSOR if k == 2 else good_sensor(0.001 * k))
    b = drive(straightness_plan(setup(4, validation=v), {}), bench)
    assert b.captures[2] == 3  # three automatic attempts, then the question
    asked = [p for p in of(b, m.Prompt) if p.key == "invalid"]
    assert len(asked) == 1 and "over-range-high" in asked[0].text and asked[0].fault
    assert stations(b.points) == [(0, 0), (0, 1), (0, 3)]
    assert b.meta["skipped"][0]["station"] == 2 and "validation" in b.meta["skipped"][0]["reason"]


@pytest.mark.parametrize(
    ("ifm", "sensor", "fragment"),
    [
        (reading(200.0, status=BEAM_LOST), good_sensor(), "interferometer data not valid"),
        (reading(200.0, stry_um=math.inf), good_sensor(), "interferometer data not valid"),
        (reading(200.0), BAD_SENSOR, "sensor reading invalid"),
        (reading(200.0), AveragedDisplacement(0.0, 0.0030, 5, 0, 0.0), "sensor not stable (std 3.00 um"),
        (reading(200.0), good_sensor(60.0), "outside the plausible range"),
        (reading(200.0, stry_um=1500.0), good_sensor(), "stry_um = +1500.0 um"),
        (reading(203.0), good_sensor(), "is it at the right station"),
    ],
)
def test_capture_checks(ifm, sensor, fragment: str) -> None:
    problem = capture_problem(ifm, sensor, 2, 200.0, ValidationSetup())
    assert problem is not None and fragment in problem and problem.startswith("station 2:")


def test_capture_check_passes_a_good_reading() -> None:
    assert capture_problem(reading(200.0015, 12.0), AveragedDisplacement(0.5, 0.0015, 5, 0, 0.0), 2, 200.0,
                           ValidationSetup()) is None


def test_return_pass_steps_back_over_the_stations() -> None:
    b = drive(straightness_plan(setup(4, return_pass=True), {}), Bench())
    assert stations(b.points) == [(0, 0), (0, 1), (0, 2), (0, 3), (1, 3), (1, 2), (1, 1), (1, 0)]
    assert [p["x_mm"] for p in b.points] == [0.0, 100.0, 200.0, 300.0, 300.0, 200.0, 100.0, 0.0]
    first_return = [i for i in of(b, m.Instruct) if i.params.get("pass") == 1][0]
    assert "leave the block at station 3" in first_return.text
    assert b.meta["progress"] == {"pass": 1, "station": 0}


def test_warmup_waits_for_a_stable_window() -> None:
    drifting = [0.0, 3.0, 5.0, 5.1, 5.2, 5.2]  # the first 3-reading window within 0.5 um ends at index 4
    w = WarmupSetup(window=3, interval_s=10.0, max_drift_ifm_um=0.5, max_drift_sensor_um=0.5, timeout_s=1e6)
    bench = Bench(stry=lambda k, n: drifting[n] if n < len(drifting) else 0.0)
    b = drive(straightness_plan(setup(3, warmup=w), {}), bench)
    wu = b.meta["warmup"]
    assert wu["stable"] is True and wu["overridden"] is False
    assert wu["drift"]["readings"] == 5 and wu["drift"]["ifm_um"] == pytest.approx(0.2)
    assert wu["duration_s"] == pytest.approx(40.0)  # four intervals between five readings
    kinds = [type(x).__name__ for x in b.msgs]
    assert kinds.index("ZeroInterferometer") > kinds.index("Annotate")  # datum after the warm-up


def test_warmup_override_is_recorded() -> None:
    w = WarmupSetup(window=2, interval_s=5.0, max_drift_ifm_um=0.5, max_drift_sensor_um=0.5, timeout_s=20.0)
    bench = Bench({("warmup", 0): ["wait", "override"]}, stry=lambda k, n: 10.0 * (n % 2))
    b = drive(straightness_plan(setup(3, warmup=w), {}), bench)
    wu = b.meta["warmup"]
    assert wu == {"stable": False, "overridden": True, "duration_s": 40.0,
                  "drift": {"ifm_um": 10.0, "sensor_um": 0.0, "window": 2, "readings": 9}}
    assert len([p for p in of(b, m.Prompt) if p.key == "warmup"]) == 2


def test_resume_point_from_points_and_skips() -> None:
    s = setup(5, return_pass=True)
    rows = [{"pass": 0, "station": k} for k in range(5)] + [{"pass": 1, "station": 4}]
    meta = {"uid": "u", "start_time_s": 5.0, "skipped": [{"pass": 1, "station": 3, "reason": "x"}]}
    rp = resume_point(meta, rows, s.steps())
    assert rp.next_index == 7 and s.steps()[7] == (1, 2) and rp.uid == "u" and rp.t0 == 5.0
    assert resume_point({}, [], s.steps()).next_index == 0


def test_resumed_plan_continues_after_the_last_step() -> None:
    s = setup(5)
    done = {(0, k): {"pass": 0, "station": k, "stry_um": 0.1 * k, "strz_um": 0.0, "sensor_mm": 0.001 * k}
            for k in range(3)}
    b = drive(straightness_plan(s, {}, resume=ResumePoint("uid-1", 900.0, 3, done)), Bench())
    opened = of(b, m.OpenRun)[0]
    assert opened.resume_uid == "uid-1"
    assert not of(b, m.ZeroInterferometer)  # the datum is kept
    assert [p.key for p in of(b, m.Prompt)] == ["resume"]
    assert stations(b.points) == [(0, 3), (0, 4)]
    assert b.points[0]["time_s"] == pytest.approx(1003.0 - 900.0)  # relative to the original start


# -- engine behaviour with fake devices ---------------------------------------------------------
class FakeController:
    def __init__(self, fail_calls: set[int] = frozenset()) -> None:
        self.calls = 0
        self.fail_calls = fail_calls
        self.station = 0

    def zero(self) -> ControllerStatus:
        return OK

    def trigger_and_read(self) -> InterferometerReading:
        self.calls += 1
        if self.calls in self.fail_calls:
            raise ConnectionLost("controller modbus-tcp://x: connection lost")
        return reading(100.0 * self.station, 0.1 * self.station)

    def close(self) -> None:
        pass


class FakeSensor:
    def read_averaged(self, samples: int) -> AveragedDisplacement:
        return good_sensor()

    def close(self) -> None:
        pass


class Scripted(AutoOperator):
    """Automatic operator that places the block on the fake controller and follows a script."""

    def __init__(self, ctl: FakeController, script: dict[tuple[str, int], list[str]] | None = None,
                 on_instruct: Callable[[int], None] | None = None) -> None:
        super().__init__()
        self.ctl = ctl
        self.script = script or {}
        self.on_instruct = on_instruct
        self.asked: list[str] = []

    def instruct(self, msg: m.Instruct) -> str:
        self.ctl.station = msg.params["station"]
        if self.on_instruct:
            self.on_instruct(self.ctl.station)
        queue = self.script.get((msg.key, self.ctl.station))
        return queue.pop(0) if queue else msg.choices[0]

    def prompt(self, msg: m.Prompt) -> str:
        self.asked.append(msg.key)
        queue = self.script.get((msg.key, self.ctl.station))
        return queue.pop(0) if queue else super().prompt(msg)


def run_engine(ctl: FakeController, op: AutoOperator, reopen=None, n: int = 5):
    events: list[tuple[str, dict]] = []
    rig = Rig(FakeSensor(), ctl, reopen)  # type: ignore[arg-type]
    eng = RunEngine(rig, op, (lambda name, doc: events.append((name, doc)),))
    return eng, eng.run(straightness_plan(setup(n), {})), events


def test_operator_pause_then_resume() -> None:
    ctl = FakeController()
    op = Scripted(ctl, {("station", 2): ["pause"], ("pause", 2): ["resume"]})
    eng, out, events = run_engine(ctl, op)
    assert out.exit_status == "success" and out.num_events == 5
    assert op.asked == ["pause"]
    assert eng.state_log == [RunState.IDLE, RunState.RUNNING, RunState.PAUSED, RunState.RUNNING,
                             RunState.STOPPING, RunState.IDLE]


def test_pause_requested_from_another_thread_then_abort() -> None:
    ctl = FakeController()
    eng_box: list[RunEngine] = []
    op = Scripted(ctl, {("pause", 3): ["abort"]},
                  on_instruct=lambda k: eng_box[0].request_pause() if k == 3 else None)
    rig = Rig(FakeSensor(), ctl)  # type: ignore[arg-type]
    eng = RunEngine(rig, op, ())
    eng_box.append(eng)
    out = eng.run(straightness_plan(setup(6), {}))
    assert out.exit_status == "abort" and "paused" in out.reason
    assert out.num_events == 3  # stations 0-2; the pause came before station 3 was captured
    assert RunState.PAUSED in eng.state_log and eng.state_log[-2:] == [RunState.ABORTING, RunState.IDLE]


def test_device_fault_pauses_reconnects_and_continues() -> None:
    ctl = FakeController(fail_calls={3})  # the third trigger loses the connection
    reopened: list[bool] = []

    def reopen() -> Rig:
        reopened.append(True)
        return Rig(FakeSensor(), ctl)  # type: ignore[arg-type]

    op = Scripted(ctl)
    eng, out, events = run_engine(ctl, op, reopen)
    assert out.exit_status == "success" and out.num_events == 5
    assert op.asked == ["fault"] and reopened == [True]
    assert eng.faults == ["controller modbus-tcp://x: connection lost"]
    states = [d["state"] for n, d in events if n == "state"]
    assert states == ["running", "paused", "running", "stopping", "idle"]
    assert [d["data"]["station"] for n, d in events if n == "event"] == [0, 1, 2, 3, 4]


def test_fault_abort_fails_the_run_with_the_fault_as_reason() -> None:
    ctl = FakeController(fail_calls={2})
    op = Scripted(ctl, {("fault", 1): ["abort"]})
    eng, out, events = run_engine(ctl, op)
    assert out.exit_status == "fail" and "connection lost" in out.reason and out.num_events == 1
    assert [n for n, _ in events if n != "state"][-1] == "stop"


def test_an_answer_outside_the_choices_fails_clearly() -> None:
    ctl = FakeController()
    op = Scripted(ctl, {("station", 1): ["sideways"]})
    _, out, _ = run_engine(ctl, op)
    assert out.exit_status == "fail" and "'sideways'" in out.reason


def test_annotate_and_retract_reach_subscribers() -> None:
    ctl = FakeController()
    op = Scripted(ctl, {("station", 3): ["redo"]})
    _, out, events = run_engine(ctl, op)
    assert out.exit_status == "success" and out.num_events == 5
    assert [d["match"] for n, d in events if n == "retract"] == [{"station": 2, "pass": 0}]
    keys = [d["key"] for n, d in events if n == "annotate"]
    assert keys[0] == "start_time_s" and keys.count("progress") == 6 and "skipped" in keys


def test_setup_steps_property() -> None:
    s = replace(setup(3), return_pass=True)
    assert s.steps() == [(0, 0), (0, 1), (0, 2), (1, 2), (1, 1), (1, 0)]


def test_pause_requested_as_the_run_opens(tmp_path) -> None:
    from saved_runs.store.reader import load_run
    from saved_runs.store.writer import RunStore

    ctl = FakeController()
    op = Scripted(ctl)
    store = RunStore(tmp_path / "r", {"setup": {}})
    eng = RunEngine(Rig(FakeSensor(), ctl), op, (store,))  # type: ignore[arg-type]
    plan = straightness_plan(setup(3), {})

    def first_pause_then_plan():
        eng.request_pause()  # honoured right after OpenRun, before the block is placed
        yield from plan

    out = eng.run(first_pause_then_plan())
    assert out.exit_status == "success" and op.asked == ["pause"]
    assert load_run(tmp_path / "r").points["station"].tolist() == [0, 1, 2]
