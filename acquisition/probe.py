"""Probe devices: open a sensor and/or the controller, show what they report
about themselves and a few readings, as text lines.

Used by ``guideway devices probe``.  A device that answers with an error
reply (LK-G ``ER,...``, a latched controller error, a Modbus exception) has
answered: the error is printed as its reading and counted in
:attr:`Probe.device_errors` (the command then exits 3: not a pass).  A device
that does not answer properly (port missing, timeout, garbage, dropped link)
raises a one-line :class:`UserError`.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from dataclasses import dataclass

from drivers.environment.xymd02 import XYMD02
from drivers.errors import DeviceError, DriverError
from drivers.interferometer import InterferometerController
from drivers.readings import ControllerStatus, DisplacementReading, InterferometerReading
from drivers.sensor import DisplacementSensor
from saved_runs.errors import UserError

from .rig import (
    DEFAULT_SENSOR_OPTIONS,
    DEFAULT_TIMING,
    ControllerTiming,
    SensorOptions,
    controller_hint,
    open_controller,
    open_environment,
    open_sensor,
)


def parse_sensor_spec(spec: str) -> tuple[str, str]:
    """``PROTOCOL:URL`` (``keyence-lkg:/dev/ttyUSB0``) -> (protocol, url)."""
    protocol, sep, url = spec.partition(":")
    if not sep or not protocol or not url:
        raise UserError(f"sensor {spec!r} must be PROTOCOL:URL, e.g. keyence-lkg:/dev/ttyUSB0")
    return protocol, url


def _identity(info: dict[str, str]) -> str:
    return " ".join(f"{k}={v}" for k, v in info.items()) if info else "(no identity offered)"


def sensor_identity(sensor: DisplacementSensor) -> str:
    """The sensor's identity line; for a command set without an identity query, says so
    (the family named is what the driver speaks, not what answered); the output read when the
    controller has several."""
    info = sensor.identify()
    output = getattr(sensor, "output", None)
    read = {"output": str(output)} if isinstance(output, int) else {}
    if sensor.identity_query:
        return _identity({**info, **read})
    family = info.pop("model", "")
    return _identity({"model": f"(not reported; protocol {sensor.protocol})",
                      **({"commands": family} if family else {}), **info, **read})


def set_flags(st: ControllerStatus) -> str:
    """The set flags of a controller status word, e.g. ``ready data-valid beam-ok`` (``none``)."""
    names = [("ready", st.ready), ("busy", st.busy), ("data-valid", st.data_valid), ("error", st.error),
             ("beam-ok", st.beam_ok)]
    return " ".join(n for n, on in names if on) or "none"


def status_flags(st: ControllerStatus) -> str:
    """The status word, its set flags and the sequence, e.g. ``status 0x0015 [ready data-valid beam-ok] sequence 4``."""
    line = f"status 0x{st.raw_status:04x} [{set_flags(st)}] sequence {st.sequence}"
    if st.error or st.error_code:
        line += f" error {st.error_code}: {st.error_text or 'unknown error'}"
    if st.error and st.beam_ok:  # the cause is gone, the flag is not: say so, or the beam looks still broken
        line += " (latched: the beam is OK again; a run clears the error itself, command 5)"
    return line


def format_sensor(r: DisplacementReading) -> str:
    value = f"{r.value_mm:+.5f} mm" if math.isfinite(r.value_mm) else "no value"
    return f"{value} {r.status.value} (raw {r.raw.strip()!r})"


def format_controller(r: InterferometerReading) -> list[str]:
    return [
        status_flags(r.status),
        f"  position {r.position_mm:.6f} mm  stry {r.stry_um:.3f} um  strz {r.strz_um:.3f} um",
        f"  pitch {r.pitch_urad:.2f} urad  yaw {r.yaw_urad:.2f} urad  roll {r.roll_urad:.2f} urad",
        f"  air {r.air_temp_c:.3f} C  pressure {r.air_pressure_hpa:.2f} hPa  "
        f"humidity {r.humidity_pct:.1f} %RH  material {r.material_temp_c:.3f} C",
    ]


@dataclass
class Probe:
    """Open devices under probe; ``name`` prefixes every line about a device."""

    sensor: DisplacementSensor | None
    controller: InterferometerController | None
    sensor_name: str = ""
    controller_name: str = ""
    environment: XYMD02 | None = None
    environment_name: str = ""
    device_errors: int = 0  # readings in which a device reported an error (not a pass)

    def _fail(self, name: str, exc: DriverError) -> UserError:
        hint = ""
        if name == self.controller_name and self.controller is not None:
            # open_controller read its status: the controller has answered at this address
            hint = "; " + controller_hint(exc, device_id=self.controller.device_id,
                                          serial=self.controller.endpoint.startswith("modbus-rtu:"), answered=True)
            hint = hint.replace("[controller] trigger_timeout_s", "--trigger-timeout").replace(
                "[controller] request_timeout_s", "--request-timeout")
        return UserError(f"{name} did not answer properly: {exc}{hint}")

    def identity_lines(self) -> list[str]:
        lines = []
        if self.sensor is not None:
            try:
                lines.append(f"{self.sensor_name}: {sensor_identity(self.sensor)}")
            except DriverError as exc:
                raise self._fail(self.sensor_name, exc) from exc
        if self.controller is not None:
            try:
                info = self.controller.identify()
                if not info:  # identification is optional: make sure something answers before saying so
                    self.controller.read_status()
            except DriverError as exc:
                raise self._fail(self.controller_name, exc) from exc
            lines.append(f"{self.controller_name}: {_identity(info)}")
        if self.environment is not None:
            lines.append(f"{self.environment_name}: model=XY-MD02 (no identity query in its register map)")
        return lines

    def reading_lines(self, index: int) -> list[str]:
        """One reading of every device, ``#index`` in front."""
        lines = []
        if self.sensor is not None:
            try:
                text = format_sensor(self.sensor.read_once())
            except DeviceError as exc:
                text = f"device error: {exc}"
                self.device_errors += 1
            except DriverError as exc:
                raise self._fail(self.sensor_name, exc) from exc
            lines.append(f"#{index} sensor: {text}")
        if self.controller is not None:
            try:
                reading = self.controller.trigger_and_read()
                body = format_controller(reading)
                if reading.status.error or not reading.status.beam_ok:
                    self.device_errors += 1
            except DeviceError as exc:
                self.device_errors += 1
                try:
                    body = [f"device error: {exc}", status_flags(self.controller.read_status())]
                except DriverError as exc2:
                    raise self._fail(self.controller_name, exc2) from exc2
            except DriverError as exc:
                raise self._fail(self.controller_name, exc) from exc
            lines.append(f"#{index} controller: {body[0]}")
            lines += body[1:]
        if self.environment is not None:
            try:
                env = self.environment.read_once()
            except DeviceError as exc:
                lines.append(f"#{index} environment: device error: {exc}")
                self.device_errors += 1
            except DriverError as exc:
                raise self._fail(self.environment_name, exc) from exc
            else:
                lines.append(f"#{index} environment: air {env.temp_c:.1f} C  humidity {env.humidity_pct:.1f} %RH")
        return lines

    def close(self) -> None:
        for dev in (self.sensor, self.controller, self.environment):
            if dev is not None:
                with contextlib.suppress(Exception):  # closing is best effort
                    dev.close()


@contextlib.contextmanager
def open_probe(sensor: str | None, controller: str | None, *, baudrate: int | None = None,
               environment: str | None = None, sensor_options: SensorOptions = DEFAULT_SENSOR_OPTIONS,
               timing: ControllerTiming = DEFAULT_TIMING) -> Iterator[Probe]:
    """Open the given devices (``sensor`` as ``PROTOCOL:URL`` with the output of ``sensor_options``,
    ``controller`` (waited for as ``timing`` says) and ``environment`` (an XY-MD02 transmitter) as
    Modbus URLs)."""
    if sensor is None and controller is None and environment is None:
        raise UserError("nothing to probe; give --sensor PROTOCOL:URL, --controller URL and/or --environment URL")
    probe = Probe(None, None)
    try:
        if sensor is not None:
            protocol, url = parse_sensor_spec(sensor)
            probe.sensor = open_sensor(protocol, url, baudrate=baudrate, options=sensor_options)
            probe.sensor_name = f"sensor {protocol}:{url}"
        if controller is not None:
            probe.controller = open_controller(controller, timing=timing)
            probe.controller_name = f"controller {controller}"
        if environment is not None:
            probe.environment = open_environment(environment)
            probe.environment_name = f"environment {environment}"
        yield probe
    finally:
        probe.close()
