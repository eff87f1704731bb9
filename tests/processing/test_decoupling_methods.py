"""Exact decoupling against the test-side rigid-body simulation at large angles,
and agreement of the three methods at guideway angles."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from processing.decoupling import METHODS, decouple
from processing.geometry import BlockGeometry, DatumAngles

from . import rigid_body

P = np.array([50.0, 110.0, 5.0])       # mirror point, block frame (mm)
E = np.array([150.0, 30.0, 40.0])      # sensor head, block frame (mm)
TILTED = np.array([0.04, -1.0, 0.03]) / np.linalg.norm([0.04, -1.0, 0.03])


def random_poses(rng: np.random.Generator, n: int, angle: float, scatter_mm: float = 0.02) -> list:
    poses = []
    for k in range(n):
        ex, ey, ez = rng.uniform(-angle, angle, 3)
        poses.append((ex, ey, ez, 100.0 * k + rng.normal(0, scatter_mm), rng.normal(0, 0.005),
                      rng.normal(0, 0.005)))
    return poses


# The laser's axes in the world: its beam is not quite along the guideway (a real alignment).
LASER = rigid_body.rot(-25e-6, 60e-6, -80e-6)


def geometry(rec: rigid_body.Recording, beam: np.ndarray, sign: str) -> BlockGeometry:
    """The set-up geometry with the datum block's angles in the laser frame as measured."""
    angles = DatumAngles(**{f"{k}_urad": v for k, v in rec.datum_urad.items()})
    return BlockGeometry(tuple(P), tuple(rec.q), tuple(beam), sign, angles)  # type: ignore[arg-type]


def run(rng_seed: int, angle: float, beam: np.ndarray, sign: str, n: int = 12):
    """Random block poses (not resting on the surface: the datum angles are given, not estimated)."""
    rec = rigid_body.simulate(random_poses(np.random.default_rng(rng_seed), n, angle), P, E, beam, sign,
                              laser=LASER)
    return pd.DataFrame(rec.rows), rec.truth, geometry(rec, beam, sign)


@pytest.mark.parametrize("sign", ["height", "gap"])
@pytest.mark.parametrize("beam", [np.array([0.0, -1.0, 0.0]), TILTED], ids=["down", "tilted"])
def test_exact_matches_rigid_body_at_5_mrad(sign: str, beam: np.ndarray) -> None:
    points, truth, geom = run(3, 5e-3, beam, sign)
    prof = decouple(points, geom, "exact")
    np.testing.assert_allclose(prof["height_um"], truth[:, 1] * 1e3, rtol=0, atol=1e-6)
    # x of each sample point (moves with pitch and with the placement scatter)
    np.testing.assert_allclose(prof["x_mm"], truth[:, 0], rtol=0, atol=1e-9)
    # ... and at these angles the first-order formula is far off
    fo = decouple(points, geom, "first-order")["height_um"].to_numpy()
    assert np.max(np.abs(fo - truth[:, 1] * 1e3)) > 1.0


def test_exact_with_a_noisy_datum_capture() -> None:
    """The interferometer was zeroed at a pose a little off the datum capture's (noise at
    zeroing: the datum's own channels are not zero): the channels and the datum angles
    refer to the zeroing pose, and the exact method still recovers the true profile."""
    poses = random_poses(np.random.default_rng(4), 12, 2e-3)
    ex, ey, ez, tx, ty, tz = poses[0]
    zero = (ex + 30e-6, ey - 20e-6, ez + 45e-6, tx + 0.3e-3, ty - 0.2e-3, tz + 0.1e-3)
    rec = rigid_body.simulate(poses, P, E, TILTED, "height", laser=LASER, zero=zero)
    points = pd.DataFrame(rec.rows)
    assert abs(points["pitch_urad"].iloc[0] + 45.0) < 1.0  # the datum capture reads the offset
    prof = decouple(points, geometry(rec, TILTED, "height"), "exact")
    np.testing.assert_allclose(prof["height_um"], rec.truth[:, 1] * 1e3, rtol=0, atol=1e-6)
    np.testing.assert_allclose(prof["x_mm"], rec.truth[:, 0], rtol=0, atol=1e-9)


def one_axis_poses(rng: np.random.Generator, n: int, axis: int, angle: float) -> list:
    poses = []
    for k in range(n):
        a = [0.0, 0.0, 0.0]
        a[axis] = rng.uniform(-angle, angle) if k else 0.0  # angles relative to the datum <= angle
        poses.append((*a, 100.0 * k + rng.normal(0, 0.02), rng.normal(0, 0.005), rng.normal(0, 0.005)))
    return poses


@pytest.mark.parametrize("sign", ["height", "gap"])
@pytest.mark.parametrize("axis", [0, 1, 2], ids=["roll", "yaw", "pitch"])
def test_three_methods_agree_up_to_1_mrad_about_one_axis(sign: str, axis: int) -> None:
    """Rotations up to 1 mrad about one axis (P 110 mm above the sample point):
    the three methods agree to < 0.07 um.  The neglected terms are second order:
    the vertical P-Q offset x angle^2 / 2 (110 mm x 1e-6 / 2 = 0.055 um) and the
    sample point's x shift x the surface slope."""
    poses = one_axis_poses(np.random.default_rng(6 + axis), 20, axis, 1e-3)
    rec = rigid_body.simulate(poses, P, E, np.array([0.0, -1.0, 0.0]), sign)
    geom = geometry(rec, np.array([0.0, -1.0, 0.0]), sign)
    hs = {m: decouple(pd.DataFrame(rec.rows), geom, m)["height_um"].to_numpy() for m in METHODS}
    np.testing.assert_allclose(hs["exact"], rec.truth[:, 1] * 1e3, atol=1e-6)
    for m in METHODS:
        assert np.max(np.abs(hs[m] - hs["exact"])) < 0.07, m


def test_three_methods_agree_within_10_nm_at_200_urad() -> None:
    """All three angles up to 0.2 mrad at once (far beyond a guideway's tens of urad)."""
    points, truth, geom = run(6, 2e-4, np.array([0.0, -1.0, 0.0]), "height", n=20)
    hs = {m: decouple(points, geom, m)["height_um"].to_numpy() for m in METHODS}
    for m in METHODS:
        assert np.max(np.abs(hs[m] - truth[:, 1] * 1e3)) < 0.01, m


def test_first_order_departs_by_second_order_terms_at_1_mrad() -> None:
    """At 1 mrad about all three axes at once the first-order formula errs by about
    (yQ - yP) (ex^2 + ez^2) / 2, i.e. ~0.1 um here: the table in conventions.md."""
    points, truth, geom = run(6, 1e-3, np.array([0.0, -1.0, 0.0]), "height", n=20)
    err = decouple(points, geom, "first-order")["height_um"].to_numpy() - truth[:, 1] * 1e3
    assert 0.05 < np.max(np.abs(err)) < 0.3


def test_patent_method_is_eq17_negated() -> None:
    """The patent method is eq. 17 computed here from the raw columns, sign-flipped."""
    points, _, geom = run(8, 1e-4, np.array([0.0, -1.0, 0.0]), "gap")
    points = points.assign(stry_um=points["stry_um"] + 0.2, pitch_urad=points["pitch_urad"] + 3.0)
    xp0, _, zp0 = geom.mirror_mm
    xq0, _, zq0 = geom.sensor_mm
    ylx = points["sensor_mm"].to_numpy() * 1e3
    dygx = (ylx - ylx[0] - points["stry_um"] + (xp0 - xq0) * 1e3 * np.sin(points["pitch_urad"] * 1e-6)
            + (zq0 - zp0) * 1e3 * np.sin(points["roll_urad"] * 1e-6))
    np.testing.assert_allclose(decouple(points, geom, "patent")["height_um"], -dygx, atol=1e-9)


def test_unknown_method_is_rejected() -> None:
    points, _, geom = run(1, 1e-4, np.array([0.0, -1.0, 0.0]), "height", n=3)
    with pytest.raises(ValueError, match="exact, first-order, patent"):
        decouple(points, geom, "second-order")
