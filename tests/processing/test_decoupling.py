"""First-order decoupling against an exact rigid-body computation written in
the test, and the mapping of the patent's eq. 17 onto our conventions."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from processing.decoupling import decouple_first_order
from processing.geometry import BlockGeometry

from . import rigid_body

P = np.array([50.0, 110.0, 5.0])       # mirror point, block frame (mm)
E = np.array([150.0, 30.0, 40.0])      # sensor head, block frame (mm)
B = np.array([0.0, -1.0, 0.0])          # beam direction


def simulate(poses: list, sign: str):
    """points DataFrame, true heights (um) and Q for poses (ex, ey, ez [rad], tx, ty, tz [mm])."""
    rec = rigid_body.simulate(poses, P, E, B, sign)
    return pd.DataFrame(rec.rows), rec.truth[:, 1] * 1e3, rec.q


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


@pytest.mark.parametrize("method", ["exact", "first-order", "patent"])
def test_an_empty_run_is_refused(method: str) -> None:
    from processing.decoupling import CHANNEL_COLUMNS, decouple_run

    empty = pd.DataFrame({c: [] for c in ("station", "pass", *CHANNEL_COLUMNS)})
    with pytest.raises(ValueError, match="no points to process"):
        decouple_run(empty, BlockGeometry(tuple(P), tuple(E), tuple(B), "height"), method)  # type: ignore[arg-type]
