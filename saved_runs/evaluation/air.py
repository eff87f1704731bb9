"""Refractive index of air for the command line (``guideway air-index``):
:mod:`processing.air_index` behind the validity ranges of its equations.

The equation names and the defaults are written out here, so that the command line's choices load
no NumPy (``guideway --help``); tests/saved_runs/test_front_end_choices.py holds them equal to
processing.air_index's."""

from __future__ import annotations

import math
from typing import Any

from ..errors import UserError

EQUATIONS = ("edlen", "ciddor")
DEFAULT_EQUATION = "ciddor"
HENE_WAVELENGTH_NM = 632.991
DEFAULT_CO2_PPM = 450.0

# (flag, lowest, highest) the equations are stated for.
RANGES = (("--t-c", -40.0, 100.0), ("--p-pa", 10e3, 140e3), ("--rh", 0.0, 100.0),
          ("--co2-ppm", 0.0, 2000.0), ("--wavelength-nm", 300.0, 1700.0))


def checked_air_index(t_c: float, p_pa: float, rh_pct: float, *, co2_ppm: float = DEFAULT_CO2_PPM,
                      wavelength_nm: float = HENE_WAVELENGTH_NM, equation: str = DEFAULT_EQUATION) -> dict[str, Any]:
    """The index with its inputs (``{"n", "equation", "t_c", "p_pa", "rh_pct", "co2_ppm", "wavelength_nm"}``).

    An input outside the range of the equations is a one-line :class:`UserError`.
    """
    for (flag, lo, hi), value in zip(RANGES, (t_c, p_pa, rh_pct, co2_ppm, wavelength_nm), strict=True):
        if not (math.isfinite(value) and lo <= value <= hi):
            raise UserError(f"{flag} {value:g} is outside the range of the equations ({lo:g} to {hi:g})")
    from processing.air_index import air_index  # NumPy only when an index is computed

    n = float(air_index(t_c, p_pa, rh_pct, co2_ppm=co2_ppm, wavelength_nm=wavelength_nm, equation=equation))
    return {"n": n, "equation": equation, "t_c": t_c, "p_pa": p_pa, "rh_pct": rh_pct, "co2_ppm": co2_ppm,
            "wavelength_nm": wavelength_nm}


def equation_name(equation: str) -> str:
    """The full name of an air-index equation (``ciddor`` -> "Ciddor 1996 (NIST form)")."""
    from processing.air_index import EQUATION_NAMES

    return EQUATION_NAMES[equation]
