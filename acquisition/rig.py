"""The devices a run uses, opened from URLs (real ports or emulator endpoints)."""

from __future__ import annotations

import contextlib
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from drivers.environment.xymd02 import XYMD02
from drivers.errors import CompletionTimeout, DeviceError, DriverError, TransportError, TransportTimeout
from drivers.interferometer import InterferometerController
from drivers.interferometer.codec import decode_value
from drivers.keyence_lkg.driver import check_output
from drivers.readings import InterferometerReading
from drivers.sensor import DisplacementSensor
from drivers.sensor_families import SENSOR_DRIVERS
from saved_runs.errors import UserError

#: The sensor protocols a set-up may name (what the front ends offer).
SENSOR_PROTOCOLS: tuple[str, ...] = tuple(SENSOR_DRIVERS)
#: Sensor protocols whose driver takes a controller series and an output number ([sensor] series / output).
SENSOR_OUTPUTS = {"keyence-lkg"}


@dataclass(frozen=True)
class ControllerTiming:
    """How the tool waits for the interferometer controller (set-up ``[controller]``, docs/modbus-map.md).

    ``trigger_timeout_s``: deadline for a measurement to complete (per attempt);
    ``trigger_retries``: further attempts after a missed deadline (a measurement still
    running is waited for again, never discarded); ``poll_interval_s``: time between
    status polls; ``request_timeout_s``: how long one Modbus request waits for its reply.
    """

    trigger_timeout_s: float = 2.0
    poll_interval_s: float = 0.002
    request_timeout_s: float = 1.0
    trigger_retries: int = 2

    def problem(self) -> str | None:
        """Why these values cannot work (one line naming the key), or None."""
        for name in ("trigger_timeout_s", "poll_interval_s", "request_timeout_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
                return f"{name} must be a positive number of seconds, got {v!r}"
        if self.poll_interval_s >= self.trigger_timeout_s:
            return (f"poll_interval_s ({self.poll_interval_s:g} s) must be shorter than trigger_timeout_s "
                    f"({self.trigger_timeout_s:g} s)")
        if not (isinstance(self.trigger_retries, int) and not isinstance(self.trigger_retries, bool)
                and self.trigger_retries >= 0):
            return f"trigger_retries must be a whole number >= 0, got {self.trigger_retries!r}"
        return None


@dataclass(frozen=True)
class SensorOptions:
    """Which output of a multi-output sensor controller is read (``[sensor] series`` / ``output``);
    None = the driver's default.  Only for the protocols in :data:`SENSOR_OUTPUTS`."""

    series: str | None = None
    output: int | None = None

    def kwargs(self) -> dict[str, Any]:
        return {k: v for k, v in (("series", self.series), ("output", self.output)) if v is not None}


DEFAULT_TIMING = ControllerTiming()
DEFAULT_SENSOR_OPTIONS = SensorOptions()


@dataclass
class Rig:
    """An open interferometer controller and, for straightness runs, a displacement sensor;
    optionally a separate air temperature / humidity transmitter (XY-MD02) for a controller
    without an environment unit."""

    sensor: DisplacementSensor | None
    controller: InterferometerController
    # Opens fresh connections to the same devices (set by open_rig); None: reconnect just retries.
    reopen: Callable[[], Rig] | None = field(default=None, repr=False)
    environment: XYMD02 | None = None
    # Held by whoever talks to the devices: the run engine for the whole run except while it waits
    # (operator, Wait), a live reader (acquisition.monitor) in between; see claim().
    lock: threading.RLock = field(default_factory=threading.RLock, repr=False)
    _claimed: threading.Event = field(default_factory=threading.Event, repr=False)

    def claim(self) -> None:
        """Take the devices for the run engine (blocks until a live reading in progress ends;
        :attr:`claimed` tells a live reader to hand them over at once)."""
        self._claimed.set()
        try:
            self.lock.acquire()
        finally:
            self._claimed.clear()

    def release(self) -> None:
        """Give the devices back (the engine waits, or the run is over)."""
        self.lock.release()

    @property
    def claimed(self) -> bool:
        """True while the engine waits to take the devices back."""
        return self._claimed.is_set()

    def trigger_and_read(self) -> InterferometerReading:
        """One triggered interferometer capture.

        With a separate transmitter, its air temperature and humidity replace the
        controller's (read right after the capture); pressure and material temperature
        stay the controller's.
        """
        reading = self.controller.trigger_and_read()
        if self.environment is None:
            return reading
        env = self.environment.read_once()
        return replace(reading, air_temp_c=env.temp_c, humidity_pct=env.humidity_pct)

    def read_angle_deg(self) -> float:
        """The rotary angle captured with the last trigger (deg, relative to the datum; register
        ``angle_deg``, docs/modbus-map.md)."""
        ctl: Any = self.controller
        reg = ctl.map["angle_deg"]
        return decode_value(ctl.read_registers(reg.address, reg.count), reg.type, ctl.word_order)

    def instruments(self) -> dict[str, dict[str, Any]]:
        """run.json ``instruments``: protocol, endpoint, identity of each device (the sensor's output
        number when its controller has several; the controller's Modbus device id)."""
        out: dict[str, dict[str, Any]] = {}
        if self.sensor is not None:
            out["sensor"] = {"protocol": self.sensor.protocol, "endpoint": self.sensor.endpoint,
                             **self.sensor.identify()}
            if self.sensor.protocol in SENSOR_OUTPUTS:
                out["sensor"]["output"] = getattr(self.sensor, "output", None)
        out["interferometer"] = {"protocol": f"modbus ({self.controller.word_order})",
                                 "endpoint": self.controller.endpoint, "device_id": self.controller.device_id,
                                 **self.controller.identify()}
        if self.environment is not None:
            out["environment"] = {"protocol": "modbus (XY-MD02)", "endpoint": self.environment.endpoint,
                                  "model": "XY-MD02 temperature/humidity transmitter",
                                  "channels": "air_temp_c, humidity_pct"}
        return out

    def clear_latched_error(self) -> tuple[bool, str]:
        """If the controller holds a latched error (the error flag, e.g. after a beam interruption),
        clear it (command 5) and check the beam.

        Returns ``(latched, problem)``: ``latched`` whether an error was set; ``problem`` why it
        could not be cleared (the cause persists), "" when the controller is ready again.
        """
        st = self.controller.read_status()
        if not st.error:
            return False, ""
        after = self.controller.clear_error()
        if after.error or not after.beam_ok:
            now = f"error {after.error_code} {after.error_text}".rstrip() if after.error else "beam OK is not set"
            return True, (f"controller error {st.error_code} ({st.error_text}) could not be cleared ({now}); "
                          "check the beam: the optics alignment and that nothing crosses it")
        return True, ""

    def reconnect(self) -> None:
        """Close both devices and open them again at the same endpoints (after a fault).

        Raises the same one-line :class:`UserError` as :func:`open_rig` if a device is still unreachable.
        """
        if self.reopen is None:
            return
        self.close()
        fresh = self.reopen()
        self.sensor, self.controller, self.environment = fresh.sensor, fresh.controller, fresh.environment

    def close(self) -> None:
        for dev in (self.sensor, self.controller, self.environment):
            if dev is None:
                continue
            with contextlib.suppress(Exception):  # closing is best effort
                dev.close()


def sensor_options_problem(protocol: str, options: SensorOptions) -> str | None:
    """Why ``series`` / ``output`` do not fit the sensor protocol (one line), or None."""
    if not options.kwargs():
        return None
    if protocol not in SENSOR_OUTPUTS:
        return (f"series and output apply to {', '.join(sorted(SENSOR_OUTPUTS))} controllers only, "
                f"not {protocol}")
    try:
        check_output(options.series or "LK-G3000", 1 if options.output is None else options.output)
    except ValueError as exc:
        return str(exc)
    return None


def open_sensor(protocol: str, url: str, *, baudrate: int | None = 115200,
                options: SensorOptions = DEFAULT_SENSOR_OPTIONS) -> DisplacementSensor:
    """Open a displacement sensor by protocol name (``keyence-lkg``) and pyserial URL.

    ``baudrate`` ``None`` opens the port at the driver's own default rate; ``options``: the
    controller series and output to read (LK-G5000 ``MS,02``), for the protocols that have them.
    """
    try:
        cls = SENSOR_DRIVERS[protocol]
    except KeyError:
        raise UserError(
            f"unknown sensor protocol {protocol!r}; use one of: {', '.join(SENSOR_DRIVERS)}"
        ) from None
    problem = sensor_options_problem(protocol, options)
    if problem:
        raise UserError(f"sensor: {problem}")
    kwargs: dict[str, Any] = options.kwargs()
    if baudrate is not None:
        kwargs["baudrate"] = baudrate
    try:
        return cls.from_url(url, **kwargs)  # type: ignore[attr-defined]
    except DriverError as exc:
        raise UserError(f"{exc}; check the port name and that the sensor is connected") from exc


def open_rig(sensor_protocol: str, sensor_url: str, controller_url: str, *, baudrate: int | None = None,
             word_order: str = "ABCD", environment_url: str | None = None,
             timing: ControllerTiming = DEFAULT_TIMING, sensor_options: SensorOptions = DEFAULT_SENSOR_OPTIONS) -> Rig:
    """Open the devices; a one-line :class:`UserError` if one is unreachable (the others are closed)."""
    sensor = open_sensor(sensor_protocol, sensor_url, baudrate=baudrate, options=sensor_options)
    try:
        controller = open_controller(controller_url, word_order=word_order, timing=timing)
    except UserError:
        sensor.close()
        raise
    try:
        environment = open_environment(environment_url) if environment_url else None
    except UserError:
        sensor.close()
        controller.close()
        raise

    def reopen() -> Rig:
        return open_rig(sensor_protocol, sensor_url, controller_url, baudrate=baudrate, word_order=word_order,
                        environment_url=environment_url, timing=timing, sensor_options=sensor_options)

    return Rig(sensor, controller, reopen, environment)


def open_environment(url: str) -> XYMD02:
    """Connect to an XY-MD02 air temperature / humidity transmitter (``modbus-rtu:PORT?baud=9600``
    or ``modbus-tcp://gateway:port``); a one-line :class:`UserError` if it does not answer."""
    try:
        transmitter = XYMD02.from_url(url)
    except (DriverError, ValueError) as exc:
        raise UserError(f"environment transmitter: {exc}; check its address, baud rate and wiring") from exc
    try:
        transmitter.read_once()
    except DriverError as exc:
        transmitter.close()
        raise UserError(f"environment transmitter at {url} did not answer: {exc}; check its address, baud rate "
                        "and wiring") from exc
    return transmitter


CONTROLLER_HINT = "check the controller address and that it is switched on"
SLOW_HINT = "the controller answers: a slow one needs a longer [controller] trigger_timeout_s"


def controller_hint(exc: DriverError, *, device_id: int, serial: bool, answered: bool) -> str:
    """What to check after a controller request failed: the address only when nothing ever answered
    (a device that answers but is slow, or a gateway without the device id, is not an address problem)."""
    if isinstance(exc, CompletionTimeout) or (answered and isinstance(exc, TransportTimeout)):
        return SLOW_HINT if isinstance(exc, CompletionTimeout) else (
            "the controller answered before: a slow one needs a longer [controller] request_timeout_s")
    if isinstance(exc, DeviceError) and exc.code in (10, 11):
        return f"no device answers at device id {device_id} behind the gateway: check device_id= in the URL"
    if serial and isinstance(exc, TransportError):
        return (f"nothing answers at device id {device_id}: check device_id= in the URL, the baud rate, parity "
                "and the wiring")
    return CONTROLLER_HINT


def open_controller(url: str, *, word_order: str = "ABCD",
                    timing: ControllerTiming = DEFAULT_TIMING) -> InterferometerController:
    """Connect to the interferometer controller and read its status once (so a wrong address or
    device id is found before a run starts); a one-line :class:`UserError` if it does not answer."""
    try:
        controller = InterferometerController.from_url(
            url, word_order=word_order, timeout_s=timing.request_timeout_s,
            trigger_timeout_s=timing.trigger_timeout_s, poll_interval_s=timing.poll_interval_s,
            retries=timing.trigger_retries)
    except ValueError as exc:
        raise UserError(str(exc)) from exc
    except DriverError as exc:
        raise UserError(f"{exc}; {CONTROLLER_HINT}") from exc
    try:
        controller.read_status()
    except DriverError as exc:
        controller.close()
        hint = controller_hint(exc, device_id=controller.device_id, serial=url.startswith("modbus-rtu:"),
                               answered=False)
        raise UserError(f"{exc}; {hint}") from exc
    return controller


def open_controller_rig(controller_url: str, *, word_order: str = "ABCD", environment_url: str | None = None,
                        timing: ControllerTiming = DEFAULT_TIMING) -> Rig:
    """A rig with the interferometer controller only (positioning runs), and the transmitter if given."""
    controller = open_controller(controller_url, word_order=word_order, timing=timing)
    try:
        environment = open_environment(environment_url) if environment_url else None
    except UserError:
        controller.close()
        raise
    return Rig(None, controller,
               lambda: open_controller_rig(controller_url, word_order=word_order, environment_url=environment_url,
                                           timing=timing),
               environment)
