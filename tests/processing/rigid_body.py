"""Test-side exact rigid-body model of a gauge-block station, written from
first principles (rotation matrices, beam-surface intersection) and sharing no
code with ``processing`` or ``mocks``."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq


def rot(ex: float, ey: float, ez: float) -> np.ndarray:
    """R = Rz(ez) @ Ry(ey) @ Rx(ex)."""
    cx, sx, cy, sy, cz, sz = math.cos(ex), math.sin(ex), math.cos(ey), math.sin(ey), math.cos(ez), math.sin(ez)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def surface(x: float, z: float) -> float:
    """A wavy, twisted test surface: y in mm for x, z in mm."""
    return (2.5e-3 * math.sin(2 * math.pi * x / 500.0 + 0.4) + 0.7e-3 * math.cos(2 * math.pi * x / 170.0)
            + 3e-6 * x + (4e-6 + 2e-8 * x) * z)


def beam_hit(e: np.ndarray, d: np.ndarray) -> tuple[float, np.ndarray]:
    """Distance along unit direction d from e to the surface, and the hit point."""
    f = lambda lam: (e + lam * d)[1] - surface(*(e + lam * d)[[0, 2]])  # noqa: E731
    lam = brentq(f, 0.0, 200.0, xtol=1e-15, rtol=1e-15)
    return lam, e + lam * d


def station(pose_r: np.ndarray, pose_t: np.ndarray, p: np.ndarray, e: np.ndarray, b: np.ndarray):
    """World mirror point, sensor distance and hit point for a block pose."""
    pw = pose_r @ p + pose_t
    lam, hit = beam_hit(pose_r @ e + pose_t, pose_r @ b)
    return pw, lam, hit


def euler_zyx(r: np.ndarray) -> tuple[float, float, float]:
    """(ex, ey, ez) of r = Rz(ez) @ Ry(ey) @ Rx(ex)."""
    return math.atan2(r[2, 1], r[2, 2]), -math.asin(r[2, 0]), math.atan2(r[1, 0], r[0, 0])


def simulate(poses: list, p: np.ndarray, e: np.ndarray, b: np.ndarray, sign: str, step_mm: float = 100.0):
    """Record a run for block poses (ex, ey, ez [rad], tx, ty, tz [mm]) in the world.

    The interferometer is zeroed at the first pose: its channels are P's
    displacement and the block's rotation, both in the first pose's block
    frame.  Returns (rows as dicts, truth [n, 3] = sample points in that frame
    relative to the first sample point (mm), Q = first sample point in the
    block frame).
    """
    r0 = rot(*poses[0][:3])
    t0 = np.array(poses[0][3:])
    p0w, lam0, hit0 = station(r0, t0, p, e, b)
    rows, truth = [], []
    for k, (ex, ey, ez, tx, ty, tz) in enumerate(poses):
        r, t = rot(ex, ey, ez), np.array([tx, ty, tz])
        pw, lam, hit = station(r, t, p, e, b)
        d = r0.T @ (pw - p0w)
        ex_rel, ey_rel, ez_rel = euler_zyx(r0.T @ r)
        reading = (lam0 - lam) if sign == "height" else (lam - lam0)  # mm, plus the device's own zero
        rows.append({"station": k, "x_mm": step_mm * k, "lin_um": (d[0] - step_mm * k) * 1e3,
                     "stry_um": d[1] * 1e3, "strz_um": d[2] * 1e3, "pitch_urad": ez_rel * 1e6,
                     "yaw_urad": ey_rel * 1e6, "roll_urad": ex_rel * 1e6, "sensor_mm": reading + 0.3})
        truth.append(r0.T @ (hit - hit0))
    return rows, np.array(truth), e + lam0 * b
