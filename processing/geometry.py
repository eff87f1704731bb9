"""Set-up geometry of a gauge-block straightness run (docs/conventions.md)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

SensorSign = Literal["height", "gap"]
MIN_BEAM_DOWN = 0.5  # cos 60 deg: how steeply the sensor beam must point down (-Y) at the surface
DATUM_AXES: tuple[str, ...] = ("roll", "yaw", "pitch")  # keys of datum_angles_urad: about X, Y, Z
MAX_DATUM_ANGLE_URAD = 10_000.0  # 10 mrad: a block tilted more than that in the laser frame is a unit mistake


@dataclass(frozen=True)
class DatumAngles:
    """Measured angles (urad) of the datum block in the laser's frame; None = not measured.

    The block's pose when the interferometer was zeroed is R0 = Rz(pitch) Ry(yaw)
    Rx(roll) in the laser frame (docs/conventions.md, "The laser frame").  The
    exact decoupling estimates an unmeasured pitch from the first step and takes
    an unmeasured roll or yaw as 0.
    """

    roll_urad: float | None = None
    yaw_urad: float | None = None
    pitch_urad: float | None = None

    def __post_init__(self) -> None:
        for axis in DATUM_AXES:
            v = getattr(self, f"{axis}_urad")
            if v is None:
                continue
            if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
                raise ValueError(f"datum_angles_urad.{axis} must be a finite number (urad), got {v!r}")
            if abs(v) > MAX_DATUM_ANGLE_URAD:
                raise ValueError(f"datum_angles_urad.{axis} = {v} urad is more than {MAX_DATUM_ANGLE_URAD:g} urad "
                                 "(10 mrad) off the laser axis; the angles are in urad - check the units")

    @classmethod
    def from_dict(cls, d: Any) -> DatumAngles:
        """From ``{"roll": .., "yaw": .., "pitch": ..}`` (any subset; urad)."""
        if d is None:
            return cls()
        if not isinstance(d, dict):
            raise ValueError(f"datum_angles_urad must be a table of roll, yaw and pitch (urad), got {d!r}")
        unknown = sorted(set(d) - set(DATUM_AXES))
        if unknown:
            raise ValueError(f"datum_angles_urad: unknown key(s) {', '.join(map(str, unknown))}; "
                             f"use {', '.join(DATUM_AXES)}")
        return cls(**{f"{axis}_urad": (float(d[axis]) if _is_number(d[axis]) else d[axis])
                      for axis in DATUM_AXES if axis in d})

    def given(self) -> dict[str, float]:
        """The measured angles only, ``{"pitch": 42.0}`` (run.json's ``setup.geometry.datum_angles_urad``)."""
        return {axis: float(v) for axis in DATUM_AXES if (v := getattr(self, f"{axis}_urad")) is not None}

    def as_tuple(self) -> tuple[float | None, float | None, float | None]:
        """(roll, yaw, pitch) in urad, None where not measured."""
        return self.roll_urad, self.yaw_urad, self.pitch_urad


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


@dataclass(frozen=True)
class BlockGeometry:
    """Points in the block frame (mm) and the sensor's sign convention.

    ``mirror_mm``: interferometer measuring point P.  ``sensor_mm``: the point Q
    where the sensor beam meets the surface at the first station.
    ``sensor_beam``: unit beam direction.  ``sensor_sign``: ``"height"`` if the
    reading increases when the surface comes closer, ``"gap"`` if it increases
    when the surface moves away.  ``datum_angles_urad``: the datum block's
    measured angles in the laser frame (:class:`DatumAngles`).
    """

    mirror_mm: tuple[float, float, float]
    sensor_mm: tuple[float, float, float]
    sensor_beam: tuple[float, float, float] = (0.0, -1.0, 0.0)
    sensor_sign: SensorSign = "height"
    datum_angles_urad: DatumAngles = DatumAngles()

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
                datum_angles_urad=DatumAngles.from_dict(d.get("datum_angles_urad")),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"invalid geometry {d!r}: {exc}") from exc

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "mirror_mm": list(self.mirror_mm),
            "sensor_mm": list(self.sensor_mm),
            "sensor_beam": list(self.sensor_beam),
            "sensor_sign": self.sensor_sign,
        }
        if self.datum_angles_urad.given():
            d["datum_angles_urad"] = self.datum_angles_urad.given()
        return d
