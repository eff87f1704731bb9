"""Environmental compensation of linear interferometer readings (standards.md §3, §3.5).

The controller displays ``L_read = OPC / n_assumed``, the optical path change
since it was zeroed divided by the index it assumed.  The true optical path
change over the beam is ``n₁ (D + L) − n₀ D`` (dead path D at the datum, index
n₀ when the interferometer was zeroed, n₁ at the reading), so

    L    = L_read · n_assumed / n₁ − D (n₁ − n₀) / n₁          (air index + dead path)
    L₂₀  = L / (1 + α (T_m − 20 °C))                             (material normalised to 20 °C, ISO 1)

with n₁ from the air temperature, pressure and humidity logged with each point
(:mod:`processing.air_index`), n₀ the index at the first point of the run (the
interferometer is zeroed at the start of the run), α the expansion coefficient
(ppm/K) and T_m the material temperature logged with the point.  The readings
are lengths from the interferometer zero, which is taken as axis position 0
(``reading_mm`` is in the axis coordinates, as ``target_mm``).

Rotary axes are not compensated: an angular interferometer measures a ratio of
two beam paths in the same air, in which the index cancels.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .air_index import DEFAULT_CO2_PPM, DEFAULT_EQUATION, EQUATION_NAMES, HENE_WAVELENGTH_NM, air_index

if TYPE_CHECKING:  # the set-up loaders import the settings: pandas only with points
    import pandas as pd

REFERENCE_TEMP_C = 20.0

FORMULAS = {
    "air": "L = L_read * n_assumed / n1 - D * (n1 - n0) / n1",
    "material": "L20 = L / (1 + alpha * (T_m - 20 C))",
}


class MissingValueError(ValueError):
    """A point lacks a value the compensation needs; ``point`` is its 0-based position."""

    def __init__(self, point: int, column: str, why: str) -> None:
        super().__init__(f"point {point} has no {column}: {why}")
        self.point, self.column, self.why = point, column, why


WAVELENGTH_RANGE_NM = (300.0, 1700.0)  # vacuum wavelengths the air-index equations cover (guideway air-index)


@dataclass(frozen=True)
class EnvironmentSettings:
    """``setup.environment`` of a positioning run (docs/run-format.md)."""

    readings_compensated: bool = False
    refractive_index_assumed: float | None = None
    wavelength_nm: float = HENE_WAVELENGTH_NM
    co2_ppm: float = DEFAULT_CO2_PPM
    expansion_ppm_per_k: float | None = None
    dead_path_mm: float = 0.0
    index_equation: str = DEFAULT_EQUATION

    @classmethod
    def from_dict(cls, d: dict[str, Any] | None) -> EnvironmentSettings:
        """Read ``setup.environment``; unknown keys are ignored; raises ValueError on bad values."""
        d = dict(d or {})

        def num(key: str, default: float | None) -> float | None:
            v = d.get(key, default)
            if v is None:
                return None
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise ValueError(f"setup.environment.{key} must be a finite number, got {v!r}")
            return float(v)

        comp = d.get("readings_compensated", False)
        if not isinstance(comp, bool):
            raise ValueError(f"setup.environment.readings_compensated must be true or false, got {comp!r}")
        eq = d.get("index_equation", DEFAULT_EQUATION)
        if eq not in EQUATION_NAMES:
            raise ValueError(f"setup.environment.index_equation must be one of {', '.join(EQUATION_NAMES)}, "
                             f"got {eq!r}")
        s = cls(
            readings_compensated=comp,
            refractive_index_assumed=num("refractive_index_assumed", None),
            wavelength_nm=num("wavelength_nm", HENE_WAVELENGTH_NM),  # type: ignore[arg-type]
            co2_ppm=num("co2_ppm", DEFAULT_CO2_PPM),  # type: ignore[arg-type]
            expansion_ppm_per_k=num("expansion_ppm_per_k", None),
            dead_path_mm=num("dead_path_mm", 0.0),  # type: ignore[arg-type]
            index_equation=eq,
        )
        lo, hi = WAVELENGTH_RANGE_NM
        if not lo <= s.wavelength_nm <= hi:  # also a negative or zero one, which would still give an index
            raise ValueError(f"setup.environment.wavelength_nm = {s.wavelength_nm:g} is outside {lo:g} to {hi:g} nm, "
                             "the range of the air-index equations (a HeNe laser: 632.991)")
        if s.refractive_index_assumed is not None and not 0.9 < s.refractive_index_assumed < 1.1:
            raise ValueError(f"setup.environment.refractive_index_assumed = {s.refractive_index_assumed} is not an "
                             "air index (expected about 1.0 to 1.0003)")
        return s


@dataclass(frozen=True)
class CompensationInfo:
    """What was done to the readings (reported with the results)."""

    applied: bool
    reason: str
    equation: str | None = None
    equation_name: str | None = None
    refractive_index_assumed: float | None = None
    index_min: float | None = None
    index_max: float | None = None
    index_datum: float | None = None
    wavelength_nm: float | None = None
    co2_ppm: float | None = None
    dead_path_mm: float | None = None
    expansion_ppm_per_k: float | None = None
    material_temp_min_c: float | None = None
    material_temp_max_c: float | None = None
    formulas: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["formulas"] = list(self.formulas)
        return d


def compensate_linear_readings(
    reading_mm: np.ndarray,
    air_temp_c: np.ndarray,
    air_pressure_hpa: np.ndarray,
    humidity_pct: np.ndarray,
    material_temp_c: np.ndarray,
    settings: EnvironmentSettings,
) -> tuple[np.ndarray, CompensationInfo]:
    """Compensated lengths (mm) of readings in recording order (the first is the datum).

    Arrays are per point.  Air values are needed unless ``readings_compensated``;
    the material temperature only when ``expansion_ppm_per_k`` is set.  Raises
    ValueError naming the first point (0-based row) with a missing value.
    """
    reading = np.asarray(reading_mm, dtype=float)
    if settings.readings_compensated:
        return reading.copy(), CompensationInfo(
            applied=False, reason="readings_compensated is true: readings used as recorded")
    if settings.refractive_index_assumed is None:
        raise ValueError("setup.environment.refractive_index_assumed is missing: state the air index the "
                         "controller applied (1.0 for raw vacuum-wavelength counts) or set readings_compensated")
    t = np.asarray(air_temp_c, dtype=float)
    p = np.asarray(air_pressure_hpa, dtype=float) * 100.0
    rh = np.asarray(humidity_pct, dtype=float)
    for name, arr in (("air_temp_c", t), ("air_pressure_hpa", p), ("humidity_pct", rh)):
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise MissingValueError(int(bad[0]), name, "air values are needed to compensate the readings "
                                    "(or set readings_compensated)")
    n1 = air_index(t, p, rh, co2_ppm=settings.co2_ppm, wavelength_nm=settings.wavelength_nm,
                   equation=settings.index_equation)
    n0 = float(n1[0]) if n1.size else float("nan")
    D = settings.dead_path_mm
    length = reading * settings.refractive_index_assumed / n1 - D * (n1 - n0) / n1
    formulas = [FORMULAS["air"]]
    tm_min = tm_max = None
    alpha = settings.expansion_ppm_per_k
    if alpha is not None:
        tm = np.asarray(material_temp_c, dtype=float)
        bad = np.flatnonzero(~np.isfinite(tm))
        if bad.size:
            raise MissingValueError(int(bad[0]), "material_temp_c", "needed for the normalisation to 20 C "
                                    "(or remove expansion_ppm_per_k)")
        length = length / (1 + alpha * 1e-6 * (tm - REFERENCE_TEMP_C))
        formulas.append(FORMULAS["material"])
        tm_min, tm_max = float(tm.min()), float(tm.max())
    reason = "air index re-scaled per point" + (", dead path corrected" if D else "") + (
        ", material normalised to 20 C" if alpha is not None else ", no material normalisation "
        "(expansion_ppm_per_k not set)")
    return length, CompensationInfo(
        applied=True, reason=reason, equation=settings.index_equation,
        equation_name=EQUATION_NAMES[settings.index_equation],
        refractive_index_assumed=settings.refractive_index_assumed,
        index_min=float(n1.min()), index_max=float(n1.max()), index_datum=n0,
        wavelength_nm=settings.wavelength_nm, co2_ppm=settings.co2_ppm, dead_path_mm=D,
        expansion_ppm_per_k=alpha, material_temp_min_c=tm_min, material_temp_max_c=tm_max,
        formulas=tuple(formulas))


def compensate_points(points: pd.DataFrame, settings: EnvironmentSettings) -> tuple[np.ndarray, CompensationInfo]:
    """:func:`compensate_linear_readings` on the columns of a linear positioning points.csv,
    in time order (``time_s``; row order where it is NaN). Returns lengths in row order."""
    order = np.arange(len(points))
    if "time_s" in points and np.isfinite(points["time_s"].to_numpy(dtype=float)).all():
        order = np.argsort(points["time_s"].to_numpy(dtype=float), kind="stable")
    cols = {c: points[c].to_numpy(dtype=float)[order] if c in points else np.full(len(points), np.nan)
            for c in ("reading_mm", "air_temp_c", "air_pressure_hpa", "humidity_pct", "material_temp_c")}
    try:
        length_sorted, info = compensate_linear_readings(
            cols["reading_mm"], cols["air_temp_c"], cols["air_pressure_hpa"], cols["humidity_pct"],
            cols["material_temp_c"], settings)
    except MissingValueError as exc:
        # Name the data row of points.csv (1 = first row after the header).
        raise ValueError(f"points.csv data row {int(order[exc.point]) + 1} has no {exc.column}: {exc.why}") from None
    length = np.empty_like(length_sorted)
    length[order] = length_sorted
    return length, info


def angular_deviation_deg(reading_deg: np.ndarray | float, target_deg: np.ndarray | float) -> np.ndarray:
    """reading − target of a rotary axis wrapped to (−180, 180] deg, so 359.9999 read at target 0
    is a small negative deviation (angular readings are not air-compensated, see above)."""
    diff = np.asarray(reading_deg, dtype=float) - np.asarray(target_deg, dtype=float)
    return -((-diff + 180.0) % 360.0 - 180.0)
