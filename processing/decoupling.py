"""Recover the guideway surface profile from a gauge-block run.

First-order decoupling in our conventions (docs/conventions.md):

    h = stry + s + (xQ - xP) * ez - (zQ - zP) * ex

with s the sensor reading in the height convention relative to the first
station (um), ez = pitch and ex = roll (rad), P = mirror point, Q = sensor
sample point (mm).  All channels are relative to the first station, so h is
the surface height at the sample point relative to the first station.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .geometry import BlockGeometry


def sensor_height_um(sensor_mm: np.ndarray, sign: str) -> np.ndarray:
    """Sensor readings as surface height (um) relative to the first reading."""
    s = (np.asarray(sensor_mm, dtype=float) - float(sensor_mm[0])) * 1000.0
    return s if sign == "height" else -s


def relative_to_first(values: pd.Series | np.ndarray) -> np.ndarray:
    """Channel values relative to the first station (the datum capture carries noise too)."""
    v = np.asarray(values, dtype=float)
    return v - v[0]


def decouple_first_order(points: pd.DataFrame, geometry: BlockGeometry) -> pd.DataFrame:
    """Profile (station, x_mm, height_um) by the first-order formula.

    ``x_mm`` is the nominal station position relative to the first station.
    """
    if len(points) == 0:
        raise ValueError("no points to process")
    xp, _, zp = geometry.mirror_mm
    xq, _, zq = geometry.sensor_mm
    s = sensor_height_um(points["sensor_mm"].to_numpy(), geometry.sensor_sign)
    ez = relative_to_first(points["pitch_urad"]) * 1e-6
    ex = relative_to_first(points["roll_urad"]) * 1e-6
    stry = relative_to_first(points["stry_um"])
    h_um = stry + s + (xq - xp) * 1e3 * ez - (zq - zp) * 1e3 * ex
    x = points["x_mm"].to_numpy(dtype=float)
    return pd.DataFrame(
        {"station": points["station"].to_numpy(dtype=int), "x_mm": x - x[0], "height_um": h_um}
    )
