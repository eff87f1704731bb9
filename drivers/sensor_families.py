"""The displacement-sensor drivers by protocol name: the names set-up files (``[sensor] protocol``)
and run.json (``instruments.sensor.protocol``) use."""

from __future__ import annotations

from .keyence_lkg import KeyenceLKG
from .me_ild1420 import ILD1420
from .panasonic_hlg1 import PanasonicHLG1
from .sensor import DisplacementSensor

SENSOR_DRIVERS: dict[str, type[DisplacementSensor]] = {
    "keyence-lkg": KeyenceLKG,
    "panasonic-hlg1": PanasonicHLG1,
    "me-ild1420": ILD1420,
}
