"""Set-up geometry of a gauge-block straightness run (docs/conventions.md)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

SensorSign = Literal["height", "gap"]
MIN_BEAM_DOWN = 0.5  # cos 60 deg: how steeply the sensor beam must point down (-Y) at the surface


@dataclass(frozen=True)
class BlockGeometry:
    """Points in the block frame (mm) and the sensor's sign convention.

    ``mirror_mm``: interferometer measuring point P.  ``sensor_mm``: the point Q
    where the sensor beam meets the surface at the first station.
    ``sensor_beam``: unit beam direction.  ``sensor_sign``: ``"height"`` if the
    reading increases when the surface comes closer, ``"gap"`` if it increases
    when the surface moves away.
    """

    mirror_mm: tuple[float, float, float]
    sensor_mm: tuple[float, float, float]
    sensor_beam: tuple[float, float, float] = (0.0, -1.0, 0.0)
    sensor_sign: SensorSign = "height"

    def __post_init__(self) -> None:
        for name in ("mirror_mm", "sensor_mm", "sensor_beam"):
            v = getattr(self, name)
            if len(v) != 3 or not all(np.isfinite(v)):
                raise ValueError(f"geometry {name} must be three finite numbers, got {v!r}")
        if abs(float(np.linalg.norm(self.sensor_beam)) - 1.0) > 1e-6:
            raise ValueError(f"sensor_beam must be a unit vector, got {self.sensor_beam!r}")
        if self.sensor_beam[1] > -MIN_BEAM_DOWN:
            # The sensor reads the base surface below the block: a beam along X or Z never meets it.
            raise ValueError(f"sensor_beam must point down at the surface (-Y, within 60 degrees; y <= "
                             f"-{MIN_BEAM_DOWN}), got {self.sensor_beam!r}")
        if self.sensor_sign not in ("height", "gap"):
            raise ValueError(f"sensor_sign must be 'height' or 'gap', got {self.sensor_sign!r}")

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> BlockGeometry:
        """Build from run.json's ``setup.geometry`` object."""
        try:
            return cls(
                mirror_mm=tuple(float(v) for v in d["mirror_mm"]),  # type: ignore[arg-type]
                sensor_mm=tuple(float(v) for v in d["sensor_mm"]),  # type: ignore[arg-type]
                sensor_beam=tuple(float(v) for v in d.get("sensor_beam", (0.0, -1.0, 0.0))),  # type: ignore[arg-type]
                sensor_sign=d.get("sensor_sign", "height"),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"invalid geometry {d!r}: {exc}") from exc

    def to_dict(self) -> dict[str, Any]:
        return {
            "mirror_mm": list(self.mirror_mm),
            "sensor_mm": list(self.sensor_mm),
            "sensor_beam": list(self.sensor_beam),
            "sensor_sign": self.sensor_sign,
        }
