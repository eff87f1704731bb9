"""Behaviour shared by all laser displacement sensor drivers.

A concrete driver implements :meth:`DisplacementSensor.read_once`; averaging,
``read()`` and ``describe()`` are common, so acquisition builds its records
without knowing the device type.
"""

from __future__ import annotations

import math
import statistics
import time
from abc import ABC, abstractmethod
from typing import Any

from .readings import AveragedDisplacement, DisplacementReading
from .transport import ByteLink


class DisplacementSensor(ABC):
    """A laser displacement sensor on a byte link."""

    protocol: str = ""
    #: True when :meth:`identify` asks the device; False when it only names the driver's family
    #: (a command set without an identity query: nothing on the line says which device answers).
    identity_query: bool = False

    def __init__(self, link: ByteLink, *, endpoint: str = "", timeout_s: float = 0.5) -> None:
        self._link = link
        self.endpoint = endpoint
        self.timeout_s = timeout_s

    @abstractmethod
    def read_once(self) -> DisplacementReading:
        """Measure one displacement value in mm (polled)."""

    def identify(self) -> dict[str, str]:
        """Return what the device reports about itself (model, serial); may be empty."""
        return {}

    def read_averaged(self, samples: int) -> AveragedDisplacement:
        """Measure ``samples`` polled values and return their mean and std in mm.

        Samples the device flags invalid are counted in ``rejected`` and left
        out of the mean; the caller decides whether that is acceptable.
        """
        if samples < 1:
            raise ValueError("samples must be >= 1")
        good: list[float] = []
        bad = []
        for _ in range(samples):
            reading = self.read_once()
            if reading.ok:
                good.append(reading.value_mm)
            else:
                bad.append(reading.status)
        mean = statistics.fmean(good) if good else math.nan
        std = statistics.stdev(good) if len(good) > 1 else (0.0 if good else math.nan)
        return AveragedDisplacement(
            mean_mm=mean,
            std_mm=std,
            count=len(good),
            rejected=len(bad),
            timestamp_s=time.time(),
            statuses=tuple(bad),
        )

    def read(self) -> dict[str, dict[str, Any]]:
        """Bluesky-style reading: ``{"sensor_mm": {"value", "timestamp", "status"}}``."""
        r = self.read_once()
        return {"sensor_mm": {"value": r.value_mm, "timestamp": r.timestamp_s, "status": r.status.value}}

    def describe(self) -> dict[str, dict[str, Any]]:
        """Schema of :meth:`read`, with the same keys."""
        return {
            "sensor_mm": {
                "source": f"{self.protocol}:{self.endpoint}",
                "dtype": "number",
                "shape": [],
                "units": "mm",
            }
        }

    def close(self) -> None:
        self._link.close()
