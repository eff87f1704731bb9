"""Every controller fault kind of mocks/faults.py surfaces as the right typed
error in the driver, and the driver works again on the next request.

Request counting (what ``@N`` refers to): with the emulator's measure time 0,
``trigger_and_read`` makes these Modbus requests: 1 read status, 2 write the
trigger (the measurement completes while this write is served), 3 poll
status, 4 read data 100-127, 5 read status.  ``read_status`` is one request.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from drivers.errors import ChecksumError, ConnectionLost, DeviceError, ProtocolError, TransportTimeout
from drivers.interferometer import InterferometerController
from mocks.faults import FaultPlan
from mocks.interferometer import InterferometerEmulator, start_controller
from mocks.world import Noise, World

TIMEOUT_S = 0.2


@contextmanager
def rig(spec: str = "", transport: str = "tcp", *, device_id: int = 1, url: Callable[[str], str] | None = None,
        emulator: dict[str, Any] | None = None, **controller: Any
        ) -> Iterator[tuple[InterferometerEmulator, InterferometerController]]:
    """An emulator with fault plan ``spec`` served at unit id ``device_id`` over ``transport``, and the
    driver connected to it (``url``: what the driver opens, made from the server's URL; ``controller``:
    driver settings, default a 0.2 s deadline, 1 retry)."""
    emu = InterferometerEmulator(World(noise=Noise.off(), seed=5), faults=FaultPlan.parse(spec), **(emulator or {}))
    server = start_controller(emu, transport=transport, device_id=device_id)
    settings = {"timeout_s": TIMEOUT_S, "trigger_timeout_s": 0.2, "retries": 1, **controller}
    try:
        ctl = InterferometerController.from_url(url(server.url) if url else server.url, **settings)
    except BaseException:
        server.stop()
        raise
    try:
        yield emu, ctl
    finally:
        ctl.close()
        server.stop()


def test_fault_kinds_are_registered() -> None:
    for kind in ("freeze-seq", "beam-loss", "exception", "delay", "drop", "corrupt", "close"):
        assert FaultPlan.parse(f"controller:{kind}@1").faults[0].kind == kind


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
def test_exception_reply_is_a_device_error_with_the_modbus_meaning(transport: str) -> None:
    with rig("controller:exception@2x1=6", transport) as (_, ctl):
        with pytest.raises(DeviceError) as info:
            ctl.trigger_and_read()  # request 2, the trigger write, answers exception 6
        assert info.value.code == 6 and info.value.text == "Modbus exception 6: server device busy"
        assert info.value.command == "command trigger"
        # the message says which device answered so (a run's fault dialog and run.json show only the message)
        assert str(info.value) == (f"controller {ctl.endpoint}: device reported error 6 to 'command trigger': "
                                   "Modbus exception 6: server device busy")
        assert ctl.trigger_and_read().ok


def test_default_exception_is_device_failure() -> None:
    with rig("controller:exception@1x1") as (_, ctl):
        with pytest.raises(DeviceError, match="server device failure") as info:
            ctl.read_status()
        assert info.value.code == 4
        assert ctl.read_status().ready


def test_frozen_sequence_counter_times_out_after_the_retries() -> None:
    with rig("controller:freeze-seq@1") as (emu, ctl):
        with pytest.raises(TransportTimeout, match="trigger not completed within 0.2 s"):
            ctl.trigger_and_read()
        triggers = emu.faults.requests("controller")
        assert triggers >= 6  # two attempts, each: status, write, at least one poll
        emu.faults = FaultPlan()  # the counter runs again
        reading = ctl.trigger_and_read()
        assert reading.ok and reading.sequence == 1  # frozen completions did not count


def test_a_single_frozen_completion_is_retried() -> None:
    with rig("controller:freeze-seq@2x1") as (_, ctl):
        reading = ctl.trigger_and_read()
        assert reading.ok and reading.sequence == 1  # the second trigger's completion


def test_beam_loss_latches_error_1_until_cleared() -> None:
    with rig("controller:beam-loss@2x1") as (_, ctl):
        with pytest.raises(DeviceError) as info:
            ctl.trigger_and_read()
        assert info.value.code == 1 and info.value.text.startswith("beam interrupted")
        with pytest.raises(DeviceError):  # latched: a new trigger is refused with the same error
            ctl.trigger_and_read()
        assert not ctl.clear_error().error
        assert ctl.trigger_and_read().ok


def test_delayed_reply_is_a_timeout_and_the_next_request_is_answered() -> None:
    with rig("controller:delay@1x1=0.6") as (_, ctl):
        with pytest.raises(TransportTimeout, match="no response within 0.2 s"):
            ctl.read_status()
        assert ctl.read_status().ready


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
def test_dropped_reply_is_a_timeout_and_the_next_request_is_answered(transport: str) -> None:
    with rig("controller:drop@1x1", transport) as (_, ctl):
        with pytest.raises(TransportTimeout):
            ctl.read_status()
        assert ctl.read_status().ready


def test_dropped_trigger_reply_keeps_the_measurement_it_started() -> None:
    # The write was executed, only its reply was lost: the status shows the new sequence number,
    # so the measurement it started is used; no second trigger.
    with rig("controller:drop@2x1") as (emu, ctl):
        reading = ctl.trigger_and_read()
        assert reading.ok and reading.sequence == 1 and emu.sequence == 1


def test_connection_closed_mid_run_is_connection_lost_then_reconnects() -> None:
    with rig("controller:close@4x1") as (emu, ctl):
        with pytest.raises(ConnectionLost, match="connection lost"):
            ctl.trigger_and_read()  # closed while the data block is read
        assert emu.wire_faults.applied == ["close"]
        reading = ctl.trigger_and_read()  # pymodbus's sync client reconnects on the next request
        assert reading.ok and reading.sequence == 2


def test_corrupt_rtu_reply_is_a_checksum_error() -> None:
    with rig("controller:corrupt@1x1", "rtu") as (_, ctl):
        with pytest.raises(ChecksumError, match="CRC"):
            ctl.read_status()
        assert ctl.read_status().ready


def test_corrupt_tcp_header_is_a_protocol_error() -> None:
    with rig("controller:corrupt@1x1") as (_, ctl):
        with pytest.raises(ProtocolError) as info:
            ctl.read_status()
        assert not isinstance(info.value, ChecksumError)  # Modbus TCP has no frame checksum
        assert ctl.read_status().ready
