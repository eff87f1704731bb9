"""The exact decoupling in the laser's fixed frame (docs/conventions.md, "The laser frame").

A gauge block is stepped by its own length along a curved, twisted guideway
(tests/processing/rigid_body.py: the block stands on its bottom-centre line,
the laser is a little misaligned), so the datum block stands tilted by the local
slope (~80 urad in the laser frame) and the angles change by up to 1 mrad.  The
truth, the residual the old frame assumption leaves and the bound the estimated
datum pitch leaves are all computed here from first principles:

* residual identity (exact): taking the datum orientation as R' instead of R0,
  truth - computed = (dR_k - dR_0) (R0 - R') v_k + dR_0 (R0 - R') dl_k b, with
  v_k = Q - P + dl_k b in the block frame;
* its small-angle form (a = the rotation since the datum, e = the datum angle
  error): e_y = e_y (a_x v_x + a_z v_z) - v_y (a_x e_x + a_z e_z) + dl (e_z b_x - e_x b_z);
* the estimator is the pitch of the chord O1 - O0 between the block origins of
  the first two stations; it misses the datum pitch by at most
  |placement| |s_F - tan(pitch0)| / (L - |placement|) (s_F the surface slope
  where the rear end lands) plus |a_1| |e_xy| |P| / L when roll and yaw are not
  measured.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from mocks.world import Laser, Noise, World
from processing.decoupling import (
    Channels,
    Setup,
    datum_angles_used,
    decouple,
    estimate_datum_pitch,
)
from processing.geometry import BlockGeometry, DatumAngles
from processing.straightness import evaluate_straightness
from processing.uncertainty import UncertaintyInputs, datum_pitch_u_urad

from . import rigid_body

P = np.array([50.0, 110.0, 5.0])  # mirror point, block frame (mm)
E = np.array([150.0, 30.0, 40.0])  # sensor head, block frame (mm)
DOWN = np.array([0.0, -1.0, 0.0])
TILTED = np.array([0.25, -1.0, -0.15]) / np.linalg.norm([0.25, -1.0, -0.15])
L = 100.0  # block length = step (mm)
N = 12
LASER = rigid_body.rot(-5e-6, 10e-6, 20e-6)  # the laser's axes in the world: a real, imperfect alignment


def twist(x: float) -> float:
    """Transverse slope dy/dz of the guideway (rad): 15 urad at the datum, ~1 mrad at the far end."""
    return 15e-6 + 0.9e-6 * x


def curved(x: float, z: float) -> float:
    """A bowed, wavy, twisted guideway (y in mm): slope ~100 urad under the datum block, rising by ~1 mrad."""
    return 40e-6 * x + 0.45e-6 * x * x + 2e-3 * math.sin(2 * math.pi * x / 350.0 + 0.3) + twist(x) * z


def recording(beam: np.ndarray = DOWN, sign: str = "height", seed: int = 1,
              placement_mm: float = 0.02) -> tuple[rigid_body.Recording, list]:
    rng = np.random.default_rng(seed)
    roll = [twist(k * L) for k in range(N)]
    yaw = [-10e-6 + 0.6e-3 * math.sin(2 * math.pi * k / 9) for k in range(N)]
    placement = [0.0, *rng.normal(0.0, placement_mm, N - 1)]
    poses = rigid_body.resting_poses(curved, L, roll, yaw, placement)
    return rigid_body.simulate(poses, P, E, beam, sign, L, laser=LASER, surf=curved), poses


def geometry(rec: rigid_body.Recording, beam: np.ndarray, sign: str = "height", **angles: float) -> BlockGeometry:
    return BlockGeometry(tuple(P), tuple(rec.q), tuple(beam), sign,  # type: ignore[arg-type]
                         DatumAngles(**{f"{k}_urad": v for k, v in angles.items()}))


def residual_um(rec: rigid_body.Recording, r_used: np.ndarray, beam: np.ndarray) -> np.ndarray:
    """truth - computed height (um) when the datum orientation is taken as r_used (exact identity)."""
    dr0, dr = rec.rotations[0], rec.datum_r - r_used
    out = []
    for rk, dl in zip(rec.rotations, rec.beam_change_mm, strict=True):
        v = rec.q - P + dl * beam
        out.append(((rk - dr0) @ dr @ v + dr0 @ dr @ (dl * beam))[1] * 1e3)
    return np.array(out)


def rotation_vectors(rec: rigid_body.Recording) -> np.ndarray:
    """a_k: (roll, yaw, pitch) of each point's rotation since the datum (rad)."""
    return np.array([rigid_body.euler_zyx(r) for r in rec.rotations])


def small_angle_bound_um(rec: rigid_body.Recording, beam: np.ndarray, e_abs: np.ndarray) -> np.ndarray:
    """The bound of docs/conventions.md: |e_y| <= |e_y| (|a_x||v_x| + |a_z||v_z|)
    + |v_y| (|a_x||e_x| + |a_z||e_z|) + |dl| (|e_z||b_x| + |e_x||b_z|), per point (um)."""
    a = np.abs(rotation_vectors(rec))
    v = np.abs(rec.q - P)
    ex, ey, ez = e_abs
    dl = np.abs(rec.beam_change_mm)
    bound = (ey * (a[:, 0] * v[0] + a[:, 2] * v[2]) + v[1] * (a[:, 0] * ex + a[:, 2] * ez)
             + dl * (ez * abs(beam[0]) + ex * abs(beam[2])))
    return bound * 1e3


def chord_pitch_urad(poses: list) -> float:
    """Pitch of O1 - O0 (the block origins of the first two stations) in the laser frame."""
    c = LASER.T @ (np.array(poses[1][3:]) - np.array(poses[0][3:]))
    return math.atan2(c[1], c[0]) * 1e6


def premise_bound_urad(poses: list) -> float:
    """How far the chord's pitch can be from the datum block's: the rear end lands |placement|
    past the datum block's front end, on a surface of slope s_F there."""
    ex, ey, ez, *o0 = poses[0]
    front = np.array(o0) + rigid_body.rot(ex, ey, ez) @ np.array([L, 0.0, 0.0])
    placement = poses[1][3] - front[0]
    s_f = (curved(front[0] + placement, front[2]) - curved(front[0], front[2])) / placement
    return abs(placement) * abs(s_f - math.tan(ez)) / (L - abs(placement)) * 1e6 * 1.01 + 1e-4


def test_the_test_run_is_what_the_brief_describes() -> None:
    rec, poses = recording()
    assert 10.0 < rec.datum_urad["pitch"] < 100.0  # the datum block tilted by the local slope
    a = rotation_vectors(rec)
    assert 0.9e-3 < np.max(np.abs(a[:, 2])) < 1.2e-3  # pitch changes reach 1 mrad
    assert np.max(np.abs(a[:, 0])) > 0.9e-3 and np.max(np.abs(a[:, 1])) > 0.5e-3
    # the model's premise: station 1's rear end stands (nearly) where the datum block's front end stood
    assert abs(chord_pitch_urad(poses) - rec.datum_urad["pitch"]) < 0.1


@pytest.mark.parametrize("sign", ["height", "gap"])
@pytest.mark.parametrize("beam", [DOWN, TILTED], ids=["down", "tilted"])
def test_measured_datum_angles_recover_the_surface_exactly(beam: np.ndarray, sign: str) -> None:
    rec, _ = recording(beam, sign)
    prof = decouple(pd.DataFrame(rec.rows), geometry(rec, beam, sign, **rec.datum_urad), "exact")
    np.testing.assert_allclose(prof["height_um"], rec.truth[:, 1] * 1e3, rtol=0, atol=1e-6)
    np.testing.assert_allclose(prof["x_mm"], rec.truth[:, 0], rtol=0, atol=1e-9)


@pytest.mark.parametrize("beam", [DOWN, TILTED], ids=["down", "tilted"])
def test_the_old_frame_assumption_leaves_the_second_order_residual(beam: np.ndarray) -> None:
    """Datum angles 0 = the block frame taken for the laser frame (the method before the laser frame)."""
    rec, _ = recording(beam)
    old = decouple(pd.DataFrame(rec.rows), geometry(rec, beam, roll=0.0, yaw=0.0, pitch=0.0), "exact")
    err = old["height_um"].to_numpy() - rec.truth[:, 1] * 1e3
    expected = -residual_um(rec, np.eye(3), beam)
    np.testing.assert_allclose(err, expected, rtol=0, atol=1e-6)
    # the small-angle form, term by term, with e = the datum angles
    a = rotation_vectors(rec)
    v = rec.q - P
    e = np.array([rec.datum_urad[k] for k in ("roll", "yaw", "pitch")]) * 1e-6
    dl = rec.beam_change_mm
    approx = (e[1] * (a[:, 0] * v[0] + a[:, 2] * v[2]) - v[1] * (a[:, 0] * e[0] + a[:, 2] * e[2])
              + dl * (e[2] * beam[0] - e[0] * beam[2])) * 1e3
    np.testing.assert_allclose(-expected, approx, rtol=0.03, atol=2e-5)
    # the (yP - yQ) e0 de: the pitch-pitch term, ~0.01 um at 1 mrad and 80 urad
    pitch_term = (P[1] - rec.q[1]) * a[:, 2] * e[2] * 1e3
    assert np.max(np.abs(pitch_term)) > 0.008
    assert np.max(np.abs(err)) > 0.005


@pytest.mark.parametrize("beam", [DOWN, TILTED], ids=["down", "tilted"])
def test_estimated_pitch_with_measured_roll_and_yaw_leaves_a_negligible_residual(beam: np.ndarray) -> None:
    rec, poses = recording(beam)
    geom = geometry(rec, beam, roll=rec.datum_urad["roll"], yaw=rec.datum_urad["yaw"])
    points = pd.DataFrame(rec.rows)
    used = datum_angles_used(points, geom)
    assert used.source == {"roll": "measured", "yaw": "measured", "pitch": "estimated"}
    # the estimator is the chord's pitch, and the chord misses the datum pitch by the placement
    assert abs(used.pitch_urad - chord_pitch_urad(poses)) < 1e-4
    e_z = abs(used.pitch_urad - rec.datum_urad["pitch"])
    assert e_z <= premise_bound_urad(poses)
    err = decouple(points, geom, "exact")["height_um"].to_numpy() - rec.truth[:, 1] * 1e3
    bound = small_angle_bound_um(rec, beam, np.array([0.0, 0.0, premise_bound_urad(poses) * 1e-6]))
    assert np.all(np.abs(err) <= bound * 1.02 + 2e-6)
    old = residual_um(rec, np.eye(3), beam)
    assert np.max(np.abs(err)) < 1e-3 * np.max(np.abs(old))


@pytest.mark.parametrize("beam", [DOWN, TILTED], ids=["down", "tilted"])
def test_estimated_pitch_alone_leaves_the_stated_bound(beam: np.ndarray) -> None:
    """The default: nothing measured.  Roll and yaw of the datum are not observable (taken
    as 0); what is left is the bound with e_x, e_y = the datum's roll and yaw."""
    rec, poses = recording(beam)
    points = pd.DataFrame(rec.rows)
    geom = geometry(rec, beam)
    used = datum_angles_used(points, geom)
    assert used.source == {"roll": "assumed", "yaw": "assumed", "pitch": "estimated"}
    assert used.roll_urad == used.yaw_urad == 0.0
    e_x, e_y = abs(rec.datum_urad["roll"]) * 1e-6, abs(rec.datum_urad["yaw"]) * 1e-6
    a1 = np.linalg.norm(rotation_vectors(rec)[1] - rotation_vectors(rec)[0])
    lever_urad = a1 * math.hypot(e_x, e_y) * np.linalg.norm(P) / L * 1e6 * 1.01
    e_z_bound = premise_bound_urad(poses) + lever_urad
    assert abs(used.pitch_urad - rec.datum_urad["pitch"]) <= e_z_bound
    err = decouple(points, geom, "exact")["height_um"].to_numpy() - rec.truth[:, 1] * 1e3
    bound = small_angle_bound_um(rec, beam, np.array([e_x, e_y, e_z_bound * 1e-6]))
    assert np.all(np.abs(err) <= bound * 1.02 + 2e-6)
    assert np.max(bound) < 0.01  # roll and yaw of ~20 urad at 1 mrad: below 0.01 um here
    # and the pitch term of the old assumption is gone: what is left is the roll/yaw part of the old residual
    old = residual_um(rec, np.eye(3), beam)
    roll_yaw_only = residual_um(rec, rigid_body.rot(0.0, 0.0, rec.datum_urad["pitch"] * 1e-6), beam)
    np.testing.assert_allclose(-err, roll_yaw_only, rtol=0, atol=2e-5)
    assert np.max(np.abs(err)) < 0.6 * np.max(np.abs(old))


@pytest.mark.parametrize("xp", [50.0, 20.0])
def test_datum_pitch_estimate_scatters_as_its_stated_uncertainty(xp: float) -> None:
    """Noise on stry and the angles of the datum and first-step captures: to first order L times the
    estimate is (stry1 - stry0) - (ez1 - ez0) xP + (ex1 - ex0) zP - ez0 L (the chord turned back by
    the datum capture's own pitch reading), so its standard deviation is
    sqrt(2 u_str^2 + (xP^2 + (xP - L)^2 + 2 zP^2) u_ang^2) / L (derived here; at xP = L / 2 the two
    pitch levers are equal, so a second mirror position tells them apart)."""
    mirror = np.array([xp, P[1], P[2]])
    _, poses = recording()
    rec = rigid_body.simulate(poses, mirror, E, DOWN, "height", L, laser=LASER, surf=curved)
    points = pd.DataFrame(rec.rows)
    u = UncertaintyInputs(straightness_um=0.1, angle_urad=2.0, offset_mm=0.0)
    lever = mirror[0] ** 2 + (mirror[0] - L) ** 2 + 2 * mirror[2] ** 2
    expected = math.sqrt(2 * 0.1**2 + lever * (2.0e-3) ** 2) / L * 1e3
    ch = Channels.from_points(points)
    geom = BlockGeometry(tuple(mirror), tuple(rec.q), tuple(DOWN), "height")  # type: ignore[arg-type]
    assert datum_pitch_u_urad(ch, geom, u) == pytest.approx(expected, rel=1e-12)
    rng = np.random.default_rng(5)
    m = 20_000
    shape = (m, len(points))
    noisy = Channels(x_mm=ch.x_mm, lin_um=ch.lin_um, stry_um=ch.stry_um + rng.normal(0, 0.1, shape),
                     strz_um=ch.strz_um + rng.normal(0, 0.1, shape),
                     pitch_urad=ch.pitch_urad + rng.normal(0, 2.0, shape),
                     yaw_urad=ch.yaw_urad + rng.normal(0, 2.0, shape),
                     roll_urad=ch.roll_urad + rng.normal(0, 2.0, shape), sensor_mm=ch.sensor_mm,
                     first_step=ch.first_step)
    est = np.asarray(estimate_datum_pitch(noisy, Setup.from_geometry(geom), 0.0, 0.0)) * 1e6
    assert est.shape == (m, 1)
    assert np.std(est) == pytest.approx(expected, rel=0.03)  # 1/sqrt(2m) = 0.5 % standard error
    assert abs(np.mean(est) - chord_pitch_urad(poses)) < 5 * expected / math.sqrt(m) + 0.01


def test_without_a_first_step_the_pitch_is_assumed_zero_and_said_so() -> None:
    rec, _ = recording()
    points = pd.DataFrame(rec.rows).query("station != 1").reset_index(drop=True)
    res = evaluate_straightness(points, geometry(rec, DOWN), uncertainty=UncertaintyInputs(), mc_trials=0)
    d = res.to_dict()["datum_angles_urad"]
    assert d == {"roll": 0.0, "yaw": 0.0, "pitch": 0.0,
                 "source": {"roll": "assumed", "yaw": "assumed", "pitch": "assumed"}}


def test_result_json_names_the_datum_angles_and_their_sources() -> None:
    rec, _ = recording()
    points = pd.DataFrame(rec.rows)
    u = UncertaintyInputs()
    res = evaluate_straightness(points, geometry(rec, DOWN, roll=12.5), uncertainty=u, mc_trials=0)
    d = res.to_dict()["datum_angles_urad"]
    assert d["roll"] == 12.5 and d["yaw"] == 0.0
    assert d["source"] == {"roll": "measured", "yaw": "assumed", "pitch": "estimated"}
    assert abs(d["pitch"] - rec.datum_urad["pitch"]) < 0.1
    assert d["pitch_u_urad"] == datum_pitch_u_urad(Channels.from_points(points), geometry(rec, DOWN), u)
    given = evaluate_straightness(points, geometry(rec, DOWN, pitch=55.0), mc_trials=0).to_dict()
    assert given["datum_angles_urad"]["pitch"] == 55.0 and "pitch_u_urad" not in given["datum_angles_urad"]
    for method in ("first-order", "patent"):  # they do not use the datum angles
        assert "datum_angles_urad" not in evaluate_straightness(points, geometry(rec, DOWN), method=method,
                                                                mc_trials=0).to_dict()


def test_a_return_pass_does_not_change_the_first_step() -> None:
    rec, _ = recording()
    fwd = pd.DataFrame(rec.rows).assign(**{"pass": 0})
    back = fwd.iloc[::-1].assign(**{"pass": 1})
    both = pd.concat([fwd, back], ignore_index=True)
    geom = geometry(rec, DOWN)
    assert datum_angles_used(both, geom) == datum_angles_used(fwd, geom)


@pytest.mark.parametrize("seed", [2, 7])
def test_simulated_world_reports_in_the_laser_frame(seed: int) -> None:
    """mocks/world.py: channels in a misaligned laser's frame; the exact method recovers its
    surface exactly with the world's datum angles, and with the estimated pitch to < 1e-4 um."""
    world = World(seed=seed, noise=Noise.off(), laser=Laser(roll_urad=8.0, yaw_urad=-30.0, pitch_urad=45.0))
    lr = rigid_body.rot(8e-6, -30e-6, 45e-6)  # the laser's axes in the world, written out here
    b = world.block
    rows, hits, lams = [], [], []
    for k in range(15):
        world.place_block(k)
        if k == 0:
            world.set_datum()
        c = world.capture()
        lams.append(world.sensor_distance_mm())
        rows.append({"station": k, "x_mm": k * b.length_mm, "lin_um": (c.position_mm - k * b.length_mm) * 1e3,
                     "stry_um": c.stry_um, "strz_um": c.strz_um, "pitch_urad": c.pitch_urad,
                     "yaw_urad": c.yaw_urad, "roll_urad": c.roll_urad, "sensor_mm": b.standoff_mm - lams[-1]})
        hits.append(world.true_sample_point(k))
    points = pd.DataFrame(rows)
    # the channels against the poses, in the laser's axes (independent of the world's capture code)
    r0, r3 = world.solve_pose(0.0), world.solve_pose(3 * b.length_mm)
    d3 = lr.T @ (r3.apply(b.mirror_mm) - r0.apply(b.mirror_mm))
    assert abs(points["stry_um"].iloc[3] - d3[1] * 1e3) < 1e-9
    assert abs(points["lin_um"].iloc[3] - (d3[0] - 3 * b.length_mm) * 1e3) < 1e-9
    ex, ey, ez = rigid_body.euler_zyx(lr.T @ r3.r @ r0.r.T @ lr)
    assert abs(points["pitch_urad"].iloc[3] - ez * 1e6) < 1e-9 and abs(points["roll_urad"].iloc[3] - ex * 1e6) < 1e-9
    datum = world.datum_angles_urad()
    assert np.allclose([datum[k] for k in ("roll", "yaw", "pitch")],
                       np.array(rigid_body.euler_zyx(lr.T @ r0.r)) * 1e6, atol=1e-9)
    assert 1.0 < abs(datum["pitch"]) < 150.0
    truth = np.array([lr.T @ (h - hits[0]) for h in hits])
    q = tuple(np.array(b.sensor_head_mm) + lams[0] * np.array(b.beam))  # the first sample point
    given = BlockGeometry(b.mirror_mm, q, b.beam, "height",  # type: ignore[arg-type]
                          DatumAngles(**{f"{k}_urad": v for k, v in datum.items()}))
    prof = decouple(points, given, "exact")
    np.testing.assert_allclose(prof["height_um"], truth[:, 1] * 1e3, rtol=0, atol=1e-6)
    np.testing.assert_allclose(prof["x_mm"], truth[:, 0], rtol=0, atol=1e-9)
    pitch_only = BlockGeometry(b.mirror_mm, q, b.beam, "height",  # type: ignore[arg-type]
                               DatumAngles(roll_urad=datum["roll"], yaw_urad=datum["yaw"]))
    assert abs(datum_angles_used(points, pitch_only).pitch_urad - datum["pitch"]) < 1e-3
    est = decouple(points, pitch_only, "exact")
    np.testing.assert_allclose(est["height_um"], truth[:, 1] * 1e3, rtol=0, atol=1e-4)


def test_datum_pitch_estimate_when_the_first_readings_are_not_zero() -> None:
    """A run that starts at x = 500 mm, with the interferometer zeroed at a pose a little off
    the datum capture's (its channels at the datum read 0.3 mm, -0.2 mm, 0.1 mm, 30, -20,
    45 urad): the datum angles are the zeroing pose's (rigid_body.simulate's datum_r), and the
    estimate still finds its pitch within the premise bound (it missed it by the 45 urad
    before it took the datum capture's own rotation out of the chord)."""
    rec0, poses = recording()
    ex, ey, ez, tx, ty, tz = poses[0]
    zero = (ex + 30e-6, ey - 20e-6, ez + 45e-6, tx + 0.3, ty - 0.2, tz + 0.1)
    rec = rigid_body.simulate(poses, P, E, DOWN, "height", L, laser=LASER, zero=zero, surf=curved)
    points = pd.DataFrame(rec.rows).assign(x_mm=lambda d: d["x_mm"] + 500.0)
    first = points.iloc[0]
    assert abs(first["pitch_urad"] + 45.0) < 1.0 and abs(first["stry_um"]) > 100.0  # not zero
    assert abs(rec.datum_urad["pitch"] - rec0.datum_urad["pitch"] - 45.0) < 1.0  # the zeroing pose's pitch
    geom = geometry(rec, DOWN, roll=rec.datum_urad["roll"], yaw=rec.datum_urad["yaw"])
    used = datum_angles_used(points, geom)
    assert used.source["pitch"] == "estimated"
    assert abs(used.pitch_urad - rec.datum_urad["pitch"]) <= premise_bound_urad(poses)
    err = decouple(points, geom, "exact")["height_um"].to_numpy() - rec.truth[:, 1] * 1e3
    bound = small_angle_bound_um(rec, DOWN, np.array([0.0, 0.0, premise_bound_urad(poses) * 1e-6]))
    assert np.all(np.abs(err) <= bound * 1.02 + 2e-6)
