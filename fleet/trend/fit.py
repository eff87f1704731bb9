"""The trend of one headline value over the runs of a machine axis: weighted least-squares straight line
against time, its slope in µm per year, the date the line reaches a limit, and the steps between
consecutive runs (docs/fleet.md gives the formulas).

Pure arithmetic on a few thousand numbers: no NumPy, so a trend answers as fast as the catalogue does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Any

DAYS_PER_YEAR = 365.25  # the Julian year
SECONDS_PER_YEAR = DAYS_PER_YEAR * 86400.0
STEP_K = 2.0  # a step is flagged when |change| exceeds k times the combined standard uncertainty


@dataclass(frozen=True)
class TrendPoint:
    """One run's value: ``date`` (run.json ``created``), ``value_um`` and its standard uncertainty
    ``u_um`` (None: not evaluated)."""

    run: str
    date: str
    value_um: float
    u_um: float | None
    path: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"run": self.run, "date": self.date, "value_um": self.value_um, "u_um": self.u_um}


def parse_date(text: str) -> datetime:
    """run.json ``created`` (ISO 8601, UTC when it names no zone) as an aware datetime."""
    when = datetime.fromisoformat(text.replace("Z", "+00:00"))
    return when if when.tzinfo is not None else when.replace(tzinfo=UTC)


def _iso(when: datetime) -> str:
    return when.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


@dataclass(frozen=True)
class Step:
    """A change between consecutive runs larger than ``STEP_K`` times their combined standard uncertainty."""

    from_run: str
    to_run: str
    date: str
    change_um: float
    u_um: float

    def to_dict(self) -> dict[str, Any]:
        return {"from_run": self.from_run, "to_run": self.to_run, "date": self.date, "change_um": self.change_um,
                "u_um": self.u_um, "k": STEP_K}


@dataclass(frozen=True)
class Trend:
    """The fit: ``value(t) = intercept_um + slope_um_per_year * (t - t0)`` with t in years of 365.25 days
    from ``t0`` (the first run); uncertainties are standard (k = 1)."""

    points: list[TrendPoint]
    slope_um_per_year: float | None = None
    u_slope_um_per_year: float | None = None
    intercept_um: float | None = None
    t0: str | None = None
    weights: str = ""
    limit_um: float | None = None
    crossing_date: str | None = None
    u_crossing_days: float | None = None
    crossing_note: str = ""
    steps: list[Step] = field(default_factory=list)
    chi2_per_dof: float | None = None

    def line_um(self, when: datetime) -> float | None:
        """The fitted line's value at ``when``."""
        if self.slope_um_per_year is None or self.intercept_um is None or self.t0 is None:
            return None
        return self.intercept_um + self.slope_um_per_year * years_between(parse_date(self.t0), when)


def years_between(t0: datetime, t: datetime) -> float:
    return (t - t0).total_seconds() / SECONDS_PER_YEAR


def weighted_line(t: list[float], y: list[float], u: list[float]) -> tuple[float, float, float, float, float]:
    """Weighted least-squares line y = a + b t with weights 1/u²: (a, b, var a, var b, cov a b), the
    variances from the stated uncertainties (closed form, Bevington & Robinson eq. 6.12, 6.21)."""
    w = [1.0 / (ui * ui) for ui in u]
    s = sum(w)
    sx = sum(wi * ti for wi, ti in zip(w, t, strict=True))
    sy = sum(wi * yi for wi, yi in zip(w, y, strict=True))
    # centred sums: the same line, without the cancellation of S*Sxx - Sx^2 when t is large
    tm = sx / s
    stt = sum(wi * (ti - tm) ** 2 for wi, ti in zip(w, t, strict=True))
    sty = sum(wi * (ti - tm) * yi for wi, ti, yi in zip(w, t, y, strict=True))
    b = sty / stt
    a = (sy - b * sx) / s
    var_b = 1.0 / stt
    var_a = 1.0 / s + tm * tm / stt
    cov_ab = -tm / stt
    return a, b, var_a, var_b, cov_ab


def fit_trend(points: list[TrendPoint], limit_um: float | None = None) -> Trend:
    """The trend of ``points`` (any order; sorted oldest first).

    With every point's uncertainty known, the weights are 1/u² and the slope's uncertainty comes from
    them; when some are missing, all points weigh the same and u is estimated from the scatter about the
    line (s² = Σ r² / (n − 2)), as ordinary least squares does.  The crossing is where the line reaches
    ``limit_um``, with its uncertainty propagated from the line's (first order, the covariance included);
    none when the line does not rise."""
    pts = sorted(points, key=lambda p: (parse_date(p.date), p.run))
    steps = find_steps(pts)
    if len(pts) < 2:
        return Trend(pts, limit_um=limit_um, steps=steps, crossing_note="a trend needs at least two runs")
    t0 = parse_date(pts[0].date)
    t = [years_between(t0, parse_date(p.date)) for p in pts]
    if max(t) - min(t) <= 0:
        return Trend(pts, limit_um=limit_um, steps=steps, crossing_note="all runs have the same date")
    y = [p.value_um for p in pts]
    known = all(p.u_um is not None and p.u_um > 0 for p in pts)
    if known:
        u = [float(p.u_um) for p in pts]  # type: ignore[arg-type]
        weights = "1/u² (the runs' standard uncertainties)"
    else:
        u = [1.0] * len(pts)
        weights = "equal (not every run has an uncertainty: u estimated from the scatter about the line)"
    a, b, var_a, var_b, cov_ab = weighted_line(t, y, u)
    resid = [(yi - a - b * ti) / ui for ti, yi, ui in zip(t, y, u, strict=True)]
    dof = len(pts) - 2
    chi2 = sum(r * r for r in resid)
    if not known:
        if dof < 1:
            var_a = var_b = cov_ab = math.nan
        else:
            s2 = chi2 / dof
            var_a, var_b, cov_ab = var_a * s2, var_b * s2, cov_ab * s2
    trend = Trend(pts, slope_um_per_year=b, u_slope_um_per_year=math.sqrt(var_b) if math.isfinite(var_b) else None,
                  intercept_um=a, t0=_iso(t0), weights=weights, limit_um=limit_um, steps=steps,
                  chi2_per_dof=chi2 / dof if known and dof > 0 else None)
    if limit_um is None:
        return trend
    crossing, u_days, note = _crossing(a, b, var_a, var_b, cov_ab, limit_um, t0, t[-1])
    return Trend(**{**trend.__dict__, "crossing_date": crossing, "u_crossing_days": u_days, "crossing_note": note})


def _crossing(a: float, b: float, var_a: float, var_b: float, cov_ab: float, limit: float, t0: datetime,
              t_last: float) -> tuple[str | None, float | None, str]:
    """t* = (L − a) / b; u²(t*) = (var a + t*² var b + 2 t* cov(a, b)) / b² (first-order propagation).

    The values are "larger is worse" (straightness, ISO 230-2 deviations): only a rising line reaches
    its limit; one that was past it at the last run already (``t_last``, years from t0) gets its date with
    a note."""
    if not b > 0:
        return None, None, "the value does not grow: the line never reaches the limit"
    t_star = (limit - a) / b
    var_t = (var_a + t_star * t_star * var_b + 2.0 * t_star * cov_ab) / (b * b)
    u_days = math.sqrt(var_t) * DAYS_PER_YEAR if math.isfinite(var_t) and var_t >= 0 else None
    try:
        when = t0 + timedelta(days=t_star * DAYS_PER_YEAR)
    except OverflowError:
        return None, u_days, "the crossing lies beyond the calendar (year 9999)"
    note = "the line was past the limit at the last run already" if t_star <= t_last else ""
    return _iso(when), u_days, note


def find_steps(pts: list[TrendPoint]) -> list[Step]:
    """Consecutive runs (oldest first) whose values differ by more than ``STEP_K`` √(u₁² + u₂²);
    pairs where either uncertainty is unknown are not judged."""
    out = []
    for p, q in zip(pts, pts[1:], strict=False):
        if p.u_um is None or q.u_um is None:
            continue
        u = math.hypot(p.u_um, q.u_um)
        change = q.value_um - p.value_um
        if abs(change) > STEP_K * u:
            out.append(Step(p.run, q.run, q.date, change, u))
    return out
