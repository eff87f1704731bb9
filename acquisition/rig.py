"""The devices a run uses, opened from URLs (real ports or emulator endpoints)."""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from drivers.environment.xymd02 import XYMD02
from drivers.errors import DriverError
from drivers.interferometer import InterferometerController
from drivers.keyence_lkg import KeyenceLKG
from drivers.me_ild1420 import ILD1420
from drivers.panasonic_hlg1 import PanasonicHLG1
from drivers.readings import InterferometerReading
from drivers.sensor import DisplacementSensor

from .errors import UserError

SENSOR_DRIVERS: dict[str, type[DisplacementSensor]] = {
    "keyence-lkg": KeyenceLKG,
    "panasonic-hlg1": PanasonicHLG1,
    "me-ild1420": ILD1420,
}


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

    def instruments(self) -> dict[str, dict[str, Any]]:
        """run.json ``instruments``: protocol, endpoint, identity of each device."""
        out: dict[str, dict[str, Any]] = {}
        if self.sensor is not None:
            out["sensor"] = {"protocol": self.sensor.protocol, "endpoint": self.sensor.endpoint,
                             **self.sensor.identify()}
        out["interferometer"] = {"protocol": f"modbus ({self.controller.word_order})",
                                 "endpoint": self.controller.endpoint, **self.controller.identify()}
        if self.environment is not None:
            out["environment"] = {"protocol": "modbus (XY-MD02)", "endpoint": self.environment.endpoint,
                                  "model": "XY-MD02 temperature/humidity transmitter",
                                  "channels": "air_temp_c, humidity_pct"}
        return out

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


def open_sensor(protocol: str, url: str, *, baudrate: int | None = 115200) -> DisplacementSensor:
    """Open a displacement sensor by protocol name (``keyence-lkg``) and pyserial URL.

    ``baudrate`` ``None`` opens the port at the driver's own default rate.
    """
    try:
        cls = SENSOR_DRIVERS[protocol]
    except KeyError:
        raise UserError(
            f"unknown sensor protocol {protocol!r}; use one of: {', '.join(SENSOR_DRIVERS)}"
        ) from None
    try:
        if baudrate is None:
            return cls.from_url(url)  # type: ignore[attr-defined]
        return cls.from_url(url, baudrate=baudrate)  # type: ignore[attr-defined]
    except DriverError as exc:
        raise UserError(f"{exc}; check the port name and that the sensor is connected") from exc


def open_rig(sensor_protocol: str, sensor_url: str, controller_url: str, *, baudrate: int | None = None,
             word_order: str = "ABCD", environment_url: str | None = None) -> Rig:
    """Open the devices; a one-line :class:`UserError` if one is unreachable (the others are closed)."""
    sensor = open_sensor(sensor_protocol, sensor_url, baudrate=baudrate)
    try:
        controller = open_controller(controller_url, word_order=word_order)
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
                        environment_url=environment_url)

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


def open_controller(url: str, *, word_order: str = "ABCD") -> InterferometerController:
    """Connect to the interferometer controller; a one-line :class:`UserError` if unreachable."""
    try:
        return InterferometerController.from_url(url, word_order=word_order)
    except (DriverError, ValueError) as exc:
        raise UserError(f"{exc}; {CONTROLLER_HINT}") from exc


def open_controller_rig(controller_url: str, *, word_order: str = "ABCD", environment_url: str | None = None) -> Rig:
    """A rig with the interferometer controller only (positioning runs), and the transmitter if given."""
    controller = open_controller(controller_url, word_order=word_order)
    try:
        environment = open_environment(environment_url) if environment_url else None
    except UserError:
        controller.close()
        raise
    return Rig(None, controller,
               lambda: open_controller_rig(controller_url, word_order=word_order, environment_url=environment_url),
               environment)
