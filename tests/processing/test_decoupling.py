"""First-order decoupling against an exact rigid-body computation written in
the test, and the mapping of the patent's eq. 17 onto our conventions."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from processing.decoupling import decouple_first_order
from processing.geometry import BlockGeometry

from .rigid_body import rot, station

P = np.array([50.0, 110.0, 5.0])       # mirror point, block frame (mm)
E = np.array([150.0, 30.0, 40.0])      # sensor head, block frame (mm)
B = np.array([0.0, -1.0, 0.0])          # beam direction


def simulate(poses: list[tuple[float, float, float, float, float, float]], sign: str):
    """points DataFrame, true heights and Q for poses (ex, ey, ez [rad], tx, ty, tz [mm]).

    The datum (first pose) defines the interferometer frame: channels are the
    displacement of P and the rotation of the block relative to it.
    """
    r0 = rot(*poses[0][:3])
    t0 = np.array(poses[0][3:])
    rows, truth = [], []
    p0w, lam0, hit0 = station(r0, t0, P, E, B)
    q_block = E + lam0 * B  # where the beam meets the surface at the first station
    for k, (ex, ey, ez, tx, ty, tz) in enumerate(poses):
        r, t = rot(ex, ey, ez), np.array([tx, ty, tz])
        pw, lam, hit = station(r, t, P, E, B)
        d = r0.T @ (pw - p0w)
        rel = r0.T @ r
        ey_rel = -math.asin(rel[2, 0])
        ex_rel = math.atan2(rel[2, 1], rel[2, 2])
        ez_rel = math.atan2(rel[1, 0], rel[0, 0])
        reading = (lam0 - lam) if sign == "height" else (lam - lam0)  # mm, device's own zero
        rows.append({"station": k, "x_mm": 100.0 * k, "lin_um": (d[0] - 100.0 * k) * 1e3,
                     "stry_um": d[1] * 1e3, "strz_um": d[2] * 1e3, "pitch_urad": ez_rel * 1e6,
                     "yaw_urad": ey_rel * 1e6, "roll_urad": ex_rel * 1e6, "sensor_mm": reading + 0.3})
        truth.append((r0.T @ (hit - hit0))[1] * 1e3)
    return pd.DataFrame(rows), np.array(truth), q_block


def random_poses(rng: np.random.Generator, n: int, angle: float) -> list:
    poses = []
    for k in range(n):
        ex, ey, ez = rng.uniform(-angle, angle, 3)
        poses.append((ex, ey, ez, 100.0 * k + rng.normal(0, 0.02), rng.normal(0, 0.005), rng.normal(0, 0.005)))
    return poses


@pytest.mark.parametrize("sign", ["height", "gap"])
def test_first_order_matches_exact_rigid_body_at_guideway_angles(sign: str) -> None:
    rng = np.random.default_rng(11)
    points, truth, q = simulate(random_poses(rng, 15, 50e-6), sign)
    geom = BlockGeometry(tuple(P), tuple(q), tuple(B), sign)  # type: ignore[arg-type]
    profile = decouple_first_order(points, geom)
    assert profile["height_um"].iloc[0] == 0.0
    # Neglected terms are second order: angle^2 x lever arm (~0.4 nm) and the
    # sample point's x shift times the surface slope.
    np.testing.assert_allclose(profile["height_um"], truth, atol=2e-3)
    assert list(profile["x_mm"]) == [100.0 * k for k in range(15)]


def test_each_term_matters() -> None:
    """Dropping the pitch or roll term, or flipping the sensor sign, is caught."""
    rng = np.random.default_rng(5)
    points, truth, q = simulate(random_poses(rng, 10, 50e-6), "height")
    for wrong in (
        points.assign(pitch_urad=0.0),
        points.assign(roll_urad=0.0),
        points.assign(sensor_mm=-points["sensor_mm"]),
    ):
        h = decouple_first_order(wrong, BlockGeometry(tuple(P), tuple(q)))["height_um"]  # type: ignore[arg-type]
        assert np.max(np.abs(h - truth)) > 0.1


def test_patent_eq17_is_minus_our_height_for_a_gap_reading() -> None:
    """Seed 001 eq. 17: dygx = ylx - ylx0 - dysx + (xp0 - xq0) sin ezx + (zq0 - zp0) sin exx.

    With a gap-type reading (ylx grows as the surface moves away) eq. 17's
    dygx is the negative of our height."""
    rng = np.random.default_rng(8)
    points, truth, q = simulate(random_poses(rng, 12, 40e-6), "gap")
    xp0, _, zp0 = P
    xq0, _, zq0 = q
    ylx = points["sensor_mm"].to_numpy() * 1e3
    dysx = points["stry_um"].to_numpy()
    ezx = points["pitch_urad"].to_numpy() * 1e-6
    exx = points["roll_urad"].to_numpy() * 1e-6
    dygx = ylx - ylx[0] - dysx + (xp0 - xq0) * 1e3 * np.sin(ezx) + (zq0 - zp0) * 1e3 * np.sin(exx)
    ours = decouple_first_order(points, BlockGeometry(tuple(P), tuple(q), tuple(B), "gap"))["height_um"]  # type: ignore[arg-type]
    np.testing.assert_allclose(dygx, -ours.to_numpy(), atol=1e-9)
    np.testing.assert_allclose(dygx, -truth, atol=2e-3)
