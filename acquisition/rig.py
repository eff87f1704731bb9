"""The devices a run uses, opened from URLs (real ports or emulator endpoints)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from drivers.errors import DriverError
from drivers.interferometer import InterferometerController
from drivers.keyence_lkg import KeyenceLKG
from drivers.me_ild1420 import ILD1420
from drivers.panasonic_hlg1 import PanasonicHLG1
from drivers.sensor import DisplacementSensor

from .errors import UserError

SENSOR_DRIVERS: dict[str, type[DisplacementSensor]] = {
    "keyence-lkg": KeyenceLKG,
    "panasonic-hlg1": PanasonicHLG1,
    "me-ild1420": ILD1420,
}


@dataclass
class Rig:
    """An open interferometer controller and, for straightness runs, a displacement sensor."""

    sensor: DisplacementSensor | None
    controller: InterferometerController
    # Opens fresh connections to the same devices (set by open_rig); None: reconnect just retries.
    reopen: Callable[[], Rig] | None = field(default=None, repr=False)

    def instruments(self) -> dict[str, dict[str, Any]]:
        """run.json ``instruments``: protocol, endpoint, identity of each device."""
        out: dict[str, dict[str, Any]] = {}
        if self.sensor is not None:
            out["sensor"] = {"protocol": self.sensor.protocol, "endpoint": self.sensor.endpoint,
                             **self.sensor.identify()}
        out["interferometer"] = {"protocol": f"modbus ({self.controller.word_order})",
                                 "endpoint": self.controller.endpoint, **self.controller.identify()}
        return out

    def reconnect(self) -> None:
        """Close both devices and open them again at the same endpoints (after a fault).

        Raises the same one-line :class:`UserError` as :func:`open_rig` if a device is still unreachable.
        """
        if self.reopen is None:
            return
        self.close()
        fresh = self.reopen()
        self.sensor, self.controller = fresh.sensor, fresh.controller

    def close(self) -> None:
        for dev in (self.sensor, self.controller):
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
             word_order: str = "ABCD") -> Rig:
    """Open both devices; a one-line :class:`UserError` if either is unreachable."""
    sensor = open_sensor(sensor_protocol, sensor_url, baudrate=baudrate)
    try:
        controller = open_controller(controller_url, word_order=word_order)
    except UserError:
        sensor.close()
        raise

    def reopen() -> Rig:
        return open_rig(sensor_protocol, sensor_url, controller_url, baudrate=baudrate, word_order=word_order)

    return Rig(sensor, controller, reopen)


def open_controller(url: str, *, word_order: str = "ABCD") -> InterferometerController:
    """Connect to the interferometer controller; a one-line :class:`UserError` if unreachable."""
    try:
        return InterferometerController.from_url(url, word_order=word_order)
    except (DriverError, ValueError) as exc:
        raise UserError(f"{exc}; check the controller address and that it is switched on") from exc


def open_controller_rig(controller_url: str, *, word_order: str = "ABCD") -> Rig:
    """A rig with the interferometer controller only (positioning runs)."""
    controller = open_controller(controller_url, word_order=word_order)
    return Rig(None, controller, lambda: open_controller_rig(controller_url, word_order=word_order))
