"""``guideway trend``: one headline value over every catalogued run of a machine axis, fitted (fit.py),
as the JSON object and the one-line-per-run text of the command."""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime
from typing import Any, TextIO

from fleet.catalog.clock import future_cutoff, is_future
from fleet.catalog.database import Catalog
from fleet.catalog.runs import list_entries
from saved_runs.errors import UserError

from .fit import MIN_RUNS_FOR_DATE, MIN_SPAN_DAYS, SIGNED_VALUES, STEP_K, Trend, TrendPoint, fit_trend, parse_date

MAGNITUDE_NOTE = {"B": "B is a magnitude (the largest |B_i|): a reversal changing sign shows as a V; "
                       "--value B_mean trends the signed mean reversal"}


@dataclass(frozen=True)
class AxisTrend:
    """The trend of ``value`` on ``machine`` / ``axis`` and where its limit came from."""

    machine: str
    axis: str
    value: str
    unit: str
    trend: Trend
    limit_source: str = ""
    left_out: tuple[str, ...] = ()  # runs not trended, each "uid (why)": not complete, dated in the future

    @property
    def beyond_text(self) -> str:
        """"beyond the limit since run NAME (DATE)..." when the newest run exceeds the limit, else ""."""
        t, p = self.trend, self.trend.beyond_since
        if p is None:
            return ""
        which = "every run" if t.beyond_count == len(t.points) else f"the newest {t.beyond_count} run(s)"
        mag = "|value| " if t.signed else ""
        return f"beyond the limit since run {p.name} ({p.date[:10]}): {which} {mag}above {t.limit_um:g} {self.unit}"

    def to_dict(self) -> dict[str, Any]:
        """The ``guideway trend --json`` object (issue 20's keys, then the fit's details)."""
        t = self.trend
        since = t.beyond_since
        return {"machine": self.machine, "axis": self.axis, "value": self.value,
                "points": [p.to_dict() for p in t.points],
                "slope_um_per_year": t.slope_um_per_year, "u_slope_um_per_year": t.u_slope_um_per_year,
                "limit_um": t.limit_um, "crossing_date": t.crossing_date, "steps": [s.to_dict() for s in t.steps],
                "u_crossing_days": t.u_crossing_days, "crossing_note": t.crossing_note,
                "beyond_limit": t.beyond_limit,
                "beyond_limit_since": None if since is None else {"run": since.run, "name": since.name,
                                                                   "date": since.date},
                "intercept_um": t.intercept_um, "t0": t.t0, "weights": t.weights, "chi2_per_dof": t.chi2_per_dof,
                "u_scaled_by": t.u_scale, "step_scale": t.step_scale, "signed": t.signed,
                "value_note": MAGNITUDE_NOTE.get(self.value, ""),
                "limit_source": self.limit_source, "unit": self.unit, "days_per_year": 365.25,
                "min_runs_for_date": MIN_RUNS_FOR_DATE, "min_span_days": MIN_SPAN_DAYS,
                "left_out": list(self.left_out)}

    def print_text(self, stream: TextIO) -> None:
        t, u = self.trend, self.unit
        kind = "signed values" if t.signed else "values"
        print(f"{self.value} on {self.machine or '(no machine)'} axis {self.axis or '(none)'}: {len(t.points)} run(s), "
              f"{kind} in {u}", file=stream)
        if self.value in MAGNITUDE_NOTE:
            print(f"note: {MAGNITUDE_NOTE[self.value]}", file=stream)
        if self.left_out:
            print(f"left out: {', '.join(self.left_out)}", file=stream)
        stepped = {s.to_run for s in t.steps}
        for p in t.points:
            unc = "" if p.u_um is None else f" ± {p.u_um:.3f}"
            mark = "  <- step" if p.run in stepped else ""
            print(f"  {p.date}  {p.value_um:10.3f}{unc}  {p.name}  {p.run}{mark}", file=stream)
        if t.limit_um is not None and t.beyond_limit:
            print(f"limit {t.limit_um:g} {u} ({self.limit_source}): {self.beyond_text}", file=stream)
        if t.slope_um_per_year is None:
            print(f"trend: none ({t.crossing_note})", file=stream)
            return
        us = "?" if t.u_slope_um_per_year is None else f"{t.u_slope_um_per_year:.3f}"
        print(f"trend: {t.slope_um_per_year:+.3f} ± {us} {u}/year (u, k = 1; weights {t.weights})", file=stream)
        if t.u_scale is not None:
            print(f"  u scaled by √(χ²/dof) = {t.u_scale:.2f}: the runs scatter about the line more than their "
                  "stated uncertainties", file=stream)
        if t.limit_um is not None:
            note = f" ({t.crossing_note})" if t.crossing_note else ""
            if t.crossing_date is not None:
                ud = f" ± {t.u_crossing_days:.0f} days" if t.u_crossing_days is not None else ""
                print(f"limit {t.limit_um:g} {u} ({self.limit_source}): the line reaches it {t.crossing_date}{ud}"
                      f"{note}", file=stream)
            else:
                print(f"limit {t.limit_um:g} {u} ({self.limit_source}): no crossing date{note}", file=stream)
        scaled = (f" (u x {t.step_scale:.1f}: the runs scatter more than their u)"
                  if t.step_scale is not None and t.step_scale > 1 else "")
        for s in t.steps:
            print(f"step: run {s.to_name or s.to_run} ({s.date}) {s.change_um:+.3f} {u} off the line of the runs "
                  f"before it ({s.expected_um:.3f}), more than {STEP_K:g} x {s.u_um:.3f} {u}{scaled}", file=stream)


def axis_trend(cat: Catalog, machine: str, axis: str, value: str, limit_um: float | None = None,
               now: datetime | None = None) -> AxisTrend:
    """The trend of ``value`` over the catalogued runs of ``machine`` / ``axis`` (runs without the value,
    runs not complete, and runs dated later than ``now`` (default the clock) + 1 day are left out); the limit
    is ``limit_um``, else the newest run's ``[tolerance]`` on that value."""
    if limit_um is not None and not (math.isfinite(limit_um) and limit_um > 0):
        raise UserError(f"--limit must be a positive number, got {limit_um}")
    entries = list_entries(cat, machine=machine, axis=axis, oldest_first=True)
    if not entries:
        raise UserError(f"no catalogued run of machine {machine!r} axis {axis!r} in {cat.url}; see guideway catalog "
                        "list (add runs with guideway catalog add)")
    points: list[TrendPoint] = []
    left_out: list[str] = []
    unit, limit, source = "um", None, ""
    cutoff = future_cutoff(now)
    for e in entries:
        v = e.values.get(value)
        if not v:
            continue
        if e.status != "complete":  # an aborted run's E over half the axis is no point of the axis' trend
            left_out.append(f"{e.uid} ({e.status or 'no status'})")
            continue
        try:
            parse_date(e.created)
        except ValueError:  # the trend places each run in time: a run without a readable time has no place
            raise UserError(f"run {e.uid} ({e.path}) has created {e.created!r}, not an ISO 8601 time; correct "
                            "created in its run.json and add it again (guideway catalog add), or remove it from the "
                            "catalogue (guideway catalog remove)") from None
        if is_future(e.created, now):  # a rig clock at 2099: its far date would flatten the line
            left_out.append(f"{e.uid} (created {e.created}, in the future: later than "
                            f"{cutoff.strftime('%Y-%m-%dT%H:%M:%SZ')}; check the rig's clock)")
            continue
        unit = "arcsec" if "value_arcsec" in v else "um"
        points.append(TrendPoint(e.uid, e.created, float(v[f"value_{unit}"]), v.get(f"u_{unit}"), e.path))
        if v.get(f"limit_{unit}") is not None:
            limit, source = float(v[f"limit_{unit}"]), f"[tolerance] of run {e.uid}"
    if not points and left_out:
        raise UserError(f"no complete run of machine {machine!r} axis {axis!r} dated up to now has a value "
                        f"{value!r}; left out: {', '.join(left_out)}")
    if not points:
        names = sorted({n for e in entries for n in e.values})
        hint = ("; runs catalogued before B_mean was recorded lack it: guideway catalog remove RUN, then add it "
                "again" if value == "B_mean" else "")
        raise UserError(f"no run of machine {machine!r} axis {axis!r} has a value {value!r}; "
                        f"its runs have: {', '.join(names) or 'no evaluated value'}{hint}")
    if limit_um is not None:
        limit, source = limit_um, "--limit"
    return AxisTrend(machine, axis, value, unit, fit_trend(points, limit, signed=value in SIGNED_VALUES), source,
                     tuple(left_out))
