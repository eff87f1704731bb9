"""Opening devices: an unreachable sensor port or controller is a one-line UserError."""

from __future__ import annotations

from pathlib import Path

import pytest

from acquisition.rig import open_rig
from mocks.keyence_lkg import KeyenceLKGEmulator
from mocks.serial_endpoints import TcpEndpoint
from saved_runs.errors import UserError


def test_missing_serial_port(tmp_path: Path) -> None:
    with pytest.raises(UserError, match="cannot open serial port") as info:
        open_rig("keyence-lkg", str(tmp_path / "ttyUSB9"), "modbus-tcp://127.0.0.1:1")
    assert "\n" not in str(info.value) and "check the port name" in str(info.value)


def test_unreachable_controller_closes_the_sensor(refused_port: int) -> None:
    emu = KeyenceLKGEmulator(lambda _o: 0.0)
    ep = TcpEndpoint(emu)
    try:
        with pytest.raises(UserError, match="cannot connect to controller") as info:
            open_rig("keyence-lkg", ep.url, f"modbus-tcp://127.0.0.1:{refused_port}")
        assert "check the controller address" in str(info.value)
    finally:
        ep.stop()


def test_unknown_sensor_protocol() -> None:
    with pytest.raises(UserError, match="unknown sensor protocol 'acme'"):
        open_rig("acme", "loop://", "modbus-tcp://127.0.0.1:1")
