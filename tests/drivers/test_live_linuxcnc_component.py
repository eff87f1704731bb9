"""The LinuxCNC HAL component of live compensation (drivers/live_compensation/linuxcnc_component.py) with a
stand-in for LinuxCNC's ``hal`` module: the compensator over Modbus TCP drives ``eoffset-counts`` = the
offset in counts of 0.01 arcsec (expected values from numpy here), homing gates it, a stale heartbeat drops
it to 0 and latches."""

from __future__ import annotations

import argparse
import struct
import threading
import time
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from pymodbus.client import ModbusTcpClient

from acquisition.live_compensation import LiveCompensator, predictor_from_means, start_in_thread
from drivers.live_compensation.linuxcnc_component import parser, run_component
from tests.waiting import wait_for


def settled(condition: Any) -> None:
    """Wait (bounded) until the component's pins meet ``condition``: it serves the registers in a thread."""
    wait_for(condition, timeout_s=10, interval_s=0.002, what="the component's pins")


X = np.array([0.0, 90.0, 180.0, 270.0, 360.0])
UP = np.array([0.0, 10.0, 0.0, -10.0, 0.0])
DOWN = UP + 4.0


class FakeComponent:
    def __init__(self) -> None:
        self.pins: dict[str, Any] = {}
        self.is_ready = False

    def newpin(self, name: str, kind: str, direction: str) -> None:
        self.pins[name] = 0.0 if kind == "float" else 0

    def ready(self) -> None:
        self.is_ready = True

    def __getitem__(self, name: str) -> Any:
        return self.pins[name]

    def __setitem__(self, name: str, value: Any) -> None:
        assert name in self.pins
        self.pins[name] = value


@pytest.fixture
def component() -> Iterator[tuple[FakeComponent, int]]:
    comp = FakeComponent()
    hal = SimpleNamespace(component=lambda name: comp, HAL_FLOAT="float", HAL_BIT="bit", HAL_S32="s32",
                          HAL_IN="in", HAL_OUT="out")
    args: argparse.Namespace = parser().parse_args(["--axis", "C", "--host", "127.0.0.1", "--port", "0",
                                                    "--timeout-ms", "300"])
    stop, port = threading.Event(), {}
    ready = threading.Event()
    thread = threading.Thread(target=run_component, args=(hal, args),
                              kwargs={"stop": stop, "on_ready": lambda p: (port.setdefault("p", p), ready.set())},
                              daemon=True)
    thread.start()
    assert ready.wait(10)
    yield comp, port["p"]
    stop.set()
    thread.join(5)



def test_compensator_drives_eoffset_counts(component) -> None:  # noqa: ANN001
    comp, port = component
    comp["homed"] = True
    comp["pos-cmd"] = 10.0
    live = LiveCompensator(predictor_from_means("linear", X, UP, DOWN, rotary=True), f"modbus-tcp://127.0.0.1:{port}",
                           cycle_ms=2, max_jump=1000)
    thread, _ = start_in_thread(live)
    try:
        comp["pos-cmd"] = 45.0  # moving +: the up curve, 5 arcsec -> offset -5 arcsec = -500 counts
        settled(lambda: comp["eoffset-counts"] == round(-np.interp(45.0, X, UP) / 0.01))
        assert comp["active"]
        comp["pos-cmd"] = 30.0  # moving -: the down curve
        settled(lambda: comp["eoffset-counts"] == round(-np.interp(30.0, X, DOWN) / 0.01))
        comp["homed"] = False  # not homed: no offset
        settled(lambda: comp["eoffset-counts"] == 0)
        comp["homed"] = True
        settled(lambda: comp["eoffset-counts"] != 0)
    finally:
        live.stop()
        thread.join(5)
    settled(lambda: comp["eoffset-counts"] == 0)  # the compensator wrote 0 and enable 0 leaving


def test_stale_heartbeat_drops_the_offset_and_latches(component) -> None:  # noqa: ANN001
    comp, port = component
    comp["homed"] = True
    client = ModbusTcpClient("127.0.0.1", port=port, timeout=2)
    assert client.connect()
    offset = list(struct.unpack(">HH", struct.pack(">f", 2.5)))
    client.write_register(8, 1, device_id=1)
    client.write_registers(9, [1, 0, 250, *offset], device_id=1)
    settled(lambda: comp["eoffset-counts"] == 250)
    t0 = time.monotonic()
    settled(lambda: comp["eoffset-counts"] == 0 and not comp["active"])  # T = 300 ms without a heartbeat
    assert time.monotonic() - t0 > 0.2  # not before T (the last heartbeat was just before t0)
    regs = client.read_holding_registers(0, count=17, device_id=1).registers
    assert regs[1] & 2 and regs[16] == 300
    client.write_registers(9, [2, 0, 250, *offset], device_id=1)
    time.sleep(0.05)
    assert comp["eoffset-counts"] == 0  # latched: a heartbeat alone does not resume
    client.write_register(8, 1, device_id=1)
    settled(lambda: comp["eoffset-counts"] == 250)
    assert client.write_register(4, 1, device_id=1).isError()  # the position is the controller's
    client.close()
