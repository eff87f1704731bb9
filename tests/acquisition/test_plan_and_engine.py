"""The straightness plan as a message sequence (no devices), and the engine's
state machine, abort/fail handling and cleanup with fake devices."""

from __future__ import annotations

import math

import pytest

from acquisition import messages as m
from acquisition.engine import TRANSITIONS, IllegalTransition, RunEngine, RunState
from acquisition.operators import AutoOperator
from acquisition.plans import straightness_plan
from acquisition.rig import Rig
from acquisition.setup.straightness import StraightnessSetup
from drivers.errors import TransportTimeout
from drivers.readings import AveragedDisplacement, ControllerStatus, InterferometerReading
from processing.geometry import BlockGeometry

GEOM = BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0))
OK_STATUS = ControllerStatus(True, False, True, False, True, 1, 0, "", 0b10101)


def ifm(position_mm: float, seq: int = 1) -> InterferometerReading:
    return InterferometerReading(position_mm, 0.5, 0.1, 2.0, 1.0, -3.0, 20.1, 1013.0, 45.0, 20.0, seq,
                                 OK_STATUS, 1000.0 + seq)


def sensor(v: float) -> AveragedDisplacement:
    return AveragedDisplacement(v, 0.0001, 3, 0, 1000.0)


def setup(n: int = 3) -> StraightnessSetup:
    return StraightnessSetup(block_length_mm=100.0, stations=n, geometry=GEOM, samples_per_reading=3)


def test_plan_message_sequence() -> None:
    plan = straightness_plan(setup(3), {})
    msgs = []
    replies = {m.OpenRun: 1000.0, m.ReadSensor: sensor(0.01), m.Instruct: "capture"}
    reply = None
    seq = 0
    while True:
        try:
            msg = plan.send(reply)
        except StopIteration:
            break
        msgs.append(msg)
        if isinstance(msg, m.TriggerInterferometer):
            seq += 1
            reply = ifm(100.0 * (seq - 1) + 0.001, seq)
        elif isinstance(msg, m.Instruct) and msg.key == "datum":
            reply = "done"
        else:
            reply = replies.get(type(msg))
    kinds = [type(x).__name__ for x in msgs if not isinstance(x, m.Log | m.Annotate)]
    assert kinds == [
        "OpenRun", "Instruct", "ZeroInterferometer",
        "TriggerInterferometer", "ReadSensor", "Record",
        "Instruct", "Stillness", "TriggerInterferometer", "ReadSensor", "Record",
        "Instruct", "Stillness", "TriggerInterferometer", "ReadSensor", "Record",
        "CloseRun",
    ]
    instructs = [x for x in msgs if isinstance(x, m.Instruct)]
    assert [i.params["station"] for i in instructs] == [0, 1, 2]
    assert "x = 200 mm" in instructs[2].text and "side face" in instructs[2].text
    assert instructs[2].choices[0] == "capture" and "skip" in instructs[2].choices
    records = [x.data for x in msgs if isinstance(x, m.Record)]
    assert [r["x_mm"] for r in records] == [0.0, 100.0, 200.0]
    assert records[2]["lin_um"] == pytest.approx(1.0)  # 200.001 mm - 200 mm
    assert records[0]["sensor_mm"] == 0.01 and records[1]["time_s"] == pytest.approx(2.0)
    progress = [x.value for x in msgs if isinstance(x, m.Annotate) and x.key == "progress"]
    assert progress == [{"pass": 0, "station": k} for k in range(3)]


class FakeController:
    def __init__(self, fail_at: int | None = None) -> None:
        self.n = 0
        self.fail_at = fail_at
        self.zeroed = False
        self.closed = False

    def zero(self) -> ControllerStatus:
        self.zeroed = True
        return OK_STATUS

    def trigger_and_read(self) -> InterferometerReading:
        if self.fail_at is not None and self.n == self.fail_at:
            raise TransportTimeout("controller did not complete the trigger")
        self.n += 1
        return ifm(100.0 * (self.n - 1), self.n)

    def close(self) -> None:
        self.closed = True


class FakeSensor:
    def read_averaged(self, samples: int) -> AveragedDisplacement:
        return sensor(0.002)


class Collector:
    def __init__(self) -> None:
        self.docs: list[tuple[str, dict]] = []

    def __call__(self, name: str, doc: dict) -> None:
        self.docs.append((name, doc))

    def names(self) -> list[str]:
        return [n for n, _ in self.docs]

    def of(self, name: str) -> list[dict]:
        return [d for n, d in self.docs if n == name]


def engine(controller: FakeController, operator=None) -> tuple[RunEngine, Collector]:
    col = Collector()
    rig = Rig(FakeSensor(), controller)  # type: ignore[arg-type]
    return RunEngine(rig, operator or AutoOperator(), (col,)), col


def test_complete_run_emits_start_events_stop() -> None:
    eng, col = engine(FakeController())
    out = eng.run(straightness_plan(setup(4), {"machine": "m1"}))
    assert out.exit_status == "success" and out.num_events == 4
    assert [n for n in col.names() if n in ("start", "event", "stop")] == ["start"] + ["event"] * 4 + ["stop"]
    assert col.of("start")[0]["machine"] == "m1" and col.of("stop")[0]["exit_status"] == "success"
    assert [d["state"] for d in col.of("state")] == ["running", "stopping", "idle"]
    assert eng.state is RunState.IDLE
    assert eng.state_log == [RunState.IDLE, RunState.RUNNING, RunState.STOPPING, RunState.IDLE]


def test_operator_abort_keeps_data_and_ends_as_abort() -> None:
    class AbortAtStation2(AutoOperator):
        def instruct(self, msg: m.Instruct) -> str:
            return "abort" if msg.params.get("station") == 2 else msg.choices[0]

    eng, col = engine(FakeController(), AbortAtStation2())
    out = eng.run(straightness_plan(setup(5), {}))
    assert out.exit_status == "abort" and out.num_events == 2
    assert [n for n in col.names() if n in ("start", "event", "stop")] == ["start", "event", "event", "stop"]
    assert eng.state_log[-2:] == [RunState.ABORTING, RunState.IDLE]


def test_device_fault_fails_the_run_and_cleanup_runs() -> None:
    closed = []

    def plan():
        try:
            yield from straightness_plan(setup(5), {})
        finally:
            closed.append(True)

    eng, col = engine(FakeController(fail_at=3))  # fails at every trigger from the 4th on
    out = eng.run(plan())
    assert out.exit_status == "fail" and "did not complete" in out.reason
    assert out.num_events == 3 and [n for n in col.names() if n != "state"][-1] == "stop"
    assert closed == [True]
    # the fault paused the run; the automatic operator retried once, then gave up
    assert eng.state_log[-5:] == [RunState.PAUSED, RunState.RUNNING, RunState.PAUSED, RunState.FAILED,
                                  RunState.IDLE]
    assert len(eng.faults) == 2


def test_abort_request_from_another_thread_is_honoured() -> None:
    eng, col = engine(FakeController())

    class AbortOperator(AutoOperator):
        def instruct(self, msg: m.Instruct) -> str:
            if msg.params.get("station") == 1:
                eng.request_abort()
            return msg.choices[0]

    eng.operator = AbortOperator()
    out = eng.run(straightness_plan(setup(5), {}))
    assert out.exit_status == "abort" and out.num_events == 1


def test_transition_table_is_enforced() -> None:
    eng, _ = engine(FakeController())
    with pytest.raises(IllegalTransition):
        eng._transition(RunState.STOPPING)  # idle -> stopping is not allowed
    for state, targets in TRANSITIONS.items():
        assert state not in targets
    assert all(RunState.IDLE in TRANSITIONS[s] for s in (RunState.STOPPING, RunState.ABORTING, RunState.FAILED))


def test_invalid_sensor_reading_fails_with_clear_message() -> None:
    class BadSensor:
        def read_averaged(self, samples: int) -> AveragedDisplacement:
            return AveragedDisplacement(math.nan, math.nan, 0, samples, 0.0)

    col = Collector()
    eng = RunEngine(Rig(BadSensor(), FakeController()), AutoOperator(), (col,))  # type: ignore[arg-type]
    out = eng.run(straightness_plan(setup(3), {}))
    assert out.exit_status == "fail" and "displacement sensor reading invalid" in out.reason


def test_a_guard_fails_the_run_before_the_next_capture() -> None:
    # the guard turns (another thread: a live compensator that stopped) right after the 2nd trigger: the 2nd
    # point's capture is finished (its sensor read) and recorded, the run fails before the 3rd trigger is sent
    ctrl = FakeController()
    eng, col = engine(ctrl)
    eng.guards.append(lambda: "compensator gone" if ctrl.n >= 2 else "")
    out = eng.run(straightness_plan(setup(5), {}))
    assert out.exit_status == "fail" and out.reason == "compensator gone" and out.num_events == 2
    assert ctrl.n == 2  # no 3rd trigger reached the controller
    assert col.of("stop")[0]["reason"] == "compensator gone" and eng.faults == []  # not a device fault: no retry
    assert eng.state_log[-2:] == [RunState.FAILED, RunState.IDLE]
