"""The set-up tables both run kinds share: the devices (``[sensor]``, ``[controller]``,
``[transmitter]``), checked before any port is opened, and the ``[simulation] scenario`` path."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drivers.modbus_link import parse_modbus_url
from saved_runs.errors import SetupError
from saved_runs.toml_file import TomlTable

from ..rig import SENSOR_PROTOCOLS, ControllerTiming, SensorOptions, sensor_options_problem


@dataclass(frozen=True)
class DeviceSetup:
    """Where the devices are: sensor protocol + pyserial URL, controller URL; how the controller is
    waited for (:class:`~acquisition.rig.ControllerTiming`) and which sensor output is read."""

    sensor_protocol: str = "keyence-lkg"
    sensor_url: str = ""
    sensor_baud: int | None = None  # None: the driver's default rate for the protocol
    controller_url: str = ""
    word_order: str = "ABCD"
    # A separate XY-MD02 air temperature / humidity transmitter ("" = the controller's environment unit).
    environment_url: str = ""
    sensor_series: str | None = None  # [sensor] series (keyence-lkg: LK-G3000 or LK-G5000); None: driver default
    sensor_output: int | None = None  # [sensor] output number; None: driver default (1)
    trigger_timeout_s: float = ControllerTiming.trigger_timeout_s
    poll_interval_s: float = ControllerTiming.poll_interval_s
    request_timeout_s: float = ControllerTiming.request_timeout_s
    trigger_retries: int = ControllerTiming.trigger_retries

    @property
    def timing(self) -> ControllerTiming:
        return ControllerTiming(self.trigger_timeout_s, self.poll_interval_s, self.request_timeout_s,
                                self.trigger_retries)

    @property
    def sensor_options(self) -> SensorOptions:
        return SensorOptions(self.sensor_series, self.sensor_output)


CONTROLLER_SCHEMES = ("modbus-tcp://", "modbus-rtu:")


def check_devices(devices: DeviceSetup, source: str, *, sensor: bool) -> None:
    """Sensor protocol and options, controller URL (scheme, options, device id) and timing,
    before any port is opened."""
    if sensor and devices.sensor_protocol not in SENSOR_PROTOCOLS:
        raise SetupError(f"{source}: [sensor] protocol {devices.sensor_protocol!r} is not supported; "
                         f"use one of: {', '.join(SENSOR_PROTOCOLS)}")
    if sensor and (problem := sensor_options_problem(devices.sensor_protocol, devices.sensor_options)):
        raise SetupError(f"{source}: [sensor] {problem}")
    if devices.controller_url and not devices.controller_url.startswith(CONTROLLER_SCHEMES):
        raise SetupError(f"{source}: [controller] url {devices.controller_url!r} must start with modbus-tcp:// "
                         "or modbus-rtu: (e.g. modbus-tcp://192.168.0.10:502)")
    if devices.controller_url:
        try:
            parse_modbus_url(devices.controller_url)
        except ValueError as exc:
            raise SetupError(f"{source}: [controller] url: {exc}") from None
    if problem := devices.timing.problem():
        raise SetupError(f"{source}: [controller] {problem}")
    if devices.environment_url and not devices.environment_url.startswith(CONTROLLER_SCHEMES):
        raise SetupError(f"{source}: [transmitter] url {devices.environment_url!r} must start with modbus-rtu: "
                         "or modbus-tcp:// (e.g. modbus-rtu:/dev/ttyUSB2?baud=9600)")


def controller_timing_keys(ctl: TomlTable) -> dict[str, Any]:
    """The ``[controller]`` timing keys of a set-up table (defaults: :class:`ControllerTiming`)."""
    d = ControllerTiming()
    return {"trigger_timeout_s": ctl.get("trigger_timeout_s", float, d.trigger_timeout_s),
            "poll_interval_s": ctl.get("poll_interval_s", float, d.poll_interval_s),
            "request_timeout_s": ctl.get("request_timeout_s", float, d.request_timeout_s),
            "trigger_retries": ctl.get("trigger_retries", int, d.trigger_retries)}


def catalog_table(top: TomlTable) -> TomlTable:
    """``[catalog] url``: the catalogue a completed run adds itself to (docs/fleet.md); read by
    :func:`acquisition.cataloguing.setup_catalog_url`, checked here with the set-up."""
    table = top.table("catalog")
    table.get("url", str, "")
    return table


def scenario_path(value: str, source: str) -> str:
    """``[simulation] scenario``: a path relative to the set-up file's directory (as given otherwise)."""
    if not value or Path(value).is_absolute() or not Path(source).is_file():
        return value
    return str((Path(source).parent / value).resolve())
