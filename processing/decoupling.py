"""Recover the guideway surface profile from a gauge-block run.

Three decoupling methods (docs/conventions.md, "Decoupling"), each mapping the
recorded channels of every point to the surface sample point's position
``x_mm`` and height ``height_um`` relative to the first point (the datum):

``exact`` (default)
    Full rigid-body kinematics with all six channels, in the laser's fixed
    frame: the block's pose from the datum block's angles in that frame
    (measured, or the pitch estimated from the first step), the displacement
    of the mirror point P and the rotation R = Rz(ez) Ry(ey) Rx(ex) since the
    datum; the sensor beam rotates with the block; the sample point is where
    the beam ends, ``Q + (lambda - lambda0) b`` in the block frame.  No
    small-angle approximation.

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
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from .geometry import DATUM_AXES, BlockGeometry
from .point_columns import Points, as_columns, row_count

if TYPE_CHECKING:  # the live display decouples rows without pandas; whole runs bring it
    import pandas as pd

METHODS: tuple[str, ...] = ("exact", "first-order", "patent")
DEFAULT_METHOD = "exact"

Vec3 = tuple[np.ndarray | float, np.ndarray | float, np.ndarray | float]


CHANNEL_COLUMNS: tuple[str, ...] = ("x_mm", "lin_um", "stry_um", "strz_um", "pitch_urad", "yaw_urad",
                                    "roll_urad", "sensor_mm")


@dataclass(frozen=True)
class Channels:
    """Recorded channels of n points as arrays of shape (..., n); index 0 of the last axis is the datum.

    Units as in points.csv.  ``sensor_mm`` is the raw reading (the device's own
    sign and zero).  ``first_step``: index of the first step's point (the first
    forward point one station after the datum; None if there is none), from
    which the exact method estimates the datum pitch.
    """

    x_mm: np.ndarray
    lin_um: np.ndarray
    stry_um: np.ndarray
    strz_um: np.ndarray
    pitch_urad: np.ndarray
    yaw_urad: np.ndarray
    roll_urad: np.ndarray
    sensor_mm: np.ndarray
    first_step: int | None = None

    @staticmethod
    def from_points(points: Points) -> Channels:
        cols = as_columns(points)
        return Channels(**{f: np.asarray(cols[f], dtype=float) for f in CHANNEL_COLUMNS},
                        first_step=first_step_index(cols))


def first_step_index(points: Points) -> int | None:
    """Row index of the first step: the forward-pass point at the datum's station + 1 (None if absent)."""
    cols = as_columns(points)
    if not cols:
        return None
    st = np.asarray(cols["station"], dtype=int)
    fwd = np.asarray(cols["pass"], dtype=int) == 0 if "pass" in cols else np.ones(len(st), dtype=bool)
    hits = np.flatnonzero(fwd & (st == st[:1] + 1))  # st[:1]: no datum station without rows
    return int(hits[0]) if hits.size else None


@dataclass(frozen=True)
class Setup:
    """Geometry coordinates (mm, block frame), the sensor sign and the measured datum
    angles (roll, yaw, pitch in urad, None = not measured), possibly per Monte Carlo trial."""

    mirror: Vec3
    sensor: Vec3
    beam: tuple[float, float, float]
    sign: str
    datum_urad: tuple[float | None, float | None, float | None] = (None, None, None)

    @staticmethod
    def from_geometry(g: BlockGeometry) -> Setup:
        return Setup(g.mirror_mm, g.sensor_mm, g.sensor_beam, g.sensor_sign, g.datum_angles_urad.as_tuple())


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


DATUM_PITCH_ITERATIONS = 3  # each shrinks the pitch error by ~|first step's angle change| x |P| / L (< 1e-2)


def estimate_datum_pitch(ch: Channels, setup: Setup, ex0: np.ndarray | float,
                         ey0: np.ndarray | float) -> np.ndarray | float:
    """Datum pitch (rad) in the laser frame from the first step; 0 without one.

    The block steps by its own length, so its rear-bottom-centre (the block
    origin O) at the first step lands where its front-bottom-centre was at the
    datum: O1 - O0 points along the datum block's X axis.  The datum angles are
    those of the pose at which the interferometer was zeroed (R0; every reading
    is relative to it), and the datum capture stands at dR0 R0, where dR0 is its
    own (small, non-zero) angle reading; so dR0^T (O1 - O0) points along
    R0 (1, 0, 0) = (cos ey cos ez, cos ey sin ez, -sin ey), whose pitch is atan2
    of its Y and X components whatever the roll and yaw.  O = P_laser + d - dR R0 P,
    so ``O1 - O0 = (d1 - d0) - (dR1 - dR0) R0 P``; R0 holds the pitch sought,
    solved by fixed-point iteration from 0 (the term is second order).
    """
    i = ch.first_step
    if i is None:
        return 0.0

    def at(a: np.ndarray, k: int) -> np.ndarray:
        return np.asarray(a, dtype=float)[..., k:k + 1]

    dx = at(ch.x_mm, i) - at(ch.x_mm, 0) + (at(ch.lin_um, i) - at(ch.lin_um, 0)) * 1e-3
    dy = (at(ch.stry_um, i) - at(ch.stry_um, 0)) * 1e-3
    dz = (at(ch.strz_um, i) - at(ch.strz_um, 0)) * 1e-3
    r1 = _rows(*(at(c, i) * 1e-6 for c in (ch.roll_urad, ch.yaw_urad, ch.pitch_urad)))
    r0 = _rows(*(at(c, 0) * 1e-6 for c in (ch.roll_urad, ch.yaw_urad, ch.pitch_urad)))
    m = [[r1[j][k] - r0[j][k] for k in range(3)] for j in range(3)]  # dR1 - dR0
    wx, wy, wz = rotate(ex0, ey0, 0.0, setup.mirror)  # R0 P = Rz(ez0) w
    d = (dx, dy, dz)
    ez0: np.ndarray | float = 0.0
    for _ in range(DATUM_PITCH_ITERATIONS):
        c, s = np.cos(ez0), np.sin(ez0)
        px, py = c * wx - s * wy, s * wx + c * wy
        cx, cy, cz = (d[j] - (m[j][0] * px + m[j][1] * py + m[j][2] * wz) for j in range(3))
        # dR0^T (O1 - O0): the columns X and Y of dR0 dotted with the chord
        ux = r0[0][0] * cx + r0[1][0] * cy + r0[2][0] * cz
        uy = r0[0][1] * cx + r0[1][1] * cy + r0[2][1] * cz
        ez0 = np.arctan2(uy, ux)
    return ez0


def _rows(ex: np.ndarray, ey: np.ndarray, ez: np.ndarray) -> tuple[tuple[np.ndarray, ...], ...]:
    """The rows X, Y and Z of R = Rz(ez) Ry(ey) Rx(ex)."""
    cx, sx, cy, sy, cz, sz = np.cos(ex), np.sin(ex), np.cos(ey), np.sin(ey), np.cos(ez), np.sin(ez)
    return ((cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx),
            (sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx),
            (-sy, cy * sx, cy * cx))


def datum_angles_rad(ch: Channels, setup: Setup) -> tuple[np.ndarray | float, np.ndarray | float,
                                                            np.ndarray | float]:
    """(ex0, ey0, ez0) of the datum block in the laser frame: the measured ones; an
    unmeasured pitch estimated from the first step; an unmeasured roll or yaw 0."""
    roll, yaw, pitch = setup.datum_urad
    ex0 = 0.0 if roll is None else roll * 1e-6
    ey0 = 0.0 if yaw is None else yaw * 1e-6
    ez0 = estimate_datum_pitch(ch, setup, ex0, ey0) if pitch is None else pitch * 1e-6
    return ex0, ey0, ez0


def exact_arrays(ch: Channels, setup: Setup) -> tuple[np.ndarray, np.ndarray]:
    """(x_mm, height_um) of the surface sample points by exact rigid-body kinematics, in the laser frame.

    The interferometer reports, in the laser's fixed frame, the displacement
    d of P since it was zeroed and the rotation dR = Rz(ez) Ry(ey) Rx(ex)
    since then; the block's pose then was R0 = R(datum angles).  Point k's
    pose is (dRk R0, P_laser + dk), so a block point p lies at
    ``dRk R0 (p - P) + dk`` (plus the constant P_laser).  The sample point is
    ``p = Q + dl b`` with ``dl = -s`` the change of the beam length (mm; s =
    sensor change in the height convention), so at the datum it is Q.
    """
    px, py, pz = setup.mirror
    qx, qy, qz = setup.sensor
    bx, by, bz = setup.beam
    dl = -sensor_height_um(ch.sensor_mm, setup.sign) * 1e-3
    ex, ey, ez = (np.asarray(a, dtype=float) * 1e-6 for a in (ch.roll_urad, ch.yaw_urad, ch.pitch_urad))
    # R0 (Q - P + dl b) = R0 (Q - P) + dl R0 b: two constant vectors rotated instead of every point's
    datum = datum_angles_rad(ch, setup)
    cx, cy, cz = rotate(*datum, (qx - px, qy - py, qz - pz))
    rbx, rby, rbz = rotate(*datum, (bx, by, bz))
    wx, wy, _ = rotate(ex, ey, ez, (cx + dl * rbx, cy + dl * rby, cz + dl * rbz))
    wx = wx + relative_to_first(ch.x_mm) + relative_to_first(ch.lin_um) * 1e-3
    wy = wy + relative_to_first(ch.stry_um) * 1e-3
    # wx, wy is the sample point minus P_laser; its datum value is (R0 (Q - P)) analytically, so
    # subtracting the computed datum value makes the datum exactly 0 despite rounding.
    return relative_to_first(wx), relative_to_first(wy) * 1e3


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
    dygx = (ylx_minus_ylx0 - np.asarray(ch.stry_um)  # ylx is float64: so is the difference
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


def decouple(points: Points, geometry: BlockGeometry, method: str = DEFAULT_METHOD) -> pd.DataFrame:
    """Per-point profile (station, x_mm, height_um) by ``method``; the first row is the datum."""
    return decouple_run(points, geometry, method).profile


@dataclass(frozen=True)
class DatumAnglesUsed:
    """The datum block's angles in the laser frame (urad) the exact method used, and the
    source of each: ``measured`` (set-up), ``estimated`` (from the first step) or
    ``assumed`` (not measured and not observable, taken as 0; a pitch without a first step too)."""

    roll_urad: float
    yaw_urad: float
    pitch_urad: float
    source: dict[str, str]

    def to_dict(self) -> dict[str, Any]:
        return {"roll": self.roll_urad, "yaw": self.yaw_urad, "pitch": self.pitch_urad, "source": dict(self.source)}


def datum_angles_of(ch: Channels, setup: Setup) -> DatumAnglesUsed:
    """The datum angles :func:`exact_arrays` takes for these channels (one run, 1-D channels)."""
    angles = datum_angles_rad(ch, setup)
    source, used = {}, []
    for k, axis in enumerate(DATUM_AXES):  # the three axes of datum_urad and angles, in order
        given, rad = setup.datum_urad[k], angles[k]
        estimated = axis == "pitch" and ch.first_step is not None
        source[axis] = "measured" if given is not None else ("estimated" if estimated else "assumed")
        used.append(float(given) if given is not None else np.asarray(rad).item() * 1e6)
    return DatumAnglesUsed(*used, source=source)


def datum_angles_used(points: Points, geometry: BlockGeometry) -> DatumAnglesUsed:
    """What :func:`exact_arrays` takes for the datum angles of this run."""
    return datum_angles_of(Channels.from_points(points), Setup.from_geometry(geometry))


@dataclass(frozen=True)
class Decoupled:
    """A decoupled run: the per-point profile (``columns`` station, x_mm, height_um; the first row is
    the datum; ``profile``: the same as a DataFrame, pandas imported on first use), the channels it came
    from and, for ``exact``, the datum angles it used."""

    columns: dict[str, np.ndarray]
    channels: Channels
    datum: DatumAnglesUsed | None

    @property
    def profile(self) -> pd.DataFrame:
        import pandas as pd

        return pd.DataFrame(self.columns)


def decouple_run(points: Points, geometry: BlockGeometry, method: str = DEFAULT_METHOD) -> Decoupled:
    """Decouple every point by ``method`` (see :func:`decouple`), keeping what the result reports."""
    check_method(method)
    cols = as_columns(points)
    if row_count(cols) == 0:
        raise ValueError("no points to process")
    ch, setup = Channels.from_points(cols), Setup.from_geometry(geometry)
    datum = None
    if method == "exact":
        datum = datum_angles_of(ch, setup)
        setup = replace(setup, datum_urad=(datum.roll_urad, datum.yaw_urad, datum.pitch_urad))  # estimated once
    x, h = DECOUPLERS[method](ch, setup)
    return Decoupled({"station": np.asarray(cols["station"], dtype=int), "x_mm": x, "height_um": h}, ch, datum)


def decouple_first_order(points: Points, geometry: BlockGeometry) -> pd.DataFrame:
    """Profile (station, x_mm, height_um) by the first-order formula; x_mm = nominal travel."""
    return decouple(points, geometry, "first-order")
