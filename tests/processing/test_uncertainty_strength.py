"""Strength tests of processing/uncertainty.py (issue 28): every expected value is computed here
from first principles (hand-derived GUM sensitivities, finite differences through the datum-pitch
estimator, rigid-body kinematics with rotation matrices written out, sample statistics by their
definitions), never taken from the module under test."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from processing.decoupling import Channels, Setup, estimate_datum_pitch
from processing.geometry import BlockGeometry, DatumAngles
from processing.passes import station_groups
from processing.uncertainty import (
    MonteCarloResult,
    UncertaintyInputs,
    datum_pitch_u_urad,
    gum_per_station,
    monte_carlo,
    profile_slope,
)

from .rigid_body import rot  # Rz(ez) Ry(ey) Rx(ex), angles in rad (docs/conventions.md)

ZERO = UncertaintyInputs(sensor_noise_um=0.0, sensor_resolution_um=0.0, straightness_um=0.0, angle_urad=0.0,
                         position_um=0.0, offset_mm=0.0, step_mm=0.0)


def frame(x_mm: list[float], **cols: list[float]) -> pd.DataFrame:
    """A forward pass, one point per station, the channels not given zero."""
    n = len(x_mm)
    d = {"station": np.arange(n), "x_mm": np.asarray(x_mm, dtype=float), "time_s": 10.0 * np.arange(n),
         "pass": np.zeros(n, dtype=int)}
    for c in ("lin_um", "stry_um", "strz_um", "pitch_urad", "yaw_urad", "roll_urad"):
        d[c] = np.asarray(cols.get(c, np.zeros(n)), dtype=float)
    d["sensor_mm"] = np.asarray(cols.get("sensor_mm", np.full(n, 0.2)), dtype=float)
    return pd.DataFrame(d)


# ---------------------------------------------------------------- UncertaintyInputs.from_dict refusals


def test_from_dict_refuses_what_is_not_an_object() -> None:
    for bad in ([1.0], "offset_mm", 3):
        with pytest.raises(ValueError, match=r"^setup\.uncertainty must be an object$"):
            UncertaintyInputs.from_dict(bad)  # type: ignore[arg-type]


def test_from_dict_names_every_unknown_key_and_the_known_ones() -> None:
    with pytest.raises(ValueError) as e:
        UncertaintyInputs.from_dict({"zeta": 1, "alpha_um": 2, "offset_mm": 0.3})
    known = "angle_urad, offset_mm, position_um, sensor_noise_um, sensor_resolution_um, step_mm, straightness_um"
    assert str(e.value) == f"setup.uncertainty: unknown key(s) alpha_um, zeta (known: {known})"


@pytest.mark.parametrize("bad", [-0.001, -1, math.nan, math.inf, -math.inf, True, False, "0.5", None, [0.1]])
def test_from_dict_refuses_a_value_that_is_not_a_non_negative_number(bad: object) -> None:
    with pytest.raises(ValueError, match=r"setup\.uncertainty\.angle_urad must be a non-negative number, got"):
        UncertaintyInputs.from_dict({"angle_urad": bad, "offset_mm": 0.2})


def test_from_dict_accepts_zero_and_values_below_one() -> None:
    u = UncertaintyInputs.from_dict({"angle_urad": 0, "offset_mm": 0.25, "step_mm": 0.0, "position_um": 3})
    assert (u.angle_urad, u.offset_mm, u.step_mm, u.position_um) == (0.0, 0.25, 0.0, 3.0)
    assert isinstance(u.position_um, float)
    assert u.sensor_noise_um == 0.05  # absent keys keep the documented defaults


# ---------------------------------------------------------------- profile_slope


def test_profile_slope_two_points_is_the_chord_and_one_point_is_flat() -> None:
    np.testing.assert_array_equal(profile_slope(np.array([100.0, 300.0]), np.array([1.0, 6.0])), [0.025, 0.025])
    one = profile_slope(np.array([100.0]), np.array([4.0]))
    assert one.shape == (1,) and one[0] == 0.0
    assert profile_slope(np.array([]), np.array([])).shape == (0,)


# ---------------------------------------------------------------- datum_pitch_u_urad


GEOM_P = BlockGeometry((60.0, 110.0, 25.0), (150.0, 0.0, 40.0))
U_P = UncertaintyInputs(straightness_um=0.1, angle_urad=0.3, offset_mm=0.8)


def first_step_channels() -> Channels:
    """Datum at x = 250 mm (not 0), an extra point at index 1, the first step at index 2 (L = 100 mm);
    the angle changes of the first step (300 and 150 urad) differ from those to index 1."""
    return Channels(x_mm=np.array([250.0, 400.0, 350.0]), lin_um=np.zeros(3), stry_um=np.array([0.0, 2.0, 1.5]),
                    strz_um=np.zeros(3), pitch_urad=np.array([40.0, -70.0, 340.0]), yaw_urad=np.zeros(3),
                    roll_urad=np.array([-25.0, 60.0, 125.0]), sensor_mm=np.full(3, 0.2), first_step=2)


def test_datum_pitch_u_by_hand_with_offset_terms() -> None:
    """u = sqrt(2 u_str^2 + (xP^2 + (xP - L)^2 + 2 zP^2) u_ang^2 + (dez^2 + dex^2) u_off^2) / L
    (docs/conventions.md), dez, dex the first step's angle changes in um per mm of lever."""
    xp, zp, L = 60.0, 25.0, 100.0
    dez, dex = (340.0 - 40.0) * 1e-3, (125.0 + 25.0) * 1e-3
    var = (2 * 0.1**2 + (xp**2 + (xp - L) ** 2 + 2 * zp**2) * (0.3e-3) ** 2 + (dez**2 + dex**2) * 0.8**2)
    assert datum_pitch_u_urad(first_step_channels(), GEOM_P, U_P) == pytest.approx(math.sqrt(var) / L * 1e3,
                                                                                    rel=1e-12)


def test_datum_pitch_u_against_finite_differences_of_the_estimator() -> None:
    """GUM by finite differences through processing.decoupling.estimate_datum_pitch: the channels of the
    datum and first-step captures (independent), xP and zP (offset_mm); x and P's y enter only at
    second order."""
    ch = first_step_channels()
    setup = Setup.from_geometry(GEOM_P)

    def est(ch_: Channels, mirror: tuple[float, float, float]) -> float:
        s = Setup(mirror, setup.sensor, setup.beam, setup.sign, setup.datum_urad)
        return float(np.asarray(estimate_datum_pitch(ch_, s, 0.0, 0.0)).ravel()[0]) * 1e6  # urad

    var = 0.0
    for name, u in (("stry_um", 0.1), ("pitch_urad", 0.3), ("roll_urad", 0.3)):
        for k in (0, 2):
            h = 1e-3
            a_plus, a_minus = getattr(ch, name).copy(), getattr(ch, name).copy()
            a_plus[k] += h
            a_minus[k] -= h
            c = (est(replace(ch, **{name: a_plus}), GEOM_P.mirror_mm)
                 - est(replace(ch, **{name: a_minus}), GEOM_P.mirror_mm)) / (2 * h)
            var += (c * u) ** 2
    for axis in (0, 2):
        h = 1e-3
        mp, mm = list(GEOM_P.mirror_mm), list(GEOM_P.mirror_mm)
        mp[axis] += h
        mm[axis] -= h
        c = (est(ch, tuple(mp)) - est(ch, tuple(mm))) / (2 * h)  # type: ignore[arg-type]
        var += (c * 0.8) ** 2
    # first order against the exact estimator at angles of a few hundred urad: within 1 %
    assert datum_pitch_u_urad(ch, GEOM_P, U_P) == pytest.approx(math.sqrt(var), rel=1e-2)


def test_datum_pitch_u_is_none_without_a_step_length() -> None:
    ch = first_step_channels()
    flat = replace(ch, x_mm=np.array([250.0, 400.0, 250.0]))
    assert datum_pitch_u_urad(flat, GEOM_P, U_P) is None
    assert datum_pitch_u_urad(replace(ch, first_step=None), GEOM_P, U_P) is None


# ---------------------------------------------------------------- gum_per_station


def test_gum_exact_method_float32_columns_and_a_mirror_off_the_axis_by_hand() -> None:
    """exact: the x position error is position_um (it measures x), not step_mm; zP != 0 so the roll
    lever is zQ - zP; float32 angle columns are propagated in double precision."""
    geom = BlockGeometry((50.0, 110.0, 15.0), (150.0, 0.0, 40.0))
    u = UncertaintyInputs(sensor_noise_um=0.05, sensor_resolution_um=0.02, straightness_um=0.1, angle_urad=0.3,
                          position_um=2.0, offset_mm=0.8, step_mm=0.05)
    pts = frame([0.0, 100.0, 200.0], pitch_urad=[12.345678, 97.654321, -143.21987],
                roll_urad=[-31.41592, 127.18281, 61.80339])
    pts["pitch_urad"] = pts["pitch_urad"].astype(np.float32)
    pts["roll_urad"] = pts["roll_urad"].astype(np.float32)
    slope = np.array([0.3, -0.2, 0.5])  # um/mm
    got = gum_per_station(pts, geom, "exact", u, station_groups(pts), slope)
    p = pts["pitch_urad"].to_numpy().astype(np.float64)  # the float32 values, exactly
    r = pts["roll_urad"].to_numpy().astype(np.float64)
    us2 = u.sensor_noise_um**2 + u.sensor_resolution_um**2 / 12  # uniform display step: step^2 / 12
    ua = u.angle_urad * 1e-3
    expected = [0.0]
    for k in (1, 2):
        # h_k - h_0: two independent captures of every channel; offsets common; x placement on both
        var = (2 * us2 + 2 * u.straightness_um**2 + 2 * ((150.0 - 50.0) * ua) ** 2 + 2 * ((40.0 - 15.0) * ua) ** 2
               + 2 * ((p[k] - p[0]) * 1e-3 * u.offset_mm) ** 2 + 2 * ((r[k] - r[0]) * 1e-3 * u.offset_mm) ** 2
               + slope[k] ** 2 * 2 * (u.position_um * 1e-3) ** 2)
        expected.append(math.sqrt(var))
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)


# ---------------------------------------------------------------- MonteCarloResult.summary


def test_summary_statistics_by_their_definitions() -> None:
    v = 0.5 + 0.01 * np.random.default_rng(3).permutation(101)  # 0.50, 0.51, ... 1.50 shuffled
    res = MonteCarloResult(101, 9, np.zeros(1), {"endpoint": v})
    s = res.summary()
    assert set(s) == {"endpoint"} and set(s["endpoint"]) == {"mean", "u", "U", "interval_95"}
    # sample variance of 0.01 * (0..100): population (N^2 - 1) / 12 = 850, times N / (N - 1)
    u = 0.01 * math.sqrt(850.0 * 101 / 100)
    assert s["endpoint"]["mean"] == pytest.approx(1.0, rel=1e-12)
    assert s["endpoint"]["u"] == pytest.approx(u, rel=1e-12)
    assert s["endpoint"]["U"] == pytest.approx(2 * u, rel=1e-12)
    # linear interpolation between order statistics: rank p (N - 1) = 2.5 and 97.5
    assert s["endpoint"]["interval_95"] == pytest.approx([0.525, 1.475], rel=1e-12)


# ---------------------------------------------------------------- monte_carlo


def min_zone_brute(x: np.ndarray, h: np.ndarray) -> float:
    """Minimum zone in 2-D: one side of the optimal zone passes through two points, so its slope is one
    of the pairwise slopes."""
    return min(float(np.ptp(h - (h[j] - h[i]) / (x[j] - x[i]) * x)) for i, j in itertools.combinations(range(len(x)),
                                                                                                       2))


def test_zero_uncertainty_trials_are_the_exact_rigid_body_profile_with_the_measured_datum() -> None:
    """All inputs exact: every trial is the measurement itself.  Heights by rigid-body kinematics written
    here: the sample point Q + dl b of the block at pose dR_k R0 (R0 = the measured datum angles),
    dl = -(sensor change); the straightness of each line by its definition, x starting at 300 mm."""
    datum = (150.0, -200.0, 3000.0)  # roll, yaw, pitch (urad), far from what the first step implies
    geom = BlockGeometry((50.0, 110.0, 15.0), (150.0, 0.0, 40.0),
                         datum_angles_urad=DatumAngles(roll_urad=datum[0], yaw_urad=datum[1], pitch_urad=datum[2]))
    x = np.array([300.0, 400.0, 500.0, 600.0, 700.0])
    stry = np.array([0.0, 1.2, -0.4, 2.5, 0.9])
    pitch = np.array([20.0, 180.0, -150.0, 260.0, -40.0])
    yaw = np.array([0.0, 30.0, -10.0, 15.0, 5.0])
    roll = np.array([-10.0, 90.0, 140.0, -120.0, 30.0])
    sensor = np.array([0.2, 0.2031, 0.1975, 0.2052, 0.2008])
    pts = frame(list(x), stry_um=stry, pitch_urad=pitch, yaw_urad=yaw, roll_urad=roll, sensor_mm=sensor)

    def heights(r0: np.ndarray) -> np.ndarray:
        qp = np.subtract(geom.sensor_mm, geom.mirror_mm)
        b = np.array(geom.sensor_beam)
        y = [(rot(roll[k] * 1e-6, yaw[k] * 1e-6, pitch[k] * 1e-6) @ r0 @ (qp - (sensor[k] - sensor[0]) * b))[1]
             + stry[k] * 1e-3 for k in range(len(x))]
        return (np.array(y) - y[0]) * 1e3

    h = heights(rot(*(a * 1e-6 for a in datum)))
    assert np.ptp(h - heights(np.eye(3))) > 0.02  # the datum angles matter at this tolerance (um)
    chord = h[0] + (h[-1] - h[0]) / (x[-1] - x[0]) * (x - x[0])
    b_ls = np.sum((x - x.mean()) * (h - h.mean())) / np.sum((x - x.mean()) ** 2)
    want = {"endpoint": np.ptp(h - chord), "least_squares": np.ptp(h - b_ls * x), "minimum_zone": min_zone_brute(x, h)}
    assert want["endpoint"] > want["minimum_zone"] + 0.1  # the chord is not the minimum zone here
    groups = station_groups(pts)
    res = monte_carlo(pts, geom, "exact", ZERO, groups, x, np.full(len(x), 0.7), trials=3, seed=5)
    assert (res.trials, res.seed) == (3, 5)
    np.testing.assert_array_equal(res.per_station_std_um, np.zeros(len(x)))
    for name, w in want.items():
        np.testing.assert_allclose(res.straightness_um[name], [w] * 3, rtol=1e-9, err_msg=name)


@pytest.mark.parametrize("method", ["first-order", "patent"])
def test_zero_uncertainty_trials_first_order_by_hand(method: str) -> None:
    """first-order / patent with every input exact: h = stry + s + (xQ - xP) ez - (zQ - zP) ex relative
    to the datum (patent: the interferometer channels as recorded, sin of the angles)."""
    geom = BlockGeometry((50.0, 110.0, 15.0), (150.0, 0.0, 40.0))
    x = np.array([300.0, 400.0, 500.0, 600.0])
    stry = np.array([0.5, 1.2, -0.4, 2.5])
    pitch = np.array([20.0, 180.0, -150.0, 260.0])
    roll = np.array([-10.0, 90.0, 140.0, -120.0])
    sensor = np.array([0.2, 0.2031, 0.1975, 0.2052])
    pts = frame(list(x), stry_um=stry, pitch_urad=pitch, roll_urad=roll, sensor_mm=sensor)
    s = (sensor - sensor[0]) * 1e3
    if method == "first-order":
        h = (stry - stry[0]) + s + 100.0 * (pitch - pitch[0]) * 1e-3 - 25.0 * (roll - roll[0]) * 1e-3
    else:
        h = stry + s + 100.0e3 * np.sin(pitch * 1e-6) - 25.0e3 * np.sin(roll * 1e-6)
    chord = h[0] + (h[-1] - h[0]) / (x[-1] - x[0]) * (x - x[0])
    res = monte_carlo(pts, geom, method, ZERO, station_groups(pts), x, np.zeros(4), trials=2, lines=("endpoint",))
    assert list(res.straightness_um) == ["endpoint"]
    np.testing.assert_allclose(res.straightness_um["endpoint"], [np.ptp(h - chord)] * 2, rtol=1e-9)


def test_monte_carlo_defaults_are_the_documented_ten_thousand_trials_seed_zero() -> None:
    pts = frame([0.0, 100.0, 200.0], stry_um=[0.0, 1.0, -1.0])
    groups = station_groups(pts)
    x = pts["x_mm"].to_numpy()
    u = UncertaintyInputs(sensor_noise_um=0.0, sensor_resolution_um=0.0, straightness_um=0.1, angle_urad=0.0,
                          offset_mm=0.0, step_mm=0.0)
    res = monte_carlo(pts, BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0)), "first-order", u, groups, x,
                      np.zeros(3), lines=("endpoint",))
    assert (res.trials, res.seed) == (10_000, 0)
    assert res.straightness_um["endpoint"].shape == (10_000,)
    # only stry is drawn: station 1 of the written-out draw of the seeded stry stream (index 2 of 9)
    g = np.random.default_rng(np.random.SeedSequence(0).spawn(9)[2]).normal(0.0, 0.1, (10_000, 3))
    h1 = (1.0 + g[:, 1]) - g[:, 0]
    assert res.per_station_std_um[1] == pytest.approx(np.std(h1, ddof=1), rel=1e-9)
    assert res.per_station_std_um[1] == pytest.approx(math.sqrt(2) * 0.1, rel=0.03)  # two captures


def test_monte_carlo_needs_two_trials_and_two_suffice() -> None:
    pts = frame([0.0, 100.0, 200.0], stry_um=[0.0, 1.0, -1.0])
    args = (pts, BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0)), "first-order", UncertaintyInputs(),
            station_groups(pts), pts["x_mm"].to_numpy(), np.zeros(3))
    for bad in (1, 0, -5):
        with pytest.raises(ValueError, match=r"^Monte Carlo needs at least 2 trials$"):
            monte_carlo(*args, trials=bad)
    res = monte_carlo(*args, trials=2, seed=1, lines=("endpoint",))
    assert res.trials == 2 and res.straightness_um["endpoint"].shape == (2,)
    h = monte_carlo(*args, trials=2, seed=1, lines=("endpoint",)).per_station_std_um
    assert np.all(np.isfinite(h)) and h[0] == 0.0 and h[1] > 0.0


@pytest.mark.parametrize(("chunk_elements", "calls"), [
    (1, [(1, 5), (2, 5), (3, 5), (4, 5), (5, 5)]),  # below one trial of 3 points: one trial per chunk
    (6, [(2, 5), (4, 5), (5, 5)]),  # 6 // 3 points = 2 trials per chunk
    (10**6, [(5, 5)]),
])
def test_progress_after_each_chunk(chunk_elements: int, calls: list[tuple[int, int]]) -> None:
    pts = frame([0.0, 100.0, 200.0], stry_um=[0.0, 1.0, -1.0])
    seen: list[tuple[int, int]] = []
    monte_carlo(pts, BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0)), "first-order", UncertaintyInputs(),
                station_groups(pts), pts["x_mm"].to_numpy(), np.zeros(3), trials=5, lines=("endpoint",),
                chunk_elements=chunk_elements, progress=lambda done, total: seen.append((done, total)))
    assert seen == calls


def test_progress_of_a_one_point_run() -> None:
    """One point: chunk_elements trials per chunk."""
    pts = frame([0.0])
    seen: list[tuple[int, int]] = []
    res = monte_carlo(pts, BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0)), "first-order",
                      UncertaintyInputs(), station_groups(pts), pts["x_mm"].to_numpy(), np.zeros(1), trials=4,
                      lines=(), chunk_elements=2, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(2, 4), (4, 4)]
    np.testing.assert_array_equal(res.per_station_std_um, [0.0])  # the datum is its own reference


def test_from_dict_refuses_an_integer_beyond_float_range_as_a_value_error() -> None:
    """run.json may hold 1e400 written out as digits: json gives an int that float() cannot hold.
    The caller turns ValueError into a one-line data error; an OverflowError would be a traceback."""
    for big in (10**400, -(10**400)):
        with pytest.raises(ValueError, match=r"^setup\.uncertainty\.offset_mm is too large a number \(401 digits\); "
                                             r"give it in its unit \(um, urad or mm\)$"):
            UncertaintyInputs.from_dict({"offset_mm": big})
    assert UncertaintyInputs.from_dict({"offset_mm": 10**300}).offset_mm == 1e300  # an int within range
