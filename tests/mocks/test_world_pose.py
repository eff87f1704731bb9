"""The block's resting pose (mocks/world.py ``World.solve_pose``) against the
reference algorithm it replaced: Newton on the same six contact equations with a
central-difference Jacobian, written out here independently of the module's
solver.  Both must land on the same exact rigid-body pose."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mocks.world import BlockSetup, Guideway, Noise, Wave, World


def _rot(ex: float, ey: float, ez: float) -> np.ndarray:
    """R = Rz(ez) Ry(ey) Rx(ex) (docs/conventions.md)."""
    cx, sx, cy, sy, cz, sz = math.cos(ex), math.sin(ex), math.cos(ey), math.sin(ey), math.cos(ez), math.sin(ez)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _contact_residual(g: Guideway, b: BlockSetup, x_rear_mm: float, r: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Three pads on the base surface, two points on the side face, the rear end at x_rear (mm)."""
    half = b.width_mm / 2
    res = []
    for p in ((0.0, 0.0, -half), (0.0, 0.0, half), (b.length_mm, 0.0, 0.0)):
        w = r @ np.array(p) + t
        res.append(w[1] - g.height_mm(w[0], w[2]))
    for p in ((0.0, b.side_contact_height_mm, -half), (b.length_mm, b.side_contact_height_mm, -half)):
        w = r @ np.array(p) + t
        res.append(w[2] - (-half + g.side_mm(w[0])))
    res.append(t[0] - x_rear_mm)
    return np.array(res)


def reference_pose(g: Guideway, b: BlockSetup, x_rear_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) by Newton with a central-difference Jacobian (the original solver)."""

    def residual(u: np.ndarray) -> np.ndarray:
        return _contact_residual(g, b, x_rear_mm, _rot(u[0], u[1], u[2]), u[3:])

    u = np.array([0.0, 0.0, 0.0, x_rear_mm, g.height_mm(x_rear_mm, 0.0), 0.0])
    for _ in range(30):
        f = residual(u)
        if np.max(np.abs(f)) < 1e-13:
            break
        jac = np.empty((6, 6))
        for j in range(6):
            du = np.zeros(6)
            du[j] = 1e-7
            jac[:, j] = (residual(u + du) - residual(u - du)) / 2e-7
        u = u - np.linalg.solve(jac, f)
    else:
        raise AssertionError("reference solver did not converge")
    return _rot(u[0], u[1], u[2]), u[3:]


# A rough guideway (tens of um waves, strong twist, short side-face waves) to exercise the
# non-linear part of the contact problem beyond the default surface.
ROUGH = Guideway(waves=(Wave(40.0, 170.0, 0.4), Wave(12.0, 95.0, 2.0)), slope_urad=-150.0,
                 twist0_urad=80.0, twist_urad_per_m=-300.0, side_waves=(Wave(25.0, 140.0, 1.1),))


@pytest.mark.parametrize("guideway", [None, ROUGH], ids=["default", "rough"])
@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_pose_matches_reference_solver(seed: int, guideway: Guideway | None) -> None:
    world = World(seed=seed, guideway=guideway, noise=Noise.off())
    rng = np.random.default_rng([seed, 11])
    block = world.block
    for k in range(40):
        x = k * block.length_mm + rng.normal(0.0, 0.05)
        pose = world.solve_pose(x)
        r_ref, t_ref = reference_pose(world.guideway, block, x)
        assert np.max(np.abs(pose.t - t_ref)) < 1e-9  # mm
        assert np.max(np.abs(pose.r - r_ref)) < 1e-11  # rad; x 200 mm lever -> 2e-9 mm
        # every block point agrees, and the contacts hold (independent residual)
        for p in (block.mirror_mm, block.sensor_head_mm, (block.length_mm, 0.0, 0.0)):
            assert np.max(np.abs(pose.apply(p) - (r_ref @ np.array(p) + t_ref))) < 1e-6 * 1e-3
        assert np.max(np.abs(_contact_residual(world.guideway, block, x, pose.r, pose.t))) < 1e-12


def test_placed_pose_is_the_solved_pose() -> None:
    world = World(seed=3, noise=Noise.off())
    world.place_block(17)
    r_ref, t_ref = reference_pose(world.guideway, world.block, 17 * world.block.length_mm)
    assert np.max(np.abs(world.pose.t - t_ref)) < 1e-9
    assert np.max(np.abs(world.pose.r - r_ref)) < 1e-11


def _bisect_beam_hit(world: World, r: np.ndarray, t: np.ndarray) -> float:
    """Beam length (mm) from the sensor head to the surface by bisection on the height gap."""
    e = r @ np.array(world.block.sensor_head_mm) + t
    d = r @ np.array(world.block.beam)

    def gap(lam: float) -> float:
        p = e + lam * d
        return p[1] - world.guideway.height_mm(p[0], p[2])

    lo, hi = 0.0, 2 * world.block.sensor_head_mm[1]  # head above the surface, then below it
    assert gap(lo) > 0 > gap(hi)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        lo, hi = (mid, hi) if gap(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("guideway", [None, ROUGH], ids=["default", "rough"])
def test_sensor_reading_is_the_beam_length_to_the_surface(guideway: Guideway | None) -> None:
    world = World(seed=5, guideway=guideway, noise=Noise.off())
    for k in range(30):
        world.place_block(k)
        r_ref, t_ref = reference_pose(world.guideway, world.block, k * world.block.length_mm)
        expected = _bisect_beam_hit(world, r_ref, t_ref)
        for _ in range(3):  # every sample of the placement (the solved hit is reused)
            assert abs(world.sensor_distance_mm() - expected) < 1e-9  # type: ignore[operator]
        assert np.linalg.norm(world.true_sample_point(k) - world.sample_log[-1][1]) < 1e-12
    assert len(world.sample_log) == 90 and [s for s, _ in world.sample_log[-3:]] == [29, 29, 29]


def test_sensor_reading_follows_a_new_placement_at_the_same_station() -> None:
    world = World(seed=8, noise=Noise(0.0, 0.0, 0.0, 0.0, placement_um=5000.0))  # lands elsewhere
    readings = []
    for _ in range(2):
        world.place_block(4)
        pose = world.pose
        readings.append(world.sensor_distance_mm())
        assert abs(readings[-1] - _bisect_beam_hit(world, pose.r, pose.t)) < 1e-9  # type: ignore[operator]
    assert abs(readings[0] - readings[1]) > 1e-6  # a stale beam hit would fail the check above
