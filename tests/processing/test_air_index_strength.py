"""Strength tests of processing.air_index (issue 28): every constant of the equations has to matter.

The NIST values of test_air_index.py carry 9 digits, too few for constants that move n by 1e-10 (the last
digit of 5792105, the 450 ppm reference of the CO2 factor ...).  So the equations are written out here
once more, in scalar ``math`` from the published forms (standards.md §3.2/§3.3: NIST EMToolbox A-I to A-IV,
IAPWS-IF97 Eq. 30, IAPWS 1993 sublimation curve), checked against the NIST and IAPWS values, and the module
must agree with them to 1e-14 in n over conditions where each term weighs: below and above 0 °C (ice /
water), dry and saturated air, CO2 other than 450 ppm, several wavelengths.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from processing.air_index import (
    air_index,
    ciddor_index,
    edlen_index,
    saturation_vapour_pressure_pa,
    water_mole_fraction,
    water_vapour_pressure_pa,
)

# IAPWS-IF97 Eq. 30 (saturation pressure) with n1..n10 as NIST A-I prints them (12 digits; standards.md §3.3).
IF97_N = (1.16705214528e3, -7.24213167032e5, -1.70738469401e1, 1.20208247025e4, -3.23255503223e6,
          1.49151086135e1, -4.82326573616e3, 4.05113405421e5, -2.38555575678e-1, 6.50175348448e2)


def psat_water_pa(t_c: float) -> float:
    """IAPWS-IF97 Eq. 30: p_s = [2C / (−B + sqrt(B² − 4AC))]⁴ MPa."""
    n = IF97_N
    T = t_c + 273.15
    th = T + n[8] / (T - n[9])
    A = th * th + n[0] * th + n[1]
    B = n[2] * th * th + n[3] * th + n[4]
    C = n[5] * th * th + n[6] * th + n[7]
    return 1e6 * (2 * C / (-B + math.sqrt(B * B - 4 * A * C))) ** 4


def psat_ice_pa(t_c: float) -> float:
    """IAPWS 1993 sublimation pressure (Wagner, Saul & Pruss): ln(p/p_t) = a1 (1 − θ^−1.5) + a2 (1 − θ^−1.25),
    θ = T/T_t, T_t = 273.16 K, p_t = 611.657 Pa, a1 = −13.928169, a2 = 34.7078238."""
    theta = (t_c + 273.15) / 273.16
    return 611.657 * math.exp(-13.928169 * (1 - theta**-1.5) + 34.7078238 * (1 - theta**-1.25))


def psat_pa(t_c: float) -> float:
    """NIST A-I: over water at t >= 0 °C, over ice below."""
    return psat_water_pa(t_c) if t_c >= 0 else psat_ice_pa(t_c)


def x_v_ref(t_c: float, p_pa: float, rh_pct: float) -> float:
    """NIST A-II: x_v = f · h · p_sv / p with f = α + β p + γ t², α = 1.00062, β = 3.14e-8 /Pa, γ = 5.6e-7 /°C²."""
    f = 1.00062 + 3.14e-8 * p_pa + 5.6e-7 * t_c * t_c
    return f * (rh_pct / 100) * psat_pa(t_c) / p_pa


def edlen_ref(t_c: float, p_pa: float, rh_pct: float, co2_ppm: float, lam_nm: float) -> float:
    """Birch & Downs 1993/1994 in the NIST form (A-IV), CO2 by Ciddor's factor about 450 ppm."""
    S = (1000 / lam_nm) ** 2
    ns = 1e-8 * (8342.54 + 2406147 / (130 - S) + 15998 / (38.9 - S)) * (1 + 5.34e-7 * (co2_ppm - 450))
    X = (1 + 1e-8 * (0.601 - 0.00972 * t_c) * p_pa) / (1 + 0.003661 * t_c)
    n_tp = 1 + p_pa * ns * X / 96095.43
    p_v = rh_pct / 100 * psat_pa(t_c)
    return n_tp - 292.75 / (t_c + 273.15) * (3.7345 - 0.0401 * S) * p_v * 1e-10


def ciddor_ref(t_c: float, p_pa: float, rh_pct: float, co2_ppm: float, lam_nm: float) -> float:
    """Ciddor 1996, NIST form (A-III): R = 8.314472, Z_a = 0.9995922115, ρ_vs = 0.00985938 kg/m³."""
    S = (1000 / lam_nm) ** 2
    r_as = 1e-8 * (5792105 / (238.0185 - S) + 167917 / (57.362 - S))
    r_vs = 1.022e-8 * (295.235 + 2.6422 * S - 0.032380 * S**2 + 0.004028 * S**3)
    r_axs = r_as * (1 + 5.34e-7 * (co2_ppm - 450))
    M_a = 0.0289635 + 1.2011e-8 * (co2_ppm - 400)
    M_v, R, T = 0.018015, 8.314472, t_c + 273.15
    x_v = x_v_ref(t_c, p_pa, rh_pct)
    Z = (1 - p_pa / T * (1.58123e-6 - 2.9331e-8 * t_c + 1.1043e-10 * t_c**2 + (5.707e-6 - 2.051e-8 * t_c) * x_v
                         + (1.9898e-4 - 2.376e-6 * t_c) * x_v**2)
         + (p_pa / T) ** 2 * (1.83e-11 - 0.765e-8 * x_v**2))
    rho_axs = 101325 * M_a / (0.9995922115 * R * 288.15)
    rho_a = (1 - x_v) * p_pa * M_a / (Z * R * T)
    rho_v = x_v * p_pa * M_v / (Z * R * T)
    return 1 + rho_a / rho_axs * r_axs + rho_v / 0.00985938 * r_vs


# Conditions: cold (over ice) and warm (over water), dry and saturated, low/high pressure, CO2 0..2000 ppm,
# UV to IR wavelengths.
CONDITIONS = [
    (20.0, 101325.0, 50.0, 450.0, 633.0),
    (-25.0, 95000.0, 100.0, 300.0, 632.991),
    (-5.5, 101325.0, 80.0, 1200.0, 532.0),
    (0.0, 101325.0, 100.0, 450.0, 633.0),
    (0.4, 100000.0, 100.0, 450.0, 633.0),
    (23.7, 87000.0, 0.0, 2000.0, 1550.0),
    (40.0, 120000.0, 100.0, 0.0, 350.0),
    (35.0, 101325.0, 100.0, 400.0, 1064.0),
    (60.0, 110000.0, 70.0, 800.0, 800.0),
]

TOL_N = 1e-14  # ~45 ulp of n: room for another order of operations, far below any constant's last digit


def test_references_reproduce_nist() -> None:
    # The written-out equations are the NIST ones: NIST calculator values (standards.md §3.4) to their digits.
    for t, n in ((-20, 1.00031489), (0, 1.000291647), (20, 1.000271373), (60.45, 1.000235516)):
        assert abs(ciddor_ref(t, 101325, 50, 450, 633.0) - n) <= 5e-9
    assert abs(ciddor_ref(20, 101325, 0, 450, 633.0) - 1.0002718) <= 5e-8  # NIST gives 7 decimals here
    assert abs(ciddor_ref(20, 101325, 100, 450, 633.0) - 1.000270949) <= 1e-9
    for p, n in ((10e3, 1.000026385), (140e3, 1.000375169)):
        assert abs(ciddor_ref(20, p, 50, 450, 633.0) - n) <= 1e-9
    assert abs(ciddor_ref(20, 101325, 50, 450, 321.456) - 1.000283543) <= 1e-9
    assert abs(edlen_ref(20, 101325, 50, 450, 633.0) - 1.000271374) <= 1e-9


def test_saturation_vapour_pressure_iapws_if97_verification_values() -> None:
    # IAPWS-IF97 Table 35 (computer-program verification of Eq. 30): T = 300 K -> 0.353658941e-2 MPa.
    assert float(saturation_vapour_pressure_pa(300 - 273.15)) == pytest.approx(3536.58941, abs=1e-5)
    # 0 °C is over water (611.213 Pa), just below it is over ice (611.15 Pa); the triple point 611.657 Pa.
    assert float(saturation_vapour_pressure_pa(0.0)) == pytest.approx(611.213, abs=1e-3)
    assert float(saturation_vapour_pressure_pa(-1e-9)) == pytest.approx(611.154, abs=1e-3)
    assert float(saturation_vapour_pressure_pa(0.01)) == pytest.approx(611.657, abs=1e-3)


@pytest.mark.parametrize("t_c", [-40.0, -20.0, -5.5, -0.3, 0.0, 0.4, 0.99, 1.0, 15.0, 20.0, 45.0, 99.0])
def test_saturation_vapour_pressure_over_ice_and_water(t_c: float) -> None:
    assert float(saturation_vapour_pressure_pa(t_c)) == pytest.approx(psat_pa(t_c), rel=1e-13)


def test_saturation_vapour_pressure_array_switches_at_zero() -> None:
    t = np.array([-10.0, -0.5, 0.0, 0.5, 10.0])
    got = saturation_vapour_pressure_pa(t)
    assert got.shape == (5,)
    assert got.tolist() == pytest.approx([psat_pa(v) for v in t], rel=1e-13)


@pytest.mark.parametrize(("t_c", "rh"), [(-12.0, 33.0), (0.5, 100.0), (21.3, 33.0), (30.0, 0.0)])
def test_water_vapour_pressure_and_mole_fraction(t_c: float, rh: float) -> None:
    assert float(water_vapour_pressure_pa(t_c, rh)) == pytest.approx(rh / 100 * psat_pa(t_c), rel=1e-13, abs=0)
    for p in (60000.0, 101325.0, 130000.0):
        assert float(water_mole_fraction(t_c, p, rh)) == pytest.approx(x_v_ref(t_c, p, rh), rel=1e-13, abs=0)


@pytest.mark.parametrize("cond", CONDITIONS)
def test_ciddor_against_written_out_equation(cond: tuple[float, ...]) -> None:
    t, p, rh, co2, lam = cond
    assert abs(float(ciddor_index(t, p, rh, co2_ppm=co2, wavelength_nm=lam)) - ciddor_ref(*cond)) <= TOL_N
    assert abs(float(air_index(t, p, rh, co2_ppm=co2, wavelength_nm=lam, equation="ciddor"))
               - ciddor_ref(*cond)) <= TOL_N


@pytest.mark.parametrize("cond", CONDITIONS)
def test_edlen_against_written_out_equation(cond: tuple[float, ...]) -> None:
    t, p, rh, co2, lam = cond
    assert abs(float(edlen_index(t, p, rh, co2_ppm=co2, wavelength_nm=lam)) - edlen_ref(*cond)) <= TOL_N
    assert abs(float(air_index(t, p, rh, co2_ppm=co2, wavelength_nm=lam, equation="edlen"))
               - edlen_ref(*cond)) <= TOL_N


def test_air_index_passes_the_wavelength() -> None:
    # NIST (standards.md §3.4): 500 nm, 20 °C, 101325 Pa, 50 %RH, 450 ppm -> 1.000273781 (not the HeNe value).
    assert abs(float(air_index(20, 101325, 50, wavelength_nm=500)) - 1.000273781) <= 1e-9


@pytest.mark.parametrize("dtype", [np.float32, np.int8, np.int16, np.int32])
def test_narrow_input_dtypes_are_computed_in_double(dtype: type) -> None:
    # Logged values may come as float32 or small integers; the equations must not run in float32
    # (1e-7 relative) nor square an int8 temperature (20² overflows).  The reference takes the same values.
    t = np.array([-12, 20, 27], dtype=dtype) if dtype is not np.float32 else np.array([-12.3, 20.7, 27.1], dtype)
    p = np.array([95000, 101325, 99000], dtype=np.int32 if dtype is np.int8 or dtype is np.int16 else dtype)
    rh = np.array([33, 47, 100], dtype=dtype)
    co2 = np.array([400, 450, 700], dtype=np.int16 if dtype is np.int8 else dtype)
    lam = np.array([633, 532, 1064], dtype=np.int16 if dtype is np.int8 else dtype)
    rows = [tuple(float(a[i]) for a in (t, p, rh, co2, lam)) for i in range(3)]
    assert saturation_vapour_pressure_pa(t).tolist() == pytest.approx([psat_pa(r[0]) for r in rows], rel=1e-13)
    assert water_vapour_pressure_pa(t, rh).tolist() == pytest.approx(
        [r[2] / 100 * psat_pa(r[0]) for r in rows], rel=1e-13)
    assert water_mole_fraction(t, p, rh).tolist() == pytest.approx([x_v_ref(*r[:3]) for r in rows], rel=1e-13)
    cid = ciddor_index(t, p, rh, co2_ppm=co2, wavelength_nm=lam)
    edl = edlen_index(t, p, rh, co2_ppm=co2, wavelength_nm=lam)
    for i, r in enumerate(rows):
        assert abs(float(cid[i]) - ciddor_ref(*r)) <= TOL_N
        assert abs(float(edl[i]) - edlen_ref(*r)) <= TOL_N


def test_ciddor_at_400_ppm_co2() -> None:
    # 400 ppm is the reference of Ciddor's molar mass M_a: the equation must stay finite there.
    got = float(ciddor_index(20, 101325, 50, co2_ppm=400, wavelength_nm=633.0))
    assert abs(got - ciddor_ref(20, 101325, 50, 400, 633.0)) <= TOL_N
    # ∂n/∂CO2 = 0.0143 ppm per 100 ppm at the standard point (standards.md §3.4): 50 ppm less -> -0.00715 ppm.
    assert got - 1.000271373 == pytest.approx(-0.00715e-6, abs=0.002e-6)


def test_unknown_equation_names_the_choices() -> None:
    with pytest.raises(ValueError, match=r"unknown air-index equation 'edlen1966'; choose one of edlen, ciddor"):
        air_index(20, 101325, 50, equation="edlen1966")
