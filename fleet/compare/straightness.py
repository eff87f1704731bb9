"""Two straightness runs compared station by station against a common reference line.

Reference line: each profile's own least-squares line, fitted over the stations both runs measured,
is removed from it (docs/compare.md says why).  Per common station the residuals r_a, r_b, the change
r_b − r_a and its expanded uncertainty U = k · √(u_a² + u_b²), k = 2, where u_a, u_b are the per-station
standard uncertainties of the heights (GUM, the u_um of results/profile.csv) propagated through the
removal of the line (:func:`residual_u`).  A station measured in one
run only is listed with its residual against that run's line and no change.  The straightness values
per reference line are set side by side, with their Monte Carlo U where evaluated."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from processing.uncertainty import K
from saved_runs.errors import UserError
from saved_runs.evaluation.straightness import StraightnessEvaluation

from .changes import change, change_pct, combined_expanded, none_if_nan, significant

# A common station may sit this far apart in the two runs (mm) before the runs are refused: the decoupled
# x of a station moves by the block's placement (tens of µm); a different set-up moves it by a block length.
STATION_X_TOLERANCE_MM = 1.0
REFERENCE_LINE = "least_squares"


@dataclass(frozen=True)
class StationChange:
    station: int
    x_mm: float
    a: float | None  # residual from A's line (µm); None where A has no such station
    b: float | None
    u_a: float | None  # standard uncertainty of A's residual there (µm, k = 1)
    u_b: float | None
    k: float

    @property
    def change(self) -> float | None:
        return change(self.a, self.b)

    @property
    def expanded(self) -> float | None:
        return combined_expanded(self.u_a, self.u_b, self.k) if self.change is not None else None

    @property
    def significant(self) -> bool | None:
        return significant(self.change, self.expanded)

    @property
    def only_in(self) -> str | None:
        return "a" if self.b is None else "b" if self.a is None else None

    def to_dict(self) -> dict[str, Any]:
        return {"station": self.station, "x_mm": self.x_mm, "a_um": self.a, "b_um": self.b,
                "change_um": self.change, "u_um": self.expanded, "significant": self.significant,
                "only_in": self.only_in}


def _profile(e: StraightnessEvaluation) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    p = e.result.profile
    u = (e.result.uncertainty.per_station_u_um if e.result.uncertainty is not None
         else np.full(len(p), np.nan))
    return (p["station"].to_numpy(dtype=int), p["x_mm"].to_numpy(dtype=float), p["height_um"].to_numpy(dtype=float),
            np.asarray(u, dtype=float))


def residual_u(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Standard uncertainty (µm) of each residual from the least-squares line over the points x (mm) whose
    heights have the independent standard uncertainties u (µm): r = (I − H) h with the hat matrix
    H_ij = 1/n + (x_i − x̄)(x_j − x̄)/Sxx, so u(r_i)² = Σ_j (δ_ij − H_ij)² u_j².  An error common to every
    station (the datum's) is a constant the line removes; the datum station itself (u = 0, the heights are
    measured from it) gets the uncertainty of the line there."""
    xm = x - x.mean()
    hat = 1.0 / len(x) + np.outer(xm, xm) / np.sum(xm**2)
    return np.sqrt(((np.eye(len(x)) - hat) ** 2) @ (u**2))


def least_squares_line(x: np.ndarray, h: np.ndarray) -> tuple[float, float]:
    """(slope µm/mm, intercept µm) of the least-squares line of h over x."""
    xm = x.mean()
    slope = float(np.sum((x - xm) * (h - h.mean())) / np.sum((x - xm) ** 2))
    return slope, float(h.mean() - slope * xm)


@dataclass(frozen=True)
class StraightnessComparison:
    a: StraightnessEvaluation
    b: StraightnessEvaluation
    stations: tuple[StationChange, ...]
    lines: dict[str, tuple[float, float]]  # "a"/"b" -> (slope µm/mm, intercept µm) of the line removed
    notes: tuple[str, ...]

    k: float = K

    def values(self) -> dict[str, dict[str, Any]]:
        """Straightness per reference line of both runs: {"minimum_zone": {"a", "b", "change", "change_pct",
        "U_a", "U_b", "U", "significant"}, ...}; U of each value from its Monte Carlo (None when off)."""
        out = {}
        sa, sb = self.a.result.straightness_um(), self.b.result.straightness_um()
        ua, ub = _mc_u(self.a), _mc_u(self.b)
        for name in sa:
            va, vb = none_if_nan(sa[name]), none_if_nan(sb.get(name))
            d = change(va, vb)
            big_u = (float(np.hypot(ua[name], ub[name])) if name in ua and name in ub else None)
            out[name] = {"a": va, "b": vb, "change": d, "change_pct": change_pct(va, vb), "U_a": ua.get(name),
                         "U_b": ub.get(name), "U": big_u, "significant": significant(d, big_u)}
        return out

    def matched(self) -> list[StationChange]:
        return [s for s in self.stations if s.only_in is None]

    def to_dict(self) -> dict[str, Any]:
        return {"stations": [s.to_dict() for s in self.stations], "values": self.values(), "unit": "um", "k": self.k,
                "method": self.a.result.method,
                "reference_line": {"name": REFERENCE_LINE, "fitted_over": "the stations both runs measured",
                                   "a": {"slope_um_per_mm": self.lines["a"][0], "intercept_um": self.lines["a"][1]},
                                   "b": {"slope_um_per_mm": self.lines["b"][0], "intercept_um": self.lines["b"][1]},
                                   "text": "each profile's own least-squares line over the common stations removed"},
                "uncertainty": f"U = k * sqrt(u_a^2 + u_b^2), k = {self.k:g}: u of each run's residual, its "
                               "per-station height u (GUM) propagated through the removal of its least-squares "
                               "line, u(r_i)^2 = sum_j (delta_ij - H_ij)^2 u_j^2; the runs combined in quadrature",
                "change": "b - a (run B's residual minus run A's)"}


def _mc_u(e: StraightnessEvaluation) -> dict[str, float]:
    unc = e.result.uncertainty
    return dict(unc.to_dict().get("straightness", {})) if unc is not None else {}


def compare_straightness(a: StraightnessEvaluation, b: StraightnessEvaluation) -> StraightnessComparison:
    """Remove each profile's least-squares line over the common stations and compute the change at each."""
    if a.result.method != b.result.method:  # both are evaluated with the same options; a guard for other callers
        raise UserError(f"the runs were decoupled by different methods ({a.result.method}, {b.result.method})")
    st_a, x_a, h_a, u_a = _profile(a)
    st_b, x_b, h_b, u_b = _profile(b)
    common = np.intersect1d(st_a, st_b)
    if len(common) < 2:
        raise UserError(f"the runs share {len(common)} station(s) ({a.run.path}: stations {st_a.min()} … "
                        f"{st_a.max()}, {b.run.path}: {st_b.min()} … {st_b.max()}); a common reference line "
                        "needs at least 2")
    ia = np.searchsorted(st_a, common)
    ib = np.searchsorted(st_b, common)
    dx = np.abs(x_a[ia] - x_b[ib])
    worst = int(np.argmax(dx))
    if dx[worst] > STATION_X_TOLERANCE_MM:
        raise UserError(f"station {common[worst]} is at x = {x_a[ia][worst]:.3f} mm in {a.run.path} and "
                        f"{x_b[ib][worst]:.3f} mm in {b.run.path}: the stations are not at the same places; "
                        "compare runs of the same set-up")
    line_a = least_squares_line(x_a[ia], h_a[ia])
    line_b = least_squares_line(x_b[ib], h_b[ib])
    r_a = h_a - (line_a[1] + line_a[0] * x_a)
    r_b = h_b - (line_b[1] + line_b[0] * x_b)
    # the u of each common station's residual (the line removal propagated); a station of one run only keeps
    # the u of its height (it takes no part in the fit and has no change)
    u_a, u_b = u_a.copy(), u_b.copy()
    u_a[ia] = residual_u(x_a[ia], u_a[ia])
    u_b[ib] = residual_u(x_b[ib], u_b[ib])
    where_a = {int(s): i for i, s in enumerate(st_a)}
    where_b = {int(s): i for i, s in enumerate(st_b)}
    rows = []
    for s in sorted(set(where_a) | set(where_b)):
        i, j = where_a.get(s), where_b.get(s)
        x = float(x_a[i]) if i is not None else float(x_b[j])  # type: ignore[index]
        rows.append(StationChange(s, x, None if i is None else float(r_a[i]), None if j is None else float(r_b[j]),
                                  None if i is None else none_if_nan(float(u_a[i])),
                                  None if j is None else none_if_nan(float(u_b[j])), K))
    notes = []
    for side, st, other in (("A", st_a, st_b), ("B", st_b, st_a)):
        only = np.setdiff1d(st, other)
        if len(only):
            notes.append(f"stations measured in run {side} only: {', '.join(map(str, only[:12]))}"
                         + (" ..." if len(only) > 12 else "") + "; no change there, and the straightness values "
                         "of the runs are not over the same length")
    return StraightnessComparison(a, b, tuple(rows), {"a": line_a, "b": line_b}, tuple(notes))
