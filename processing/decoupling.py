"""Recover the guideway surface profile from a gauge-block run.

Three decoupling methods (docs/conventions.md, "Decoupling"), each mapping the
recorded channels of every point to the surface sample point's position
``x_mm`` and height ``height_um`` relative to the first point (the datum):

``exact`` (default)
    Full rigid-body kinematics with all six channels: the block's pose
    relative to the datum from the displacement of the mirror point P and the
    rotation R = Rz(ez) Ry(ey) Rx(ex); the sensor beam rotates with the block;
    the sample point is where the beam ends, ``Q + (lambda - lambda0) b`` in the
    block frame.  No small-angle approximation.

``first-order``
    ``h = stry + s + (xQ - xP) ez - (zQ - zP) ex`` (all channels relative to the
    datum), ``x`` = nominal travel.

``patent``
    Seed 001 eq. 17 exactly as written, with the patent's gap-type reading and
    sign, converted to our height: ``h = -dygx``.

The array functions (``*_arrays``) broadcast: every channel array has shape
``(..., n)`` with the datum at index 0 of the last axis; geometry coordinates
are scalars or arrays broadcastable to ``(..., 1)`` (used by the Monte Carlo
evaluation to vary them per trial).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .geometry import BlockGeometry

METHODS: tuple[str, ...] = ("exact", "first-order", "patent")
DEFAULT_METHOD = "exact"

Vec3 = tuple[np.ndarray | float, np.ndarray | float, np.ndarray | float]


@dataclass(frozen=True)
class Channels:
    """Recorded channels of n points as arrays of shape (..., n); index 0 of the last axis is the datum.

    Units as in points.csv.  ``sensor_mm`` is the raw reading (the device's own
    sign and zero).
    """

    x_mm: np.ndarray
    lin_um: np.ndarray
    stry_um: np.ndarray
    strz_um: np.ndarray
    pitch_urad: np.ndarray
    yaw_urad: np.ndarray
    roll_urad: np.ndarray
    sensor_mm: np.ndarray

    @staticmethod
    def from_points(points: pd.DataFrame) -> Channels:
        return Channels(**{f: points[f].to_numpy(dtype=float) for f in Channels.__dataclass_fields__})


@dataclass(frozen=True)
class Setup:
    """Geometry coordinates (mm, block frame) and the sensor sign, possibly per Monte Carlo trial."""

    mirror: Vec3
    sensor: Vec3
    beam: tuple[float, float, float]
    sign: str

    @staticmethod
    def from_geometry(g: BlockGeometry) -> Setup:
        return Setup(g.mirror_mm, g.sensor_mm, g.sensor_beam, g.sensor_sign)


def sensor_height_um(sensor_mm: np.ndarray, sign: str) -> np.ndarray:
    """Sensor readings as surface height (um) relative to the first reading (last axis)."""
    sensor_mm = np.asarray(sensor_mm, dtype=float)
    s = (sensor_mm - sensor_mm[..., :1]) * 1000.0
    return s if sign == "height" else -s


def relative_to_first(values: pd.Series | np.ndarray) -> np.ndarray:
    """Channel values relative to the first point (the datum capture carries noise too)."""
    v = np.asarray(values, dtype=float)
    return v - v[..., :1]


def rotate(ex: np.ndarray, ey: np.ndarray, ez: np.ndarray, v: Vec3) -> Vec3:
    """R v with R = Rz(ez) Ry(ey) Rx(ex), angles in rad, element-wise over broadcast arrays."""
    x, y, z = v
    c, s = np.cos(ex), np.sin(ex)
    y, z = c * y - s * z, s * y + c * z
    c, s = np.cos(ey), np.sin(ey)
    x, z = c * x + s * z, -s * x + c * z
    c, s = np.cos(ez), np.sin(ez)
    x, y = c * x - s * y, s * x + c * y
    return x, y, z


def rotate_back(ex: np.ndarray, ey: np.ndarray, ez: np.ndarray, v: Vec3) -> Vec3:
    """R^T v for the same R as :func:`rotate`."""
    x, y, z = v
    c, s = np.cos(ez), np.sin(ez)
    x, y = c * x + s * y, -s * x + c * y
    c, s = np.cos(ey), np.sin(ey)
    x, z = c * x - s * z, s * x + c * z
    c, s = np.cos(ex), np.sin(ex)
    y, z = c * y + s * z, -s * y + c * z
    return x, y, z


def exact_arrays(ch: Channels, setup: Setup) -> tuple[np.ndarray, np.ndarray]:
    """(x_mm, height_um) of the surface sample points by exact rigid-body kinematics.

    The interferometer frame is the block frame when it was zeroed; the point
    at index 0 (the datum) has pose (R0, d0) in it, point k has (Rk, dk) with
    d the displacement of P (mm).  The block pose of point k relative to the
    datum pose is R0^T Rk, and a block point p goes to
    ``R0^T (Rk (p - P) + dk - d0) + P`` in the datum block frame.  The sample
    point is ``p = Q + dl b`` with ``dl = -s`` the change of the beam length
    (mm; s = sensor change in the height convention), so at the datum it is Q.
    """
    px, py, pz = setup.mirror
    qx, qy, qz = setup.sensor
    bx, by, bz = setup.beam
    dl = -sensor_height_um(ch.sensor_mm, setup.sign) * 1e-3
    ex, ey, ez = (np.asarray(a, dtype=float) * 1e-6 for a in (ch.roll_urad, ch.yaw_urad, ch.pitch_urad))
    v = (qx - px + dl * bx, qy - py + dl * by, qz - pz + dl * bz)
    wx, wy, wz = rotate(ex, ey, ez, v)
    wx = wx + relative_to_first(ch.x_mm) + relative_to_first(ch.lin_um) * 1e-3
    wy = wy + relative_to_first(ch.stry_um) * 1e-3
    wz = wz + relative_to_first(ch.strz_um) * 1e-3
    sx, sy, _ = rotate_back(ex[..., :1], ey[..., :1], ez[..., :1], (wx, wy, wz))
    # sx + px, sy + py is the sample point; at the datum it is Q analytically, so subtracting
    # the computed datum value instead of Q makes the datum exactly 0 despite rounding.
    return relative_to_first(sx), relative_to_first(sy) * 1e3


def _nominal_x(ch: Channels) -> np.ndarray:
    x = relative_to_first(ch.x_mm)
    return np.broadcast_to(x, np.broadcast_shapes(x.shape, np.shape(ch.stry_um)))


def first_order_arrays(ch: Channels, setup: Setup) -> tuple[np.ndarray, np.ndarray]:
    """(x_mm, height_um): nominal x; h = stry + s + (xQ - xP) ez - (zQ - zP) ex, relative to the datum."""
    px, _, pz = setup.mirror
    qx, _, qz = setup.sensor
    s = sensor_height_um(ch.sensor_mm, setup.sign)
    ez = relative_to_first(ch.pitch_urad) * 1e-6
    ex = relative_to_first(ch.roll_urad) * 1e-6
    h = relative_to_first(ch.stry_um) + s + (qx - px) * 1e3 * ez - (qz - pz) * 1e3 * ex
    return _nominal_x(ch), h


def patent_arrays(ch: Channels, setup: Setup) -> tuple[np.ndarray, np.ndarray]:
    """(x_mm, height_um) by seed 001 eq. 17 as written, returned as our height h = -dygx.

    dygx = ylx - ylx0 - dysx + (xp0 - xq0) sin(ezx) + (zq0 - zp0) sin(exx), with
    ylx the reading in the patent's gap sense (grows as the surface moves away)
    and dysx, ezx, exx the channels as recorded (the interferometer was zeroed
    at the first station, so they are not re-referenced).
    """
    px, _, pz = setup.mirror
    qx, _, qz = setup.sensor
    ylx_minus_ylx0 = -sensor_height_um(ch.sensor_mm, setup.sign)  # gap sense, um
    ezx = np.asarray(ch.pitch_urad, dtype=float) * 1e-6
    exx = np.asarray(ch.roll_urad, dtype=float) * 1e-6
    dygx = (ylx_minus_ylx0 - np.asarray(ch.stry_um, dtype=float)
            + (px - qx) * 1e3 * np.sin(ezx) + (qz - pz) * 1e3 * np.sin(exx))
    return _nominal_x(ch), -dygx


DECOUPLERS: dict[str, Callable[[Channels, Setup], tuple[np.ndarray, np.ndarray]]] = {
    "exact": exact_arrays,
    "first-order": first_order_arrays,
    "patent": patent_arrays,
}


def check_method(method: str) -> None:
    if method not in DECOUPLERS:
        raise ValueError(f"unknown decoupling method {method!r}; choose one of {', '.join(METHODS)}")


def decouple(points: pd.DataFrame, geometry: BlockGeometry, method: str = DEFAULT_METHOD) -> pd.DataFrame:
    """Per-point profile (station, x_mm, height_um) by ``method``; the first row is the datum."""
    check_method(method)
    if len(points) == 0:
        raise ValueError("no points to process")
    x, h = DECOUPLERS[method](Channels.from_points(points), Setup.from_geometry(geometry))
    return pd.DataFrame({"station": points["station"].to_numpy(dtype=int), "x_mm": x, "height_um": h})


def decouple_first_order(points: pd.DataFrame, geometry: BlockGeometry) -> pd.DataFrame:
    """Profile (station, x_mm, height_um) by the first-order formula; x_mm = nominal travel."""
    return decouple(points, geometry, "first-order")
