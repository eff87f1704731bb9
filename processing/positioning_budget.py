"""Uncertainty budget of the ISO 230-2 values of a positioning run (ISO 230-2 Annex A, ISO/TR 230-9).

Pure: no files, no clock.  Every contribution is a *standard* uncertainty in the value's unit (µm for a
linear axis, arcsec for a rotary one); the combined u_c = √Σu², the expanded U = k·u_c
(docs/positioning.md, "Uncertainty of the ISO 230-2 values"; ../shared/reference/standards.md §1.7, §3.5).

Linear axis, for a value spanning the length L (E, M, A and their one-direction forms: the distance between
the first and the last target, the longest span a max − min of the means can cover):

* laser calibration u_DEVICE = L·u_laser (default u_laser = 0.5 ppm, the typical figure of standards.md §1.7,
  unless the set-up gives the instrument's own);
* air refractive index: L·|∂n/∂t|·u(t), L·|∂n/∂p|·u(p), L·|∂n/∂RH|·u(RH), the sensitivities computed by central
  differences of the run's own index equation (processing.air_index, Ciddor 1996 or modified Edlén) at the
  run's mean air conditions.  At 20 °C, 101325 Pa, 50 %RH, 633 nm they are ≈ −0.955 ppm/K (Ciddor), +0.27 ppm/hPa,
  −0.0085 ppm/%RH (standards.md §3.4, from the NIST EMToolbox forms);
* material temperature u_M,TE = L·α·u(T_material);
* expansion coefficient L·|T_material − 20 °C|·u(α);
* misalignment (cosine, standards.md §3.5): the laser reads short by L·θ²/2 for a residual angle up to θ;
  a rectangular distribution over [0, L·θ²/2] gives u = L·θ²/(2√12).

Those five are proportional to the position and the same for both directions at a target (one laser, one
index, one temperature): they cancel in the reversal B_i = x̄↑_i − x̄↓_i and in the repeatability R (a spread
at one target), so B and R carry none of them (ISO/TR 230-9's logic of common-mode contributions).

All values, linear and rotary:

* environmental variation E_VE (a drift check, ISO 230-2 Annex A): u = E_VE/(2√3), when the set-up gives the
  measured E_VE; otherwise not included (and said so);
* repeatability of the value itself: the standard deviation of the value over repeats of the run
  (saved_runs.evaluation.value_uncertainty's Monte Carlo, passed in).

A rotary axis's angular readings carry no air index or expansion (the index cancels in an angular
interferometer), so only E_VE and the repeatability apply there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .air_index import DEFAULT_CO2_PPM, DEFAULT_EQUATION, HENE_WAVELENGTH_NM, air_index

REFERENCE_TEMP_C = 20.0
STANDARD_AIR = (20.0, 101325.0, 50.0)  # t °C, p Pa, RH %: the conditions used when the run recorded none
# Values that span the axis (scale contributions apply) and values at one target (they cancel).
SPAN_VALUES = ("E", "E_up", "E_down", "M", "A", "A_up", "A_down")
LOCAL_VALUES = ("B", "B_mean", "R", "R_up", "R_down")
BUDGET_VALUES = SPAN_VALUES + LOCAL_VALUES
NOT_INCLUDED_EVE = "environmental variation E_VE: not included (no drift check given in [uncertainty] drift)"


@dataclass(frozen=True)
class BudgetSettings:
    """``[uncertainty]`` of a positioning set-up (run.json ``setup.uncertainty``); standard uncertainties.

    ``laser_ppm`` u of the laser's length measurement (ppm of L); ``air_temp_k``, ``air_pressure_hpa``,
    ``humidity_pct`` u of the environment sensors; ``material_temp_k`` u of the material temperature sensor;
    ``expansion_ppm_per_k`` u(α); ``misalignment_mrad`` the largest residual beam angle θ; ``drift`` E_VE of a
    drift check in the value's unit (µm, rotary arcsec), None when none was made."""

    laser_ppm: float = 0.5
    air_temp_k: float = 0.1
    air_pressure_hpa: float = 0.5
    humidity_pct: float = 3.0
    material_temp_k: float = 0.1
    expansion_ppm_per_k: float = 1.0
    misalignment_mrad: float = 0.1
    drift: float | None = None

    @classmethod
    def from_dict(cls, d: dict[str, Any] | None) -> BudgetSettings:
        """Read ``[uncertainty]``; raises ValueError naming an unknown key or a bad value."""
        if d is not None and not isinstance(d, dict):
            raise ValueError(f"[uncertainty] must be a table, got {d!r}")
        d = dict(d or {})
        names = list(cls.__dataclass_fields__)
        extra = sorted(set(d) - set(names))
        if extra:
            raise ValueError(f"unknown key {extra[0]!r} in [uncertainty]; use {', '.join(names)}")
        for key, v in d.items():
            if isinstance(v, bool) or not isinstance(v, int | float) or not (math.isfinite(v) and v >= 0):
                raise ValueError(f"[uncertainty] {key} must be a number >= 0, got {v!r}")
        return cls(**{k: float(v) for k, v in d.items()})


@dataclass(frozen=True)
class ValueBudget:
    """The budget of one ISO 230-2 value: ``contributions`` name → standard uncertainty (``unit``),
    ``u_c``, ``U`` = ``k``·u_c, ``length_mm`` the L the scale contributions act over (None: they cancel
    or do not apply), ``notes`` what is not included.  ``U`` is None when the value's repeatability is
    unknown (fewer than 2 approaches): the budget is then incomplete and nothing can be decided with it."""

    quantity: str
    unit: str
    k: float
    contributions: dict[str, float]
    u_c: float | None
    U: float | None
    length_mm: float | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        return {"unit": self.unit, "k": self.k, "u_c": self.u_c, "U": self.U, "length_mm": self.length_mm,
                "contributions": dict(self.contributions), "notes": list(self.notes)}


def index_sensitivities(t_c: float, p_pa: float, rh_pct: float, *, equation: str = DEFAULT_EQUATION,
                        wavelength_nm: float = HENE_WAVELENGTH_NM, co2_ppm: float = DEFAULT_CO2_PPM
                        ) -> dict[str, float]:
    """∂n/∂t (ppm/K), ∂n/∂p (ppm/hPa), ∂n/∂RH (ppm/%RH) of the air index ``equation`` at (t, p, RH),
    by central differences (steps 0.01 K, 1 Pa, 0.1 %RH: the index is smooth, truncation < 1e-6 relative)."""

    def n(t: float, p: float, rh: float) -> float:
        return float(air_index(t, p, rh, co2_ppm=co2_ppm, wavelength_nm=wavelength_nm, equation=equation))

    dt, dp, drh = 0.01, 1.0, 0.1
    return {
        "t_ppm_per_k": (n(t_c + dt, p_pa, rh_pct) - n(t_c - dt, p_pa, rh_pct)) / (2 * dt) * 1e6,
        "p_ppm_per_hpa": (n(t_c, p_pa + dp, rh_pct) - n(t_c, p_pa - dp, rh_pct)) / (2 * dp) * 1e6 * 100.0,
        "rh_ppm_per_pct": (n(t_c, p_pa, rh_pct + drh) - n(t_c, p_pa, rh_pct - drh)) / (2 * drh) * 1e6,
    }


def positioning_budget(*, axis_type: str, unit: str, span_mm: float, repeatability: dict[str, float | None],
                       settings: BudgetSettings = BudgetSettings(), k: float = 2.0,
                       air: tuple[float, float, float] | None = None, material_temp_c: float | None = None,
                       expansion_ppm_per_k: float | None = None, equation: str = DEFAULT_EQUATION,
                       wavelength_nm: float = HENE_WAVELENGTH_NM, co2_ppm: float = DEFAULT_CO2_PPM,
                       quantities: tuple[str, ...] = BUDGET_VALUES) -> dict[str, ValueBudget]:
    """The :class:`ValueBudget` of each of ``quantities`` (module docstring).

    ``span_mm`` the distance between the first and the last target (linear axis); ``repeatability`` the
    standard deviation of each value over repeats (None: not known); ``air`` the run's mean (t °C, p Pa,
    RH %) (None: :data:`STANDARD_AIR`); ``material_temp_c`` the run's mean material temperature (None:
    20 °C, so the u(α) term is 0); ``expansion_ppm_per_k`` α (None: 11.5, steel)."""
    linear = axis_type == "linear"
    notes_common: list[str] = []
    scale: dict[str, float] = {}
    if linear:
        t, p, rh = air if air is not None and all(math.isfinite(x) for x in air) else STANDARD_AIR
        if air is None or not all(math.isfinite(x) for x in air):
            notes_common.append("air index sensitivities at 20 °C, 101325 Pa, 50 %RH (no air data in the run)")
        sens = index_sensitivities(t, p, rh, equation=equation, wavelength_nm=wavelength_nm, co2_ppm=co2_ppm)
        alpha = 11.5 if expansion_ppm_per_k is None else expansion_ppm_per_k
        if expansion_ppm_per_k is None:
            notes_common.append("expansion coefficient not in the set-up: α = 11.5 ppm/K (steel) assumed")
        dt_mat = 0.0 if material_temp_c is None or not math.isfinite(material_temp_c) \
            else abs(material_temp_c - REFERENCE_TEMP_C)
        theta = settings.misalignment_mrad * 1e-3
        # per mm of L, in µm (1 ppm of 1 mm = 1e-3 µm)
        scale = {
            "laser calibration": settings.laser_ppm * 1e-3,
            "air index (air temperature)": abs(sens["t_ppm_per_k"]) * settings.air_temp_k * 1e-3,
            "air index (pressure)": abs(sens["p_ppm_per_hpa"]) * settings.air_pressure_hpa * 1e-3,
            "air index (humidity)": abs(sens["rh_ppm_per_pct"]) * settings.humidity_pct * 1e-3,
            "material temperature": alpha * settings.material_temp_k * 1e-3,
            "expansion coefficient": dt_mat * settings.expansion_ppm_per_k * 1e-3,
            "misalignment (cosine)": theta**2 / (2 * math.sqrt(12)) * 1e3,
        }
    if settings.drift is None:
        notes_common.append(NOT_INCLUDED_EVE)
    budgets: dict[str, ValueBudget] = {}
    for q in quantities:
        contributions: dict[str, float] = {}
        notes = list(notes_common)
        length = None
        if linear and q in SPAN_VALUES:
            length = float(span_mm)
            contributions.update({name: per_mm * length for name, per_mm in scale.items()})
        elif linear:
            notes.append("laser, air index, temperature and misalignment are common to both directions at a "
                         "target and cancel in this value")
        if settings.drift is not None:
            contributions["environmental variation E_VE"] = settings.drift / (2 * math.sqrt(3))
        rep = repeatability.get(q)
        if rep is not None and math.isfinite(rep):
            contributions["repeatability of the value"] = float(rep)
            u_c: float | None = math.sqrt(sum(u * u for u in contributions.values()))
        else:
            notes.append("repeatability of the value unknown (fewer than 2 approaches): no U")
            u_c = None
        budgets[q] = ValueBudget(q, unit, k, contributions, u_c, None if u_c is None else k * u_c, length,
                                 tuple(notes))
    return budgets


def span_of(targets: np.ndarray) -> float:
    """The distance between the first and the last target (their unit)."""
    t = np.asarray(targets, dtype=float)
    return float(np.nanmax(t) - np.nanmin(t)) if t.size else 0.0
