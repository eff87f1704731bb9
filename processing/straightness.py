"""Straightness evaluation of a gauge-block run: decoupling, station averaging
over the forward and return passes, reference lines, dominant wavelengths and
uncertainty."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from .decoupling import DEFAULT_METHOD, METHODS, DatumAnglesUsed, check_method, decouple_run
from .geometry import BlockGeometry
from .passes import ReturnPassSummary, check_order, return_pass_summary, station_groups
from .point_columns import Points, as_columns
from .reference_lines import LineFit, endpoint_line, least_squares_line, minimum_zone_line
from .uncertainty import (
    K,
    MonteCarloResult,
    UncertaintyInputs,
    datum_pitch_u_urad,
    gum_per_station,
    monte_carlo,
    profile_slope,
)
from .wavelength import Peak, dominant_wavelengths

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["METHODS", "StraightnessResult", "Uncertainty", "evaluate_straightness"]

LINES = ("endpoint", "least_squares", "minimum_zone")


@dataclass(frozen=True)
class Uncertainty:
    """GUM per-station standard uncertainties (um) and the Monte Carlo result (None if not run)."""

    inputs: UncertaintyInputs
    per_station_u_um: np.ndarray
    monte_carlo: MonteCarloResult | None

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "k": K,
            "per_station": [float(K * u) for u in self.per_station_u_um],
            "per_station_method": "GUM law of propagation, first-order sensitivities",
            "inputs": self.inputs.to_dict(),
        }
        if self.monte_carlo is not None:
            mc = self.monte_carlo.summary()
            d["straightness"] = {name: s["U"] for name, s in mc.items()}
            d["straightness_interval_95"] = {name: s["interval_95"] for name, s in mc.items()}
            d["straightness_mc_mean"] = {name: s["mean"] for name, s in mc.items()}
            d["straightness_method"] = (f"Monte Carlo (GUM-S1), {self.monte_carlo.trials} trials, "
                                        f"seed {self.monte_carlo.seed}; U = k * standard deviation")
        return d


@dataclass(frozen=True)
class StraightnessResult:
    """Profile (``profile_columns`` station, x_mm, height_um; ``profile``: the same as a DataFrame,
    pandas imported on first use) plus everything evaluated from it."""

    method: str
    profile_columns: dict[str, np.ndarray]
    lines: dict[str, LineFit] = field(default_factory=dict)
    uncertainty: Uncertainty | None = None
    wavelengths: list[Peak] = field(default_factory=list)
    return_pass: ReturnPassSummary | None = None
    datum: DatumAnglesUsed | None = None  # exact method: the datum block's angles in the laser frame
    datum_pitch_u_urad: float | None = None  # u of an estimated datum pitch (with uncertainty inputs)

    @cached_property
    def profile(self) -> pd.DataFrame:
        import pandas as pd

        return pd.DataFrame(self.profile_columns)

    def straightness_um(self) -> dict[str, float]:
        return {name: fit.straightness_um for name, fit in self.lines.items()}

    def to_dict(self) -> dict[str, Any]:
        """The JSON object ``guideway process --json`` prints."""
        d: dict[str, Any] = {
            "kind": "straightness",
            "method": self.method,
            "profile": [
                {"station": int(k), "x_mm": float(x), "height_um": float(h)}
                for k, x, h in zip(*(self.profile_columns[c] for c in ("station", "x_mm", "height_um")),
                                   strict=True)
            ],
            "straightness_um": self.straightness_um(),
            "reference_lines": {name: {"slope_um_per_mm": f.slope_um_per_mm, "intercept_um": f.intercept_um}
                                for name, f in self.lines.items()},
            "wavelength_mm": ({"dominant": self.wavelengths[0].wavelength_mm,
                               "amplitude_um": self.wavelengths[0].amplitude_um,
                               "peaks": [{"wavelength_mm": p.wavelength_mm, "amplitude_um": p.amplitude_um}
                                         for p in self.wavelengths]}
                              if self.wavelengths else None),
        }
        if self.uncertainty is not None:
            d["uncertainty_um"] = self.uncertainty.to_dict()
        if self.return_pass is not None:
            d["return_pass"] = self.return_pass.to_dict()
        if self.datum is not None:
            d["datum_angles_urad"] = self.datum.to_dict()
            if self.datum.source["pitch"] == "estimated" and self.datum_pitch_u_urad is not None:
                d["datum_angles_urad"]["pitch_u_urad"] = self.datum_pitch_u_urad
        return d


def evaluate_straightness(
    points: Points,
    geometry: BlockGeometry,
    *,
    method: str = DEFAULT_METHOD,
    uncertainty: UncertaintyInputs | None = None,
    mc_trials: int = 10_000,
    mc_seed: int = 0,
    mc_progress: Callable[[int, int], None] | None = None,
) -> StraightnessResult:
    """Decouple every point, average each station over its passes, fit the three
    reference lines, find the dominant wavelengths and, when ``uncertainty`` is
    given, the GUM per-station and (``mc_trials`` > 0) Monte Carlo uncertainties
    (``mc_progress(done, trials)`` after each chunk of trials)."""
    check_method(method)
    points = as_columns(points)
    check_order(points)
    dec = decouple_run(points, geometry, method)
    per_point = dec.columns
    groups = station_groups(points)
    x = groups.average(per_point["x_mm"])
    h = groups.average(per_point["height_um"])
    profile = {"station": groups.stations, "x_mm": x, "height_um": h}
    lines: dict[str, LineFit] = {}
    if len(x) >= 2:
        lines = {"endpoint": endpoint_line(x, h), "least_squares": least_squares_line(x, h),
                 "minimum_zone": minimum_zone_line(x, h)}
    unc = None
    if uncertainty is not None:
        slope = profile_slope(x, h)
        u = gum_per_station(points, geometry, method, uncertainty, groups, slope)
        mc = (monte_carlo(points, geometry, method, uncertainty, groups, x, slope, trials=mc_trials,
                          seed=mc_seed, lines=tuple(lines), progress=mc_progress) if mc_trials > 0 and lines else None)
        unc = Uncertainty(uncertainty, u, mc)
    return StraightnessResult(
        method=method, profile_columns=profile, lines=lines, uncertainty=unc,
        wavelengths=dominant_wavelengths(x, h) if np.all(np.diff(x) > 0) else [],
        return_pass=return_pass_summary(points, per_point),
        datum=dec.datum,
        datum_pitch_u_urad=(datum_pitch_u_urad(dec.channels, geometry, uncertainty)
                            if method == "exact" and uncertainty is not None else None),
    )
