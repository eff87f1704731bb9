"""Fault plans: the spec syntax, request counting, and the port-level ``close``
fault seen by the real driver over a pty and over TCP (detectable, then a
reconnect works)."""

from __future__ import annotations

from pathlib import Path

import pytest

from drivers.errors import ConnectionLost
from drivers.keyence_lkg import KeyenceLKG
from mocks.faults import KINDS, Fault, FaultPlan, FaultSpecError
from mocks.keyence_lkg import KeyenceLKGEmulator
from mocks.serial_endpoints import PtyEndpoint, TcpEndpoint

from ..waiting import wait_for


def test_spec_parses_every_part() -> None:
    plan = FaultPlan.parse("sensor:close@3x2, controller:delay@5=0.5,sensor:garbage@10")
    assert plan.faults == (
        Fault("sensor", "close", 3, 2, None),
        Fault("controller", "delay", 5, None, "0.5"),
        Fault("sensor", "garbage", 10, None, None),
    )


def test_a_beam_loss_is_one_request_long_unless_counted_a_slow_controller_for_good() -> None:
    plan = FaultPlan.parse("controller:beam-loss@30,controller:beam-loss@50x4,controller:slow@1=2.5")
    assert plan.faults == (Fault("controller", "beam-loss", 30, 1, None), Fault("controller", "beam-loss", 50, 4, None),
                           Fault("controller", "slow", 1, None, "2.5"))
    assert [plan.fault_for("controller", n).kind for n in (29, 30, 31, 50, 53, 54)] == [
        "slow", "beam-loss", "slow", "beam-loss", "beam-loss", "slow"]


@pytest.mark.parametrize(
    ("spec", "fragment"),
    [("sensor:close", "expected DEVICE:KIND@N"), ("robot:close@1", "unknown device"),
     ("sensor:explode@1", "unknown sensor fault"), ("sensor:close@0", "counts requests from 1"),
     # these were accepted: a count of 0 never fires, and a bad ARG only showed when the fault fired,
     # as the emulator failing (a Modbus "server device failure" blamed on the controller address)
     ("sensor:close@1x0", "xCOUNT must be at least 1"),
     ("controller:slow@1=abc", "ARG must be a number of seconds >= 0, got 'abc'"),
     ("controller:delay@2=-1", "ARG must be a number of seconds >= 0, got '-1'"),
     ("sensor:delay@2=inf", "ARG must be a number of seconds >= 0"),
     ("controller:exception@1=9", r"ARG must be a Modbus exception code \(1, 2, 3, 4, 5, 6, 7, 8, 10, 11\)"),
     ("sensor:error@1=E2", "ARG must be the device's error code, a whole number, got 'E2'"),
     ("sensor:garbage@3=5", "garbage takes no ARG")],
)
def test_bad_specs_name_the_problem(spec: str, fragment: str) -> None:
    with pytest.raises(FaultSpecError, match=fragment):
        FaultPlan.parse(spec)


def test_every_documented_sensor_kind_is_accepted() -> None:
    for kind in ("garbage", "drop", "delay", "error", "corrupt", "close"):
        assert kind in KINDS["sensor"]
        FaultPlan.parse(f"sensor:{kind}@1")


def test_requests_counted_per_device_and_first_matching_entry_wins() -> None:
    plan = FaultPlan.parse("sensor:drop@2x2,sensor:garbage@3")
    got = [plan.next_request("sensor") for _ in range(5)]
    kinds = [f.kind if f else None for f in got]
    # request 3 is covered by both entries; the first one in the spec applies
    assert kinds == [None, "drop", "drop", "garbage", "garbage"]
    assert plan.requests("sensor") == 5 and plan.requests("controller") == 0
    assert plan.fault_for("sensor", 1) is None  # pure look-up, counts nothing
    assert plan.requests("sensor") == 5


def _emulator(plan: FaultPlan) -> KeyenceLKGEmulator:
    return KeyenceLKGEmulator(lambda _out: 0.5, decimals=5, faults=plan)


def test_close_over_pty_hangs_up_then_the_port_can_be_reopened(tmp_path: Path) -> None:
    plan = FaultPlan.parse("sensor:close@2x1")
    link = tmp_path / "ttyGW"
    endpoint = PtyEndpoint(_emulator(plan), faults=plan, link=link)
    assert link.resolve() == Path(endpoint.path)
    dev = KeyenceLKG.from_url(str(link))
    try:
        assert dev.read_once().value_mm == 0.5
        with pytest.raises(ConnectionLost):
            dev.read_once()  # request 2: the device drops the link instead of answering
        dev.close()
        # A fresh pty pair; the stable name follows it, like a re-enumerated USB adapter.
        wait_for(lambda: endpoint.link_drops == 1, timeout_s=10, what="the pty to be re-opened")
        assert link.resolve() == Path(endpoint.path)
        dev = KeyenceLKG.from_url(str(link))
        assert dev.read_once().value_mm == 0.5  # request 3: after COUNT the device answers again
    finally:
        dev.close()
        endpoint.stop()
    assert not link.exists()


def test_close_over_tcp_drops_the_connection_and_keeps_listening() -> None:
    plan = FaultPlan.parse("sensor:close@1x1")
    endpoint = TcpEndpoint(_emulator(plan), faults=plan)
    dev = KeyenceLKG.from_url(endpoint.url)
    try:
        with pytest.raises(ConnectionLost):
            dev.read_once()
        dev.close()
        wait_for(lambda: endpoint.link_drops == 1, timeout_s=10, what="the connection to be dropped")
        dev = KeyenceLKG.from_url(endpoint.url)
        assert dev.read_once().value_mm == 0.5
        assert plan.requests("sensor") == 2
    finally:
        dev.close()
        endpoint.stop()


def test_endpoint_without_plan_ignores_faults_it_does_not_know_of() -> None:
    plan = FaultPlan.parse("sensor:close@1")
    endpoint = TcpEndpoint(_emulator(plan))  # no plan given to the endpoint: the emulator just answers
    dev = KeyenceLKG.from_url(endpoint.url)
    try:
        assert dev.read_once().value_mm == 0.5
    finally:
        dev.close()
        endpoint.stop()
