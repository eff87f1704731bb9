"""Typed readings returned by drivers.

Readings are frozen dataclasses with units in the field names and a host
timestamp (``time.time()``, seconds since the epoch, taken when the reply was
decoded).  A value that the device flags as invalid is NaN *and* carries a
status other than ``OK``; callers check :attr:`ok`, never the number alone.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field


class MeasurementStatus(enum.Enum):
    """Validity of a displacement value as the device reports it."""

    OK = "ok"
    OVER_RANGE_HIGH = "over-range-high"
    OVER_RANGE_LOW = "over-range-low"
    ALARM = "alarm"
    NO_VALUE = "no-value"


@dataclass(frozen=True, slots=True)
class DisplacementReading:
    """One displacement value from a laser displacement sensor.

    ``value_mm`` is in the sensor's own sign convention (whatever the
    controller outputs), NaN unless ``status`` is OK.
    """

    value_mm: float
    status: MeasurementStatus
    timestamp_s: float
    raw: str = ""

    @property
    def ok(self) -> bool:
        return self.status is MeasurementStatus.OK and math.isfinite(self.value_mm)


@dataclass(frozen=True, slots=True)
class AveragedDisplacement:
    """Mean of ``count`` valid samples (sample standard deviation, ddof = 1).

    ``rejected`` counts samples the device flagged invalid; ``statuses``
    names their statuses.  ``mean_mm`` is NaN when no sample was valid.
    """

    mean_mm: float
    std_mm: float
    count: int
    rejected: int
    timestamp_s: float
    statuses: tuple[MeasurementStatus, ...] = field(default_factory=tuple)

    @property
    def ok(self) -> bool:
        return self.count > 0 and self.rejected == 0 and math.isfinite(self.mean_mm)


@dataclass(frozen=True, slots=True)
class ControllerStatus:
    """Decoded status word, sequence counter and error code of the controller."""

    ready: bool
    busy: bool
    data_valid: bool
    error: bool
    beam_ok: bool
    sequence: int
    error_code: int
    error_text: str
    raw_status: int


@dataclass(frozen=True, slots=True)
class InterferometerReading:
    """One triggered capture of the interferometer controller.

    Channel definitions (docs/conventions.md): displacement of the mirror point
    P relative to the datum (``position_mm`` along X; ``stry_um`` along Y,
    ``strz_um`` along Z) and rotation of the block relative to the datum
    (``roll_urad`` about X, ``yaw_urad`` about Y, ``pitch_urad`` about Z).
    """

    position_mm: float
    stry_um: float
    strz_um: float
    pitch_urad: float
    yaw_urad: float
    roll_urad: float
    air_temp_c: float
    air_pressure_hpa: float
    humidity_pct: float
    material_temp_c: float
    sequence: int
    status: ControllerStatus
    timestamp_s: float

    @property
    def ok(self) -> bool:
        values = (
            self.position_mm, self.stry_um, self.strz_um,
            self.pitch_urad, self.yaw_urad, self.roll_urad,
            self.air_temp_c, self.air_pressure_hpa, self.humidity_pct, self.material_temp_c,
        )
        return (
            self.status.data_valid
            and self.status.beam_ok
            and not self.status.error
            and all(math.isfinite(v) for v in values)
        )


@dataclass(frozen=True, slots=True)
class TempHumidityReading:
    """Air temperature and relative humidity from a transmitter such as the XY-MD02.

    ``ok`` is false when a value is outside the sensor's measuring range
    (a wrong register map or a broken probe, not weather).
    """

    temp_c: float
    humidity_pct: float
    timestamp_s: float
    temp_range_c: tuple[float, float] = (-40.0, 125.0)

    @property
    def ok(self) -> bool:
        lo, hi = self.temp_range_c
        return lo <= self.temp_c <= hi and 0.0 <= self.humidity_pct <= 100.0
