"""GUM per-station uncertainty against a derivation written here, and the Monte
Carlo standard deviation against GUM where the model is linear."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from processing.geometry import BlockGeometry
from processing.straightness import evaluate_straightness
from processing.uncertainty import UncertaintyInputs

GEOM = BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0))
XP, ZP, XQ, ZQ = 50.0, 0.0, 150.0, 40.0
U = UncertaintyInputs(sensor_noise_um=0.05, sensor_resolution_um=0.02, straightness_um=0.1, angle_urad=0.3,
                      position_um=0.5, offset_mm=0.8, step_mm=0.05)


def points(n: int, passes: tuple[int, ...] = (0,)) -> pd.DataFrame:
    rng = np.random.default_rng(1)
    rows = []
    t = 0.0
    for p in passes:
        for k in (range(n) if p == 0 else reversed(range(n))):
            rows.append({"station": k, "x_mm": 100.0 * k, "time_s": t, "lin_um": 0.0,
                         "stry_um": rng.normal(0, 3), "strz_um": 0.0, "pitch_urad": rng.normal(0, 40),
                         "yaw_urad": 0.0, "roll_urad": rng.normal(0, 40), "sensor_mm": 0.2 + rng.normal(0, 2e-3),
                         "pass": p, "air_temp_c": 20.0, "air_pressure_hpa": 1013.0, "humidity_pct": 45.0,
                         "material_temp_c": 20.0})
            t += 10.0
    if passes == (0,):
        rows[0].update(pitch_urad=0.0, roll_urad=0.0, stry_um=0.0)  # a zeroed datum
    return pd.DataFrame(rows)


def test_gum_forward_pass_against_hand_derivation() -> None:
    pts = points(3)
    res = evaluate_straightness(pts, GEOM, method="first-order", uncertainty=U, mc_trials=0)
    # h_k = (stry_k - stry_0) + (s_k - s_0) + (xQ - xP)(ez_k - ez_0) - (zQ - zP)(ex_k - ex_0):
    # two independent captures of every channel, the offsets common to both.
    us2 = U.sensor_noise_um**2 + U.sensor_resolution_um**2 / 12
    ua = U.angle_urad * 1e-3  # um per (mm x urad)
    # the profile by the first-order formula, written out here (not taken from the result)
    d = pts[["stry_um", "pitch_urad", "roll_urad", "sensor_mm"]] - pts.iloc[0][["stry_um", "pitch_urad", "roll_urad",
                                                                                "sensor_mm"]]
    h = (d["stry_um"] + d["sensor_mm"] * 1000.0 + (XQ - XP) * d["pitch_urad"] * 1e-3
         - (ZQ - ZP) * d["roll_urad"] * 1e-3).to_numpy()
    np.testing.assert_allclose(res.profile["height_um"].to_numpy(), h, atol=1e-9)
    x = res.profile["x_mm"].to_numpy()
    # local slope at each station (central difference inside, one-sided at the end): a placement
    # error along X of u_step moves the sample point along that slope
    slope = [(h[1] - h[0]) / 100.0, (h[2] - h[0]) / 200.0, (h[2] - h[1]) / 100.0]
    expected = [0.0]
    for k in (1, 2):
        dez = pts["pitch_urad"][k] - pts["pitch_urad"][0]
        dex = pts["roll_urad"][k] - pts["roll_urad"][0]
        var = (2 * us2 + 2 * U.straightness_um**2 + 2 * ((XQ - XP) * ua) ** 2 + 2 * ((ZQ - ZP) * ua) ** 2
               + 2 * (dez * 1e-3 * U.offset_mm) ** 2 + 2 * (dex * 1e-3 * U.offset_mm) ** 2
               + slope[k] ** 2 * 2 * (U.step_mm * 1e3 * 1e-3) ** 2)
        expected.append(math.sqrt(var))
    assert list(x) == [0.0, 100.0, 200.0]
    np.testing.assert_allclose(res.uncertainty.per_station_u_um, expected, rtol=1e-12)
    d = res.to_dict()["uncertainty_um"]
    assert d["k"] == 2 and d["per_station"] == pytest.approx([2 * e for e in expected])


def test_gum_with_a_return_pass_against_hand_derivation() -> None:
    """Station k is the mean of a forward and a return point, both relative to the
    datum: (a_f + a_r)/2 - a_0 -> noise variance 1/4 + 1/4 + 1 = 1.5 u^2."""
    pts = points(3, passes=(0, 1))
    u = UncertaintyInputs(sensor_noise_um=0.05, sensor_resolution_um=0.0, straightness_um=0.1,
                          angle_urad=0.3, offset_mm=0.8, step_mm=0.0)
    res = evaluate_straightness(pts, GEOM, method="first-order", uncertainty=u, mc_trials=0)
    assert list(res.profile["station"]) == [0, 1, 2]
    ua = u.angle_urad * 1e-3
    noise = u.sensor_noise_um**2 + u.straightness_um**2 + ((XQ - XP) * ua) ** 2 + ((ZQ - ZP) * ua) ** 2
    fwd = pts[pts["pass"] == 0].set_index("station")
    ret = pts[pts["pass"] == 1].set_index("station")
    expected = []
    for k in range(3):
        factor = 0.5 if k == 0 else 1.5  # station 0: (a_r0 - a_0)/2 -> 1/4 + 1/4
        dez = (fwd.pitch_urad[k] + ret.pitch_urad[k]) / 2 - fwd.pitch_urad[0]
        dex = (fwd.roll_urad[k] + ret.roll_urad[k]) / 2 - fwd.roll_urad[0]
        var = factor * noise + 2 * (dez * 1e-3 * u.offset_mm) ** 2 + 2 * (dex * 1e-3 * u.offset_mm) ** 2
        expected.append(math.sqrt(var))
    np.testing.assert_allclose(res.uncertainty.per_station_u_um, expected, rtol=1e-12)


@pytest.mark.parametrize("method", ["first-order", "exact", "patent"])
@pytest.mark.parametrize("passes", [(0,), (0, 1)], ids=["forward", "round-trip"])
def test_monte_carlo_std_matches_gum_for_a_linear_model(method: str, passes: tuple[int, ...]) -> None:
    """first-order is linear in every input except through the slope term (off here:
    a zero placement uncertainty); exact is linear to within angle x u at these angles.
    20 000 trials: the relative standard error of a standard deviation is 1/sqrt(2N) = 0.5 %."""
    pts = points(6, passes)
    u = UncertaintyInputs(step_mm=0.0, position_um=0.0)
    res = evaluate_straightness(pts, GEOM, method=method, uncertainty=u, mc_trials=20_000, mc_seed=3)
    gum = res.uncertainty.per_station_u_um
    mc = res.uncertainty.monte_carlo.per_station_std_um
    mask = gum > 0
    np.testing.assert_allclose(mc[mask], gum[mask], rtol=0.03)
    assert np.all(mc[~mask] < 1e-9)


def test_monte_carlo_is_seeded_and_orders_the_lines() -> None:
    pts = points(8)
    a = evaluate_straightness(pts, GEOM, uncertainty=U, mc_trials=500, mc_seed=7).uncertainty
    b = evaluate_straightness(pts, GEOM, uncertainty=U, mc_trials=500, mc_seed=7).uncertainty
    assert a.to_dict()["straightness"] == b.to_dict()["straightness"]
    mc = a.monte_carlo.straightness_um
    # per trial the minimum zone is never wider than the other two lines
    assert np.all(mc["minimum_zone"] <= mc["least_squares"] + 1e-9)
    assert np.all(mc["minimum_zone"] <= mc["endpoint"] + 1e-9)


def test_inputs_defaults_and_bad_values() -> None:
    assert UncertaintyInputs.from_dict(None) == UncertaintyInputs()
    assert UncertaintyInputs.from_dict({"offset_mm": 1}).offset_mm == 1.0
    assert UncertaintyInputs().sensor_noise_um == 0.05 and UncertaintyInputs().step_mm == 0.05
    with pytest.raises(ValueError, match="non-negative"):
        UncertaintyInputs.from_dict({"angle_urad": -1})
    with pytest.raises(ValueError, match="unknown key"):
        UncertaintyInputs.from_dict({"angle_rad": 1})
