"""Validated set-up of a gauge-block straightness run."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from processing.geometry import BlockGeometry

from .errors import SetupError


@dataclass(frozen=True)
class DeviceSetup:
    """Where the devices are: sensor protocol + pyserial URL, controller URL."""

    sensor_protocol: str = "keyence-lkg"
    sensor_url: str = ""
    sensor_baud: int = 115200
    controller_url: str = ""
    word_order: str = "ABCD"


@dataclass(frozen=True)
class StraightnessSetup:
    """Everything a straightness run needs before it starts."""

    block_length_mm: float
    stations: int
    geometry: BlockGeometry
    devices: DeviceSetup = field(default_factory=DeviceSetup)
    samples_per_reading: int = 5
    machine: str = ""
    axis: str = ""
    operator: str = ""
    notes: str = ""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.block_length_mm) and self.block_length_mm > 0):
            raise SetupError(f"block_length_mm must be a positive length, got {self.block_length_mm}")
        if self.stations < 2:
            raise SetupError(f"stations must be at least 2 (datum + one step), got {self.stations}")
        if self.samples_per_reading < 1:
            raise SetupError(f"samples_per_reading must be >= 1, got {self.samples_per_reading}")

    def station_x_mm(self, k: int) -> float:
        """Nominal block position of station k: k times the block length."""
        return k * self.block_length_mm

    def to_run_setup(self) -> dict[str, Any]:
        """run.json ``setup`` object (run format version 1)."""
        return {
            "block_length_mm": self.block_length_mm,
            "stations": self.stations,
            "samples_per_reading": self.samples_per_reading,
            "geometry": self.geometry.to_dict(),
        }
