"""The ISO 230-2 uncertainty budget (processing.positioning_budget) against the formulas written out here."""

from __future__ import annotations

import math

import pytest

from processing.positioning_budget import BudgetSettings, index_sensitivities, positioning_budget

LAMBDA_UM = 0.632991
S = 1 / LAMBDA_UM**2


def _bd_edlen(t: float, p: float, p_v: float) -> float:
    """Modified Edlén (Birch & Downs 1994, NIST form), standards.md §3.2, water vapour pressure p_v (Pa)."""
    ns_1 = 1e-8 * (8342.54 + 2406147 / (130 - S) + 15998 / (38.9 - S))
    x = (1 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1 + 0.003661 * t)
    return 1 + p * ns_1 * x / 96095.43 - 1e-10 * (292.75 / (t + 273.15)) * (3.7345 - 0.0401 * S) * p_v


def test_edlen_sensitivities_match_a_finite_difference_of_the_formula_written_here() -> None:
    # dry air (RH 0: no water term), 20 °C, 101325 Pa
    h = 0.001
    dn_dt = (_bd_edlen(20 + h, 101325, 0) - _bd_edlen(20 - h, 101325, 0)) / (2 * h) * 1e6
    dn_dp_hpa = (_bd_edlen(20, 101325 + 10, 0) - _bd_edlen(20, 101325 - 10, 0)) / 20 * 1e6 * 100
    got = index_sensitivities(20.0, 101325.0, 0.0, equation="edlen")
    assert got["t_ppm_per_k"] == pytest.approx(dn_dt, rel=1e-4)
    assert got["p_ppm_per_hpa"] == pytest.approx(dn_dp_hpa, rel=1e-4)
    assert -0.97 < dn_dt < -0.90 and 0.26 < dn_dp_hpa < 0.28  # the textbook figures (standards.md §3.4)
    # humidity: n is linear in p_v = RH/100 · p_sv(20 °C) = RH/100 · 2339.21 Pa (standards.md §3.3)
    dn_drh = -1e-10 * (292.75 / 293.15) * (3.7345 - 0.0401 * S) * 2339.21 / 100 * 1e6
    assert index_sensitivities(20.0, 101325.0, 50.0, equation="edlen")["rh_ppm_per_pct"] == \
        pytest.approx(dn_drh, rel=2e-3)


def test_ciddor_sensitivities_are_the_nist_figures() -> None:
    got = index_sensitivities(20.0, 101325.0, 50.0, equation="ciddor")
    # standards.md §3.4: −0.952 ppm/K, +0.268 ppm per 100 Pa, −0.0085 ppm/%RH; the NIST vectors n(0, 20, 26.7982 °C)
    # = 1.000291647, 1.000271373, 1.000264994 give slopes −1.0137 (at 10 °C) and −0.9383 ppm/K (at 23.4 °C),
    # interpolated to 20 °C: −0.957 ppm/K; so the temperature figure is held to ±0.005
    assert got["t_ppm_per_k"] == pytest.approx(-0.955, abs=0.005)
    assert got["p_ppm_per_hpa"] == pytest.approx(0.268, abs=0.002)
    assert got["rh_ppm_per_pct"] == pytest.approx(-0.0085, abs=0.0003)


def test_linear_budget_of_a_span_value_and_of_a_local_value() -> None:
    settings = BudgetSettings(laser_ppm=0.5, air_temp_k=0.2, air_pressure_hpa=1.0, humidity_pct=5.0,
                              material_temp_k=0.1, expansion_ppm_per_k=1.0, misalignment_mrad=1.0, drift=0.6)
    b = positioning_budget(axis_type="linear", unit="um", span_mm=1000.0, settings=settings, k=2.0,
                           repeatability={"E": 0.3, "B": 0.2}, air=(20.0, 101325.0, 50.0), material_temp_c=21.5,
                           expansion_ppm_per_k=11.5, equation="ciddor", quantities=("E", "B"))
    e = b["E"].contributions
    assert e["material temperature"] == pytest.approx(1000 * 11.5e-6 * 0.1 * 1e3)  # 1.15 µm
    assert e["material temperature"] == pytest.approx(1.15)
    assert e["expansion coefficient"] == pytest.approx(1000 * 1.5 * 1e-6 * 1e3)  # L ΔT u(α) = 1.5 µm
    assert e["laser calibration"] == pytest.approx(0.5)  # 0.5 ppm of 1 m
    assert e["air index (air temperature)"] == pytest.approx(0.952 * 0.2, rel=0.01)
    assert e["air index (pressure)"] == pytest.approx(0.268 * 1.0, rel=0.01)
    assert e["air index (humidity)"] == pytest.approx(0.0085 * 5, rel=0.04)
    assert e["misalignment (cosine)"] == pytest.approx(1e6 * (1e-3) ** 2 / 2 / math.sqrt(12))  # µm
    assert e["environmental variation E_VE"] == pytest.approx(0.6 / (2 * math.sqrt(3)))
    assert e["repeatability of the value"] == 0.3
    u_c = math.sqrt(sum(v * v for v in e.values()))
    assert b["E"].u_c == pytest.approx(u_c) and b["E"].U == pytest.approx(2 * u_c) and b["E"].length_mm == 1000
    # B: the scale contributions are common to both directions and cancel
    assert set(b["B"].contributions) == {"environmental variation E_VE", "repeatability of the value"}
    assert b["B"].U == pytest.approx(2 * math.hypot(0.6 / (2 * math.sqrt(3)), 0.2))
    assert b["B"].length_mm is None


def test_rotary_budget_has_only_repeatability_and_unknown_repeatability_gives_no_u() -> None:
    b = positioning_budget(axis_type="rotary", unit="arcsec", span_mm=360.0, repeatability={"A": 1.0, "R": None},
                           k=3.0, quantities=("A", "R"))
    assert b["A"].contributions == {"repeatability of the value": 1.0} and b["A"].U == pytest.approx(3.0)
    assert any("E_VE: not included" in n for n in b["A"].notes)
    assert b["R"].U is None and b["R"].u_c is None


def test_budget_settings_refuse_an_unknown_key_or_a_negative_figure() -> None:
    with pytest.raises(ValueError, match="unknown key 'laser'"):
        BudgetSettings.from_dict({"laser": 1.0})
    with pytest.raises(ValueError, match="air_temp_k must be a number >= 0"):
        BudgetSettings.from_dict({"air_temp_k": -1})
    assert BudgetSettings.from_dict({"drift": 1}).drift == 1.0
