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
