"""The positioning effects' equations of docs/diagnosis.md ('The effect library'), written from the
documentation for the tests that check the simulator and the diagnosis against them (never imported
from mocks/ or processing/)."""

from __future__ import annotations

import numpy as np


def positioning_effect_um(kind: str, q: dict, p_mm, direction, t_min, pitch_urad, yaw_urad, dn):
    """e (µm) of one effect: P in mm, s = ±1, t in minutes since the first point, ε in µrad, n − n₀;
    scalars or arrays of equal length."""
    p_mm = np.asarray(p_mm, dtype=float)
    if kind == "error_table":
        return np.interp(p_mm, q["positions_mm"], q["error_um"])
    if kind == "linear_scale":
        return q["ppm"] * p_mm * 1e-3
    if kind == "quadratic":
        return q["um_per_m2"] * (p_mm / 1000) ** 2
    if kind == "backlash":
        return np.asarray(direction, dtype=float) * q["reversal_um"] / 2
    if kind == "periodic":
        return q["amplitude_um"] * np.sin(2 * np.pi * p_mm / q["wavelength_mm"] + q["phase_rad"])
    if kind == "thermal_drift":
        return q["um_per_min"] * np.asarray(t_min, dtype=float)
    if kind == "thermal_growth":
        return q["ppm_per_min"] * p_mm * np.asarray(t_min, dtype=float) * 1e-3
    if kind == "abbe":
        return q["offset_mm"] * np.asarray(pitch_urad if q["channel"] == "pitch" else yaw_urad, dtype=float) * 1e-3
    if kind == "dead_path":
        return q["length_mm"] * np.asarray(dn, dtype=float) * 1e3
    raise AssertionError(kind)
