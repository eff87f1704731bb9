"""Test-side exact rigid-body model of a gauge-block station, written from
first principles (rotation matrices, beam-surface intersection) and sharing no
code with ``processing`` or ``mocks``.

The interferometer measures in the laser's fixed frame (docs/conventions.md,
"The laser frame"): the world frame of the model expressed in the laser's
axes (``laser``: the laser's axes in the world, columns X, Y, Z; X along the
beam).  It is zeroed at one block pose (by default the first): it reports P's
displacement since that pose and the block's rotation since then, both in the
laser frame, and the zeroing pose itself is the datum block's orientation in
that frame (its angles are the set-up's ``datum_angles_urad``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

Surface = Callable[[float, float], float]


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


def beam_hit(e: np.ndarray, d: np.ndarray, surf: Surface = surface) -> tuple[float, np.ndarray]:
    """Distance along unit direction d from e to the surface, and the hit point."""
    f = lambda lam: (e + lam * d)[1] - surf(*(e + lam * d)[[0, 2]])  # noqa: E731
    lam = brentq(f, 0.0, 200.0, xtol=1e-15, rtol=1e-15)
    return lam, e + lam * d


def station(pose_r: np.ndarray, pose_t: np.ndarray, p: np.ndarray, e: np.ndarray, b: np.ndarray,
            surf: Surface = surface):
    """World mirror point, sensor distance and hit point for a block pose."""
    pw = pose_r @ p + pose_t
    lam, hit = beam_hit(pose_r @ e + pose_t, pose_r @ b, surf)
    return pw, lam, hit


def euler_zyx(r: np.ndarray) -> tuple[float, float, float]:
    """(ex, ey, ez) of r = Rz(ez) @ Ry(ey) @ Rx(ex)."""
    return math.atan2(r[2, 1], r[2, 2]), -math.asin(r[2, 0]), math.atan2(r[1, 0], r[0, 0])


@dataclass(frozen=True)
class Recording:
    """A simulated run: points.csv rows, the truth and what a technician would set up.

    ``truth``: [n, 3] sample points in the laser frame relative to the first
    one (mm); ``q``: the first sample point in the block frame (the set-up's
    Q); ``datum_urad``: the zeroing pose's angles in the laser frame,
    ``{"roll", "yaw", "pitch"}`` (urad); ``rotations``: the block's rotation
    since zeroing in the laser frame per point; ``datum_r``: the zeroing pose's
    rotation in the laser frame; ``beam_change_mm``: the beam length minus the
    first point's, per point.
    """

    rows: list[dict]
    truth: np.ndarray
    q: np.ndarray
    datum_urad: dict[str, float]
    rotations: list[np.ndarray]
    datum_r: np.ndarray
    beam_change_mm: np.ndarray


def simulate(poses: Sequence, p: np.ndarray, e: np.ndarray, b: np.ndarray, sign: str, step_mm: float = 100.0,
             *, laser: np.ndarray | None = None, zero: Sequence | None = None,
             surf: Surface = surface) -> Recording:
    """Record a run for block poses (ex, ey, ez [rad], tx, ty, tz [mm]) in the world.

    ``laser``: the laser's axes in the world (default the world's own);
    ``zero``: the pose at which the interferometer was zeroed (default the
    first pose).  Channels: P's displacement since ``zero`` and the rotation
    R_k R_zero^T, both in the laser frame; the sensor reading is the beam
    length change since the first pose (plus the device's own zero).
    """
    lz = np.eye(3) if laser is None else np.asarray(laser, dtype=float)
    zero = poses[0] if zero is None else zero
    rz, tz = rot(*zero[:3]), np.array(zero[3:], dtype=float)
    pzw = rz @ p + tz
    r0, t0 = rot(*poses[0][:3]), np.array(poses[0][3:], dtype=float)
    _, lam0, hit0 = station(r0, t0, p, e, b, surf)
    rows, truth, rotations, dlam = [], [], [], []
    for k, (ex, ey, ez, tx, ty, tz_) in enumerate(poses):
        r, t = rot(ex, ey, ez), np.array([tx, ty, tz_])
        pw, lam, hit = station(r, t, p, e, b, surf)
        d = lz.T @ (pw - pzw)
        rel = lz.T @ r @ rz.T @ lz
        ex_rel, ey_rel, ez_rel = euler_zyx(rel)
        reading = (lam0 - lam) if sign == "height" else (lam - lam0)  # mm, plus the device's own zero
        rows.append({"station": k, "x_mm": step_mm * k, "lin_um": (d[0] - step_mm * k) * 1e3,
                     "stry_um": d[1] * 1e3, "strz_um": d[2] * 1e3, "pitch_urad": ez_rel * 1e6,
                     "yaw_urad": ey_rel * 1e6, "roll_urad": ex_rel * 1e6, "sensor_mm": reading + 0.3})
        truth.append(lz.T @ (hit - hit0))
        rotations.append(rel)
        dlam.append(lam - lam0)
    datum_r = lz.T @ rz
    ax, ay, az = euler_zyx(datum_r)
    return Recording(rows, np.array(truth), e + lam0 * b, {"roll": ax * 1e6, "yaw": ay * 1e6, "pitch": az * 1e6},
                     rotations, datum_r, np.array(dlam))


def resting_poses(surf: Surface, length_mm: float, roll: Sequence[float], yaw: Sequence[float],
                  placement_mm: Sequence[float]) -> list[tuple[float, ...]]:
    """Poses of a block stepped along ``surf`` by its own length.

    The block stands on its bottom-centre line: the rear end (the block
    origin) and the front end (``length_mm`` along the block's X) both touch
    the surface.  Station k's roll and yaw are given (rad); its pitch is what
    puts the front end on the surface (root finding).  The next station's rear
    end lands where this one's front end was, moved ``placement_mm[k + 1]``
    along the world X and dropped onto the surface.
    """
    poses = []
    x, z = 0.0, 0.0
    for k in range(len(roll)):
        if k:
            x += placement_mm[k]
        o = np.array([x, surf(x, z), z])
        ex, ey = roll[k], yaw[k]

        def gap(ez: float, o: np.ndarray = o, ex: float = ex, ey: float = ey) -> float:
            f = o + rot(ex, ey, ez) @ np.array([length_mm, 0.0, 0.0])
            return f[1] - surf(f[0], f[2])

        ez = brentq(gap, -0.05, 0.05, xtol=1e-16, rtol=1e-15)
        poses.append((ex, ey, ez, *o))
        front = o + rot(ex, ey, ez) @ np.array([length_mm, 0.0, 0.0])
        x, z = float(front[0]), float(front[2])
    return poses
