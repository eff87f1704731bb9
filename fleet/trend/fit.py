"""The trend of one headline value over the runs of a machine axis: weighted least-squares straight line
against time, its slope in µm per year, the date the line reaches a limit, whether the axis is beyond
the limit already, and the steps (jumps against the trend) between runs (docs/fleet.md gives the formulas
and the rules).

Pure arithmetic on a few thousand numbers: no NumPy, so a trend answers as fast as the catalogue does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from functools import lru_cache
from typing import Any

DAYS_PER_YEAR = 365.25  # the Julian year
SECONDS_PER_YEAR = DAYS_PER_YEAR * 86400.0
# A step is a run whose value departs from the line of the runs before it (since the last step) by more than
# k times the combined standard uncertainty of the value and of the prediction. k = 3: a steady axis whose
# runs scatter as their u says flags a false step in 0.27 % of its runs (two-sided normal tail, erfc(3/√2)).
STEP_K = 3.0
# A crossing date needs at least this many runs (two runs fix a line but not its scatter) ...
MIN_RUNS_FOR_DATE = 3
# ... spanning at least this many days: runs within a month tell day-to-day set-up variation, not wear.
MIN_SPAN_DAYS = 30.0
# Values with a sign (the mean reversal B_mean drifts from + to −); the limit then bounds |value|. Every other
# headline value is a magnitude, "larger is worse" (B is the largest |B_i|: a sign change shows as a V).
SIGNED_VALUES = frozenset({"B_mean"})


@dataclass(frozen=True)
class TrendPoint:
    """One run's value: ``date`` (run.json ``created``), ``value_um`` and its standard uncertainty
    ``u_um`` (None: not evaluated); ``path`` is the run directory (its name is the run's name)."""

    run: str
    date: str
    value_um: float
    u_um: float | None
    path: str = ""

    @property
    def name(self) -> str:
        """The run's name: its directory's name (the uid when the path is unknown)."""
        return self.path.replace("\\", "/").rstrip("/").rsplit("/", 1)[-1] or self.run

    def to_dict(self) -> dict[str, Any]:
        return {"run": self.run, "name": self.name, "date": self.date, "value_um": self.value_um, "u_um": self.u_um}


@lru_cache(maxsize=1 << 16)  # a fit parses each date several times; the fleet overview fits thousands of runs
def parse_date(text: str) -> datetime:
    """run.json ``created`` (ISO 8601, UTC when it names no zone) as an aware datetime."""
    when = datetime.fromisoformat(text.replace("Z", "+00:00"))
    return when if when.tzinfo is not None else when.replace(tzinfo=UTC)


def _iso(when: datetime) -> str:
    return when.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


@dataclass(frozen=True)
class Step:
    """A run (``to_run``) whose value departs from the line of the runs before it, since the last step and up
    to ``from_run``, by ``change_um`` = value − ``expected_um``, more than ``STEP_K`` times ``u_um`` =
    √(u² of the value + u² of the prediction)."""

    from_run: str
    to_run: str
    date: str
    change_um: float
    u_um: float
    expected_um: float = math.nan
    to_name: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"from_run": self.from_run, "to_run": self.to_run, "date": self.date, "change_um": self.change_um,
                "u_um": self.u_um, "k": STEP_K, "expected_um": self.expected_um, "to_name": self.to_name}


@dataclass(frozen=True)
class Trend:
    """The fit: ``value(t) = intercept_um + slope_um_per_year * (t - t0)`` with t in years of 365.25 days
    from ``t0`` (the first run); uncertainties are standard (k = 1), scaled by ``u_scale`` = √(χ²/dof) when
    the runs scatter more than their stated uncertainties.  ``beyond_limit``: the newest run's value (its
    magnitude for a signed value) exceeds the limit; ``beyond_since`` is the first run of the unbroken
    stretch of runs beyond it that ends with the newest."""

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
    u_scale: float | None = None
    signed: bool = False
    beyond_limit: bool = False
    beyond_since: TrendPoint | None = None
    beyond_count: int = 0
    step_scale: float | None = None  # c of the step test (scatter_scale); None when steps are not judged

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


def beyond(points: list[TrendPoint], limit_um: float | None, signed: bool = False) -> tuple[TrendPoint | None, int]:
    """The first run of the unbroken stretch of runs (oldest first) beyond ``limit_um`` that ends with the
    newest run, and how many runs it holds; (None, 0) when the newest run is within the limit."""
    if limit_um is None:
        return None, 0
    n = 0
    for p in reversed(points):
        if (abs(p.value_um) if signed else p.value_um) <= limit_um:
            break
        n += 1
    return (points[-n], n) if n else (None, 0)


def fit_trend(points: list[TrendPoint], limit_um: float | None = None, signed: bool = False) -> Trend:
    """The trend of ``points`` (any order; sorted oldest first).

    With every point's uncertainty known, the weights are 1/u² and the slope's uncertainty comes from
    them, scaled by √(χ²/dof) when that exceeds 1 (the runs scatter more than they say); when some are
    missing, all points weigh the same and u is estimated from the scatter about the line
    (s² = Σ r² / (n − 2)), as ordinary least squares does.  The crossing is where the line reaches
    ``limit_um`` (``-limit_um`` too for a ``signed`` value), with its uncertainty propagated from the
    line's (first order, the covariance included); none when the line does not move towards the limit,
    from fewer than ``MIN_RUNS_FOR_DATE`` runs or over less than ``MIN_SPAN_DAYS``."""
    pts = sorted(points, key=lambda p: (parse_date(p.date), p.run))
    steps = find_steps(pts)
    judged = bool(pts) and all(p.u_um is not None and p.u_um > 0 for p in pts)
    since, count = beyond(pts, limit_um, signed)
    base = {"limit_um": limit_um, "steps": steps, "signed": signed, "beyond_limit": since is not None,
            "beyond_since": since, "beyond_count": count, "step_scale": scatter_scale(pts) if judged else None}
    if len(pts) < 2:
        return Trend(pts, crossing_note="a trend needs at least two runs", **base)
    t0 = parse_date(pts[0].date)
    t = [years_between(t0, parse_date(p.date)) for p in pts]
    if max(t) - min(t) <= 0:
        return Trend(pts, crossing_note="all runs have the same date", **base)
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
    u_scale = None
    if dof < 1:
        if not known:
            var_a = var_b = cov_ab = math.nan
    elif not known or chi2 / dof > 1.0:
        # the scatter about the line, not the stated u, sets the uncertainty when it is the larger (Birge ratio)
        s2 = chi2 / dof
        var_a, var_b, cov_ab = var_a * s2, var_b * s2, cov_ab * s2
        if known:
            u_scale = math.sqrt(s2)
    trend = Trend(pts, slope_um_per_year=b, u_slope_um_per_year=math.sqrt(var_b) if math.isfinite(var_b) else None,
                  intercept_um=a, t0=_iso(t0), weights=weights,
                  chi2_per_dof=chi2 / dof if known and dof > 0 else None, u_scale=u_scale, **base)
    if limit_um is None:
        return trend
    span_days = (t[-1] - t[0]) * DAYS_PER_YEAR
    if len(pts) < MIN_RUNS_FOR_DATE:
        note = (f"{len(pts)} runs: a crossing date needs at least {MIN_RUNS_FOR_DATE} (two runs fix a line but not "
                "its scatter)")
        return Trend(**{**trend.__dict__, "crossing_note": note})
    if span_days < MIN_SPAN_DAYS:
        note = (f"the runs span {span_days:.1f} days: a crossing date needs at least {MIN_SPAN_DAYS:g} days between "
                "the first and the newest run (a shorter span shows set-up variation, not wear)")
        return Trend(**{**trend.__dict__, "crossing_note": note})
    crossing, u_days, note = _crossing(a, b, var_a, var_b, cov_ab, limit_um, t0, t[-1], signed)
    return Trend(**{**trend.__dict__, "crossing_date": crossing, "u_crossing_days": u_days, "crossing_note": note})


def _crossing(a: float, b: float, var_a: float, var_b: float, cov_ab: float, limit: float, t0: datetime,
              t_last: float, signed: bool = False) -> tuple[str | None, float | None, str]:
    """t* = (L − a) / b; u²(t*) = (var a + t*² var b + 2 t* cov(a, b)) / b² (first-order propagation).

    The values are "larger is worse" (straightness, ISO 230-2 deviations): only a rising line reaches
    its limit; a ``signed`` value's limit bounds its magnitude: a falling line reaches −L.  A line that was
    past the limit at the last run already (``t_last``, years from t0) gets its date with a note."""
    if signed and b < 0:
        limit = -limit
    elif not b > 0:
        if b < 0 and a + b * t_last > limit:  # beyond the limit and falling: when the line is back within it
            try:
                back = _iso(t0 + timedelta(days=(limit - a) / b * DAYS_PER_YEAR))
            except OverflowError:
                back = "after year 9999"
            return None, None, f"the value falls: the line comes back within the limit on {back[:10]}"
        return None, None, ("the value does not change: the line never reaches the limit" if signed else
                            "the value does not grow: the line never reaches the limit")
    t_star = (limit - a) / b
    var_t = (var_a + t_star * t_star * var_b + 2.0 * t_star * cov_ab) / (b * b)
    u_days = math.sqrt(var_t) * DAYS_PER_YEAR if math.isfinite(var_t) and var_t >= 0 else None
    try:
        when = t0 + timedelta(days=t_star * DAYS_PER_YEAR)
    except OverflowError:
        return None, u_days, "the crossing lies beyond the calendar (year 9999)"
    note = "the line was past the limit at the last run already" if t_star <= t_last else ""
    return _iso(when), u_days, note


def find_steps(pts: list[TrendPoint], k: float = STEP_K) -> list[Step]:
    """Runs (``pts`` oldest first) that jump against the trend: each run is compared with the weighted line of
    the runs before it since the last step (at least two of them, at two different times), and is a step when
    |y − ŷ| > k c √(u² + u²(ŷ)), u²(ŷ) = (S_tt − 2 t S_t + t² S) / (S S_tt − S_t²) from the sums of w = 1/u²,
    w t, w t² of those runs.  Under steady wear (a straight line) with the stated u, y − ŷ is normal with that
    variance, so a false step comes at the two-sided normal tail rate of k.  The run after a step starts a new
    stretch (the axis' new state).  c = :func:`scatter_scale`: runs that scatter more than their stated u
    (set-up variation) are not all steps.  Not judged when a run has no uncertainty."""
    if not pts or not all(p.u_um is not None and p.u_um > 0 for p in pts):
        return []
    t0 = parse_date(pts[0].date)
    return _steps(pts, [years_between(t0, parse_date(p.date)) for p in pts], k, scatter_scale(pts))


def scatter_scale(pts: list[TrendPoint]) -> float:
    """How much more the runs scatter than their stated u, robustly to steps and to the wear:
    c = max(1, 1.4826 MAD(d)), d_i = (y_{i+1} − y_i − b̃ Δt_i) / √(u_i² + u_{i+1}²) over consecutive runs
    (``pts`` oldest first), b̃ the median of (y_{i+1} − y_i) / Δt_i: the wear removed pair by pair, and a step,
    which moves one d, ignored by the medians.  1.4826 MAD estimates a normal standard deviation; 1 with
    fewer than 3 pairs."""
    t0 = parse_date(pts[0].date) if pts else None
    t = [years_between(t0, parse_date(p.date)) for p in pts] if t0 else []
    pairs = [(p, q, tq - tp) for p, q, tp, tq in zip(pts, pts[1:], t, t[1:], strict=False) if tq > tp]
    if len(pairs) < 3:
        return 1.0
    slope = _median([(q.value_um - p.value_um) / dt for p, q, dt in pairs])
    d = [(q.value_um - p.value_um - slope * dt) / math.hypot(float(p.u_um), float(q.u_um))  # type: ignore[arg-type]
         for p, q, dt in pairs]
    centre = _median(d)
    return max(1.0, 1.4826 * _median([abs(x - centre) for x in d]))


def _median(x: list[float]) -> float:
    s = sorted(x)
    n = len(s)
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def _steps(pts: list[TrendPoint], t: list[float], k: float, scale: float) -> list[Step]:
    """The steps of :func:`find_steps` with the uncertainties multiplied by ``scale``."""
    out: list[Step] = []
    start = 0
    s = st = stt = sy = sty = 0.0
    for j, p in enumerate(pts):
        if j - start >= 2:
            tj = t[j] - t[start]  # times from the stretch's first run: small numbers, little cancellation
            det = s * stt - st * st
            if det > 1e-12 * s * stt:
                b = (s * sty - st * sy) / det
                a = (stt * sy - st * sty) / det
                expected = a + b * tj
                var_pred = (stt - 2.0 * tj * st + tj * tj * s) / det
                u = scale * math.sqrt(float(p.u_um) ** 2 + max(var_pred, 0.0))  # type: ignore[arg-type]
                change = p.value_um - expected
                if abs(change) > k * u:
                    out.append(Step(pts[j - 1].run, p.run, p.date, change, u, expected, p.name))
                    start, s, st, stt, sy, sty = j, 0.0, 0.0, 0.0, 0.0, 0.0
        w = 1.0 / float(p.u_um) ** 2  # type: ignore[arg-type]
        tj = t[j] - t[start]
        s, st, stt, sy, sty = s + w, st + w * tj, stt + w * tj * tj, sy + w * p.value_um, sty + w * tj * p.value_um
    return out
