"""Environmental compensation: the readings are built with the physical forward
model of standards.md §3.5 (optical path n₁(D + L) − n₀ D counted with the
assumed index; a scale/part at T_m measures L₂₀ (1 + α (T_m − 20))), and the
compensation must return L₂₀; plus the document's worked examples."""

from __future__ import annotations

import numpy as np
import pytest

from processing.air_index import air_index
from processing.environment import EnvironmentSettings, compensate_linear_readings, compensate_points


def test_recovers_length_from_forward_model() -> None:
    rng = np.random.default_rng(5)
    n_pts = 40
    L20 = np.linspace(0, 1500, n_pts)                      # true normalised lengths, mm
    t = 20 + rng.uniform(-1.5, 1.5, n_pts)
    p_hpa = 1013.25 + rng.uniform(-8, 8, n_pts)
    rh = rng.uniform(30, 60, n_pts)
    tm = 20 + rng.uniform(-2, 2, n_pts)
    alpha, D, n_assumed = 11.5, 230.0, 1.00027
    n1 = air_index(t, p_hpa * 100, rh, equation="edlen")
    n0 = n1[0]
    L = L20 * (1 + alpha * 1e-6 * (tm - 20))               # length in space at T_m
    reading = (n1 * (D + L) - n0 * D) / n_assumed          # what the controller shows
    settings = EnvironmentSettings(refractive_index_assumed=n_assumed, expansion_ppm_per_k=alpha,
                                   dead_path_mm=D, index_equation="edlen")
    got, info = compensate_linear_readings(reading, t, p_hpa, rh, tm, settings)
    np.testing.assert_allclose(got, L20, rtol=0, atol=1e-9)  # mm: 1 pm
    assert info.applied and info.equation == "edlen" and len(info.formulas) == 2
    assert info.index_datum == pytest.approx(n0)


def test_vacuum_counts_read_long_by_the_index() -> None:
    # n_assumed = 1: the reading is the optical path; at the standard point n = 1.000271373 (NIST, 633 nm)
    s = EnvironmentSettings(refractive_index_assumed=1.0, wavelength_nm=633.0)
    got, _ = compensate_linear_readings(np.array([0.0, 1000.0]), np.array([20.0, 20.0]),
                                        np.array([1013.25, 1013.25]), np.array([50.0, 50.0]),
                                        np.array([np.nan, np.nan]), s)
    assert (got[1] - 1000.0) * 1000 == pytest.approx(1000 * 1000 * (1 / 1.000271373 - 1), abs=0.002)


def test_material_example_of_standards() -> None:
    # steel 11.5 ppm/K at 21.5 C, 1000 mm: the part is 17.25 um long at 20 C
    s = EnvironmentSettings(readings_compensated=False, refractive_index_assumed=1.0,
                            expansion_ppm_per_k=11.5, wavelength_nm=633.0)
    n = 1.000271373
    got, _ = compensate_linear_readings(np.array([1000.0 * n]), np.array([20.0]), np.array([1013.25]),
                                        np.array([50.0]), np.array([21.5]), s)
    assert (1000.0 - got[0]) * 1000 == pytest.approx(17.25, abs=0.01)


def test_dead_path_example_of_standards() -> None:
    # D = 150 mm, air 1 K warmer than at the datum, axis not moved: the reading is short by 0.143 um.
    s = EnvironmentSettings(refractive_index_assumed=1.000271373, dead_path_mm=150.0, wavelength_nm=633.0)
    n0 = float(air_index(20, 101325, 50, wavelength_nm=633.0))
    n1 = float(air_index(21, 101325, 50, wavelength_nm=633.0))
    reading = 150.0 * (n1 - n0) / 1.000271373   # forward model with L = 0
    assert reading * 1000 == pytest.approx(-0.143, abs=0.002)
    got, _ = compensate_linear_readings(np.array([0.0, reading]), np.array([20.0, 21.0]),
                                        np.array([1013.25, 1013.25]), np.array([50.0, 50.0]),
                                        np.array([np.nan, np.nan]), s)
    assert got == pytest.approx([0.0, 0.0], abs=1e-12)


def test_precompensated_readings_are_untouched() -> None:
    s = EnvironmentSettings.from_dict({"readings_compensated": True})
    r = np.array([0.0, 100.0001])
    got, info = compensate_linear_readings(r, *(np.full(2, np.nan),) * 4, s)
    assert got.tolist() == r.tolist() and not info.applied


def test_points_in_time_order_and_missing_values() -> None:
    pts = pd_points([2.0, 1.0], [20.0, 21.0])
    s = EnvironmentSettings(refractive_index_assumed=1.0, dead_path_mm=100.0)
    got, info = compensate_points(pts, s)
    # the datum is the earlier point (time 1.0, second row, 21 C)
    assert info.index_datum == pytest.approx(float(air_index(21.0, 101325, 50)))
    assert got[1] == pytest.approx(10.0 / info.index_datum)
    pts.loc[0, "humidity_pct"] = np.nan
    with pytest.raises(ValueError, match="data row 1 has no humidity_pct"):
        compensate_points(pts, s)
    with pytest.raises(ValueError, match="refractive_index_assumed is missing"):
        compensate_points(pts, EnvironmentSettings())


def test_settings_validation() -> None:
    with pytest.raises(ValueError, match="index_equation"):
        EnvironmentSettings.from_dict({"index_equation": "edlen1966"})
    with pytest.raises(ValueError, match="refractive_index_assumed"):
        EnvironmentSettings.from_dict({"refractive_index_assumed": 271.3})
    with pytest.raises(ValueError, match="dead_path_mm"):
        EnvironmentSettings.from_dict({"dead_path_mm": "10"})


def pd_points(times, temps):
    import pandas as pd

    return pd.DataFrame({"time_s": times, "reading_mm": [0.0, 10.0], "air_temp_c": temps,
                         "air_pressure_hpa": [1013.25, 1013.25], "humidity_pct": [50.0, 50.0],
                         "material_temp_c": [np.nan, np.nan]})
