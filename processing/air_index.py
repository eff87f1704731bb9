"""Refractive index of air for laser interferometry.

Two equations, both in the form of the NIST Engineering Metrology Toolbox
documentation (emtoolbox.nist.gov/Wavelength/Documentation.asp, sections A-I
to A-IV), see ``../shared/reference/standards.md`` section 3:

* ``"edlen"``: modified Edlén equation (Birch & Downs 1993, corrected 1994)
  with the NIST temperature factor 292.75/(t + 273.15) on the water term.
* ``"ciddor"``: Ciddor 1996 (the IAG reference equation).

Inputs everywhere: air temperature ``t_c`` (°C), pressure ``p_pa`` (Pa),
relative humidity ``rh_pct`` (%), CO2 content ``co2_ppm`` (µmol/mol) and the
*vacuum* wavelength ``wavelength_nm`` (nm).  Every function accepts floats or
numpy arrays (broadcast together) and returns the index n (dimensionless).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

EQUATIONS = ("edlen", "ciddor")
DEFAULT_EQUATION = "ciddor"
HENE_WAVELENGTH_NM = 632.991
DEFAULT_CO2_PPM = 450.0

EQUATION_NAMES = {
    "edlen": "modified Edlén (Birch & Downs 1993/1994, NIST form)",
    "ciddor": "Ciddor 1996 (NIST form)",
}

# IAPWS-IF97 saturation vapour pressure over water (NIST A-I), t >= 0 °C.
_K = (1.16705214528e3, -7.24213167032e5, -1.70738469401e1, 1.20208247025e4, -3.23255503223e6,
      1.49151086135e1, -4.82326573616e3, 4.05113405421e5, -2.38555575678e-1, 6.50175348448e2)


def saturation_vapour_pressure_pa(t_c: ArrayLike) -> np.ndarray:
    """Saturation vapour pressure (Pa) at ``t_c`` (°C): over water for t >= 0 °C
    (IAPWS-IF97), over ice below (IAPWS 1995 sublimation form), as NIST A-I."""
    t = np.asarray(t_c, dtype=float)
    T = t + 273.15
    K1, K2, K3, K4, K5, K6, K7, K8, K9, K10 = _K
    omega = T + K9 / (T - K10)
    A = omega**2 + K1 * omega + K2
    B = K3 * omega**2 + K4 * omega + K5
    C = K6 * omega**2 + K7 * omega + K8
    X = -B + np.sqrt(B**2 - 4 * A * C)
    over_water = 1e6 * (2 * C / X) ** 4
    theta = T / 273.16
    Y = -13.928169 * (1 - theta**-1.5) + 34.7078238 * (1 - theta**-1.25)
    over_ice = 611.657 * np.exp(Y)
    return np.where(t >= 0, over_water, over_ice)


def water_vapour_pressure_pa(t_c: ArrayLike, rh_pct: ArrayLike) -> np.ndarray:
    """Partial pressure of water vapour (Pa): p_v = RH/100 · p_sv(t)."""
    return np.asarray(rh_pct, dtype=float) / 100.0 * saturation_vapour_pressure_pa(t_c)


def water_mole_fraction(t_c: ArrayLike, p_pa: ArrayLike, rh_pct: ArrayLike) -> np.ndarray:
    """Mole fraction x_v of water vapour: f_e · p_v / p with the enhancement factor
    f_e = 1.00062 + 3.14e-8 p + 5.6e-7 t² (NIST A-II)."""
    t = np.asarray(t_c, dtype=float)
    p = np.asarray(p_pa, dtype=float)
    f_e = 1.00062 + 3.14e-8 * p + 5.6e-7 * t**2
    return f_e * water_vapour_pressure_pa(t, rh_pct) / p


def _wavenumber_sq(wavelength_nm: ArrayLike) -> np.ndarray:
    """S = 1/λ₀² with λ₀ in µm (µm⁻²)."""
    lam_um = np.asarray(wavelength_nm, dtype=float) * 1e-3
    return 1.0 / lam_um**2


def edlen_index(t_c: ArrayLike, p_pa: ArrayLike, rh_pct: ArrayLike, *,
                co2_ppm: ArrayLike = DEFAULT_CO2_PPM,
                wavelength_nm: ArrayLike = HENE_WAVELENGTH_NM) -> np.ndarray:
    """Modified Edlén equation (Birch & Downs 1993/1994, NIST form).

    The equation refers to 450 ppm CO2; another content scales the dry-air
    refractivity by Ciddor's factor 1 + 5.34e-7 (x_CO2 − 450) (exactly the NIST
    form at 450 ppm).
    """
    t = np.asarray(t_c, dtype=float)
    # p only ever meets float64 arrays here, so its own dtype cannot set the precision of the result
    p = np.asarray(p_pa, dtype=float)  # pragma: no mutate (equivalent)
    S = _wavenumber_sq(wavelength_nm)
    ns_1 = 1e-8 * (8342.54 + 2406147 / (130 - S) + 15998 / (38.9 - S))
    ns_1 = ns_1 * (1 + 5.34e-7 * (np.asarray(co2_ppm, dtype=float) - 450.0))
    X = (1 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1 + 0.003661 * t)
    n_tp = 1 + p * ns_1 * X / 96095.43
    p_v = water_vapour_pressure_pa(t, rh_pct)
    return n_tp - 1e-10 * (292.75 / (t + 273.15)) * (3.7345 - 0.0401 * S) * p_v


def ciddor_index(t_c: ArrayLike, p_pa: ArrayLike, rh_pct: ArrayLike, *,
                 co2_ppm: ArrayLike = DEFAULT_CO2_PPM,
                 wavelength_nm: ArrayLike = HENE_WAVELENGTH_NM) -> np.ndarray:
    """Ciddor 1996 equation in the NIST form (R = 8.314472, ρ_vs = 0.00985938 kg/m³)."""
    t = np.asarray(t_c, dtype=float)
    # p only ever meets float64 arrays here (p/T, x_v), so its own dtype cannot set the precision of the result
    p = np.asarray(p_pa, dtype=float)  # pragma: no mutate (equivalent)
    x_co2 = np.asarray(co2_ppm, dtype=float)
    S = _wavenumber_sq(wavelength_nm)
    r_as = 1e-8 * (5792105 / (238.0185 - S) + 167917 / (57.362 - S))
    r_vs = 1.022e-8 * (295.235 + 2.6422 * S - 0.032380 * S**2 + 0.004028 * S**3)
    r_axs = r_as * (1 + 5.34e-7 * (x_co2 - 450.0))
    # M_a is in rho_a and rho_axs alike and cancels in rho_a/rho_axs: kept to read as the NIST form
    M_a = 0.0289635 + 1.2011e-8 * (x_co2 - 400.0)  # pragma: no mutate (equivalent)
    M_v = 0.018015
    R = 8.314472
    T = t + 273.15
    x_v = water_mole_fraction(t, p, rh_pct)
    Z = (1 - (p / T) * (1.58123e-6 - 2.9331e-8 * t + 1.1043e-10 * t**2
                        + (5.707e-6 - 2.051e-8 * t) * x_v + (1.9898e-4 - 2.376e-6 * t) * x_v**2)
         + (p / T) ** 2 * (1.83e-11 - 0.765e-8 * x_v**2))
    rho_axs = 101325 * M_a / (0.9995922115 * R * 288.15)
    rho_vs = 0.00985938
    rho_a = (1 - x_v) * p * M_a / (Z * R * T)
    rho_v = x_v * p * M_v / (Z * R * T)
    return 1 + (rho_a / rho_axs) * r_axs + (rho_v / rho_vs) * r_vs


def air_index(t_c: ArrayLike, p_pa: ArrayLike, rh_pct: ArrayLike, *,
              co2_ppm: ArrayLike = DEFAULT_CO2_PPM,
              wavelength_nm: ArrayLike = HENE_WAVELENGTH_NM,
              equation: str = DEFAULT_EQUATION) -> np.ndarray:
    """Refractive index of air with the chosen ``equation`` (``"edlen"`` or ``"ciddor"``)."""
    if equation == "edlen":
        fn = edlen_index
    elif equation == "ciddor":
        fn = ciddor_index
    else:
        raise ValueError(f"unknown air-index equation {equation!r}; choose one of {', '.join(EQUATIONS)}")
    return fn(t_c, p_pa, rh_pct, co2_ppm=co2_ppm, wavelength_nm=wavelength_nm)
