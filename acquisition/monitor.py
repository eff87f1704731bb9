"""Live readings of a rig's devices while the run engine waits (warm-up, between captures).

:class:`LiveMonitor` reads the same drivers as the engine, through the same
:class:`~acquisition.rig.Rig`, never a second connection: it takes ``rig.lock``,
which the engine holds for the whole run except while it waits for the
operator or a ``Wait`` (``RunEngine.idle``).  When the engine wants the devices
back (``rig.claimed``) the monitor ends its current reading and hands them
over, so pause, abort and capture wait for one reading at most.

A streaming sensor (a Micro-Epsilon ILD1420 sends its values continuously, up
to kHz rates) is read as stream blocks (``start_stream`` / ``read_stream``):
every frame received is counted and none is dropped by the driver, and each
block becomes *one* :class:`LiveReading` (its newest value, mean, count and
the rate), so a 2 kHz stream reaches a display as about ``1 / interval_s``
readings per second.  Polled sensors give one value per reading.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from drivers.errors import DriverError
from drivers.readings import DisplacementReading, InterferometerReading, MeasurementStatus

from .rig import Rig


@dataclass(frozen=True)
class LiveReading:
    """One live look at the devices.  ``sensor_mm`` is the newest sensor value (the sensor's own
    sign; NaN with a status other than ok), ``sensor_mean_mm`` / ``sensor_count`` / ``sensor_rate_hz``
    summarise a streamed block (count 1 for a polled value); ``frames_lost`` counts frames the
    driver saw damaged or missing in the block.  ``angle_deg``: the rotary angle captured with
    ``interferometer`` (deg from the datum; NaN unless the monitor reads it, a rotary set-up).
    ``problem``: a device that did not answer (one line)."""

    time_s: float
    sensor_mm: float = math.nan
    sensor_status: str = ""
    sensor_mean_mm: float = math.nan
    sensor_count: int = 0
    sensor_rate_hz: float = 0.0
    frames_lost: int = 0
    interferometer: InterferometerReading | None = None
    problem: str = ""
    angle_deg: float = math.nan

    @property
    def has_sensor(self) -> bool:
        return bool(self.sensor_status)


ReadingCallback = Callable[[LiveReading], None]


class LiveMonitor:
    """Reads the rig every ``interval_s`` while the engine lets it and hands each reading to ``on_reading``
    (called in the monitor's thread).  Use as a context manager, or ``start()`` / ``stop()``.

    ``stream``: read a streaming sensor as blocks (default); ``restore_output``: the ILD1420 output
    mode set again after a stream block (the engine reads the streaming head with ``read_once``,
    which needs ``RS422``; None leaves the output off, for benchmarks that count every frame sent).
    ``interferometer_interval_s``: a controller capture (a triggered measurement, slower than a sensor
    value) at most this often; the readings in between carry the last one (None: no captures).
    ``angle``: read the rotary angle captured with each of them too (a rotary positioning set-up).
    """

    def __init__(self, rig: Rig, on_reading: ReadingCallback, *, interval_s: float = 0.05, stream: bool = True,
                 restore_output: str | None = "RS422", interferometer_interval_s: float | None = 0.25,
                 angle: bool = False) -> None:
        self.rig = rig
        self.on_reading = on_reading
        self.interval_s = interval_s
        self.stream = stream
        self.restore_output = restore_output
        self.interferometer_interval_s = interferometer_interval_s
        self.angle = angle
        self._ifm: InterferometerReading | None = None
        self._angle_deg = math.nan
        self._ifm_time = -math.inf
        self.readings = 0
        self.frames_received = 0  # streamed sensor values handed out (all blocks)
        self.frames_lost = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # -- life cycle ---------------------------------------------------------------------------
    def start(self) -> LiveMonitor:
        self._thread = threading.Thread(target=self._loop, name="live-monitor", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    def __enter__(self) -> LiveMonitor:
        return self.start()

    def __exit__(self, *_exc: Any) -> None:
        self.stop()

    # -- reading ------------------------------------------------------------------------------
    def _loop(self) -> None:
        while not self._stop.wait(self.interval_s):
            if self.rig.claimed or not self.rig.lock.acquire(timeout=self.interval_s):
                continue
            try:
                if self.rig.claimed:
                    continue
                sensor = self.rig.sensor
                if self.stream and sensor is not None and hasattr(sensor, "start_stream"):
                    self._stream_blocks(sensor)
                else:
                    self._emit(self._polled())
            except Exception as exc:  # noqa: BLE001 - the live view says what broke and goes on; the run decides
                self._emit(LiveReading(time.time(), problem=f"live reading failed: {exc!r}"))
            finally:
                self.rig.lock.release()

    def _emit(self, reading: LiveReading) -> None:
        self.readings += 1
        self.on_reading(reading)

    def _interferometer(self) -> tuple[InterferometerReading | None, str]:
        every = self.interferometer_interval_s
        if every is None or time.monotonic() - self._ifm_time < every:
            return self._ifm, ""
        self._ifm_time = time.monotonic()
        self._angle_deg = math.nan
        try:
            self._ifm = self.rig.trigger_and_read()
            if self.angle:
                self._angle_deg = self.rig.read_angle_deg()
        except DriverError as exc:
            self._ifm = None
            return None, f"interferometer: {exc}"
        return self._ifm, ""

    def _polled(self) -> LiveReading:
        problems = []
        fields: dict[str, Any] = {}
        if self.rig.sensor is not None:
            try:
                r: DisplacementReading = self.rig.sensor.read_once()
                fields = {"sensor_mm": r.value_mm, "sensor_status": r.status.value,
                          "sensor_mean_mm": r.value_mm, "sensor_count": 1}
            except DriverError as exc:
                problems.append(f"sensor: {exc}")
        ifm, problem = self._interferometer()
        if problem:
            problems.append(problem)
        return LiveReading(time.time(), **fields, interferometer=ifm, problem="; ".join(problems),
                           angle_deg=self._angle_deg if ifm is not None else math.nan)

    def _stream_blocks(self, sensor: Any) -> None:
        """Stream blocks of about ``interval_s`` until the engine claims the rig or the monitor stops."""
        try:
            sensor.start_stream()
        except DriverError as exc:
            self._emit(LiveReading(time.time(), problem=f"sensor: {exc}"))
            return
        try:
            while not (self.rig.claimed or self._stop.is_set()):
                block = sensor.read_stream(duration_s=self.interval_s)
                ifm, problem = self._interferometer()
                self._emit(self._block_reading(block, ifm, problem))
        except DriverError as exc:
            self._emit(LiveReading(time.time(), problem=f"sensor: {exc}"))
        finally:
            try:
                final = sensor.stop_stream()
                if final is not None:
                    self._count(final)
                if self.restore_output is not None:
                    sensor.set_output(self.restore_output)
            except DriverError as exc:
                self._emit(LiveReading(time.time(), problem=f"sensor: {exc}"))

    def _count(self, block: Any) -> None:
        self.frames_received += int(block.frames_ok)
        self.frames_lost += int(block.frames_lost) + int(block.resyncs)

    def _block_reading(self, block: Any, ifm: InterferometerReading | None, problem: str) -> LiveReading:
        self._count(block)
        n = int(block.frames_ok)
        lost = int(block.frames_lost) + int(block.resyncs)
        if n == 0:
            return LiveReading(time.time(), sensor_status=MeasurementStatus.NO_VALUE.value, frames_lost=lost,
                               interferometer=ifm, problem=problem or "sensor: no values in the last block")
        values = block.values_mm
        good = values[~(values != values)]  # NaN-free (invalid values are NaN)
        mean = float(good.mean()) if len(good) else math.nan
        rate = n / block.duration_s if block.duration_s > 0 else 0.0
        return LiveReading(block.timestamp_s, sensor_mm=float(values[-1]), sensor_status=block.statuses[-1].value,
                           sensor_mean_mm=mean, sensor_count=n, sensor_rate_hz=rate, frames_lost=lost,
                           interferometer=ifm, problem=problem)
