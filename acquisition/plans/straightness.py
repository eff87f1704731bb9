"""Gauge-block straightness workflow (seed 001).

Datum: the block at station 0, zero the interferometer, record the sensor's
start reading.  Then per station k: the operator places the block at
x = k * L against the side face; trigger the interferometer (it waits for the
new sequence number), read the sensor (averaged) and record the point.
"""

from __future__ import annotations

from collections.abc import Generator
from typing import Any

from drivers.readings import AveragedDisplacement, InterferometerReading

from ..errors import UserError
from ..messages import (
    CloseRun,
    Instruct,
    Log,
    Message,
    OpenRun,
    ReadSensor,
    Record,
    TriggerInterferometer,
    ZeroInterferometer,
)
from ..setup import StraightnessSetup


class CaptureRejected(UserError):
    """A reading failed validation."""


def point_record(
    k: int, x_mm: float, t0: float, ifm: InterferometerReading, sensor: AveragedDisplacement,
    pass_: int = 0,
) -> dict[str, Any]:
    """One row of points.csv (run format v2) from the two readings; ``pass_`` 0 forward, 1 return."""
    return {
        "station": k,
        "x_mm": x_mm,
        "time_s": ifm.timestamp_s - t0,
        "lin_um": (ifm.position_mm - x_mm) * 1000.0,
        "stry_um": ifm.stry_um,
        "strz_um": ifm.strz_um,
        "pitch_urad": ifm.pitch_urad,
        "yaw_urad": ifm.yaw_urad,
        "roll_urad": ifm.roll_urad,
        "sensor_mm": sensor.mean_mm,
        "air_temp_c": ifm.air_temp_c,
        "air_pressure_hpa": ifm.air_pressure_hpa,
        "humidity_pct": ifm.humidity_pct,
        "material_temp_c": ifm.material_temp_c,
        "pass": pass_,
    }


def _check(ifm: InterferometerReading, sensor: AveragedDisplacement, k: int) -> None:
    if not ifm.ok:
        st = ifm.status
        raise CaptureRejected(
            f"station {k}: interferometer data not valid (beam OK={st.beam_ok}, error={st.error_code} "
            f"{st.error_text}); check the beam and retry"
        )
    if not sensor.ok:
        bad = ", ".join(s.value for s in sensor.statuses) or "no valid sample"
        raise CaptureRejected(
            f"station {k}: displacement sensor reading invalid ({bad}); check the sensor range and target"
        )


def straightness_plan(setup: StraightnessSetup, metadata: dict[str, Any]) -> Generator[Message, Any, None]:
    """Yield the messages of a complete straightness run."""
    t0 = yield OpenRun("straightness", metadata)
    yield Instruct(
        "place_block",
        "Place the block at station 0 (x = 0 mm), against the side face; then confirm.",
        {"station": 0},
    )
    yield ZeroInterferometer()
    start = yield ReadSensor(setup.samples_per_reading)
    yield Log(f"datum set; sensor start reading {start.mean_mm:+.5f} mm")
    for k in range(setup.stations):
        x = setup.station_x_mm(k)
        if k > 0:
            yield Instruct(
                "place_block",
                f"Move the block to station {k} (x = {x:g} mm), against the side face; then confirm.",
                {"station": k},
            )
        ifm = yield TriggerInterferometer()
        sensor = start if k == 0 else (yield ReadSensor(setup.samples_per_reading))
        _check(ifm, sensor, k)
        yield Record(point_record(k, x, t0, ifm, sensor))
        yield Log(f"station {k:3d}  x = {x:8.1f} mm  stry = {ifm.stry_um:+8.3f} um  "
                  f"sensor = {sensor.mean_mm:+.5f} mm")
    yield CloseRun("all stations captured")
