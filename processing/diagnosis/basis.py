"""The contribution of each effect type to an observed channel (the equations of
:mod:`processing.effects`), as a value and as least-squares columns.

An effect contributes either fully fixed (no free parameter: its value is subtracted from
the observations) or through columns whose coefficients are its free parameters.  The one
nonlinear parameter is a periodic effect's free wavelength: given the wavelength, sine and
cosine columns carry amplitude and phase (A sin(θ + φ) = A cos φ · sin θ + A sin φ · cos θ).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..effects import Effect
from .observations import Observations

# Linear one-parameter effects: (parameter, the column: contribution per unit of the parameter, µm).
LINEAR: dict[str, tuple[str, Callable[[Observations], np.ndarray]]] = {
    "linear_scale": ("ppm", lambda o: o.values["position_mm"] * 1e-3),
    "quadratic": ("um_per_m2", lambda o: (o.values["position_mm"] / 1000.0) ** 2),
    "backlash": ("reversal_um", lambda o: o.values["direction"] / 2.0),
    "thermal_drift": ("um_per_min", lambda o: o.values["time_min"]),
    "thermal_growth": ("ppm_per_min", lambda o: o.values["position_mm"] * o.values["time_min"] * 1e-3),
    "dead_path": ("length_mm", lambda o: o.values["index_change"] * 1e3),
    "sensor_drift": ("um_per_min", lambda o: o.values["time_min"]),
    "sensor_gain": ("ppm", lambda o: o.values["sensor_um"] * 1e-6),
    # the height takes (xQ − xP)·Δε: a recorded distance |xQ − xP| longer by error_mm errs by its side's sign
    "lever_arm": ("error_mm", lambda o: o.values["q_side"] * o.values["dpitch_urad"] * 1e-3),
    "block_length": ("um_per_block", lambda o: o.values["station"]),
}
TABLES = {"error_table": ("position_mm", "error_um"), "profile_table": ("x_mm", "height_um")}


def abbe_column(obs: Observations, channel: str) -> np.ndarray:
    return obs.values[f"{channel}_urad"] * 1e-3


def needs(effect_type: str, variant: str = "") -> tuple[str, ...]:
    """The per-point values an effect type is a function of."""
    if effect_type in LINEAR:
        keys = {"linear_scale": ("position_mm",), "quadratic": ("position_mm",), "backlash": ("direction",),
                "thermal_drift": ("time_min",), "thermal_growth": ("position_mm", "time_min"),
                "dead_path": ("index_change",), "sensor_drift": ("time_min",), "sensor_gain": ("sensor_um",),
                "lever_arm": ("dpitch_urad", "q_side"), "block_length": ("station",)}
        return keys[effect_type]
    if effect_type == "abbe":
        return (f"{variant or 'pitch'}_urad",)
    if effect_type in TABLES:
        return (TABLES[effect_type][0],)
    return ("position_mm",)  # periodic


def hat_columns(x: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Columns whose combination with weights w is np.interp(x, nodes, w) (flat beyond the ends)."""
    m = len(nodes)
    eye = np.eye(m)
    return np.column_stack([np.interp(x, nodes, eye[j]) for j in range(m)])


def phase_angle(obs: Observations, wavelength_mm: float) -> np.ndarray:
    return 2.0 * math.pi * obs.values["position_mm"] / wavelength_mm


def value(effect: Effect, obs: Observations) -> np.ndarray:
    """The effect's contribution to every observation (µm)."""
    t = effect.type
    if t in LINEAR:
        name, col = LINEAR[t]
        return effect.value(name) * col(obs)
    if t == "abbe":
        return effect.value("offset_mm") * abbe_column(obs, effect.variant)
    if t in TABLES:
        key, vals = TABLES[t]
        return np.interp(obs.values[key], np.asarray(effect.params["positions_mm"]), np.asarray(effect.params[vals]))
    if t == "periodic":
        wl = effect.params["wavelength_mm"]
        if wl is None:
            return np.zeros(obs.n)
        return effect.value("amplitude_um") * np.sin(phase_angle(obs, float(wl)) + effect.value("phase_rad"))
    raise ValueError(f"no contribution defined for effect type {t!r}")


@dataclass(frozen=True)
class Columns:
    """Least-squares columns of a free effect and how their coefficients map to its parameters."""

    matrix: np.ndarray
    to_params: Callable[[np.ndarray], dict[str, float | tuple[float, ...]]]


def columns(effect: Effect, obs: Observations, wavelength_mm: float | None = None) -> Columns:
    """Columns of a free effect (``wavelength_mm``: the trial wavelength of a periodic one with a free
    wavelength)."""
    t = effect.type
    if t in LINEAR:
        name, col = LINEAR[t]
        return Columns(col(obs)[:, None], lambda c: {name: float(c[0])})
    if t == "abbe":
        return Columns(abbe_column(obs, effect.variant)[:, None], lambda c: {"offset_mm": float(c[0])})
    if t in TABLES:
        key, vals = TABLES[t]
        nodes = np.asarray(effect.params["positions_mm"], dtype=float)
        return Columns(hat_columns(obs.values[key], nodes), lambda c: {vals: tuple(float(v) for v in c)})
    if t == "periodic":
        wl = wavelength_mm if wavelength_mm is not None else effect.params["wavelength_mm"]
        if wl is None:
            raise ValueError("a periodic effect with a free wavelength needs a trial wavelength")
        theta = phase_angle(obs, float(wl))
        if effect.free == {"amplitude_um"}:
            phase = effect.value("phase_rad")
            return Columns(np.sin(theta + phase)[:, None], lambda c: {"amplitude_um": float(c[0])})

        def amp_phase(c: np.ndarray, wl: float = float(wl)) -> dict[str, float | tuple[float, ...]]:
            a, b = float(c[0]), float(c[1])
            out: dict[str, float | tuple[float, ...]] = {"amplitude_um": math.hypot(a, b),
                                                         "phase_rad": math.atan2(b, a)}
            if "wavelength_mm" in effect.free:
                out["wavelength_mm"] = wl
            return out

        return Columns(np.column_stack([np.sin(theta), np.cos(theta)]), amp_phase)
    raise ValueError(f"no columns defined for effect type {t!r}")


def jacobian(effect: Effect, obs: Observations) -> tuple[list[str], np.ndarray]:
    """Derivatives of the effect's contribution with respect to its free scalar parameters
    (tables: one per value), at its current parameters; for the standard errors."""
    t = effect.type
    if t == "periodic":
        a, ph = effect.value("amplitude_um"), effect.value("phase_rad")
        wl = float(effect.params["wavelength_mm"] or 1.0)
        arg = phase_angle(obs, wl) + ph
        cols = {"amplitude_um": np.sin(arg), "phase_rad": a * np.cos(arg),
                "wavelength_mm": -a * np.cos(arg) * 2 * math.pi * obs.values["position_mm"] / wl**2}
        names = [n for n in ("amplitude_um", "wavelength_mm", "phase_rad") if n in effect.free]
        return names, np.column_stack([cols[n] for n in names])
    cols_ = columns(effect, obs)
    if t in TABLES:
        vals = TABLES[t][1]
        return [f"{vals}[{i}]" for i in range(cols_.matrix.shape[1])], cols_.matrix
    return list(cols_.to_params(np.ones(1))), cols_.matrix
