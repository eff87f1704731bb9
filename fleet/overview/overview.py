"""``guideway fleet``: one row per machine, axis and tolerance value of the catalogue, with its latest complete
run, that run's verdict, the trend of the value (fleet/trend/fit.py: the same fit, rules and crossing date as
``guideway trend``), the last step and the compensation state, sorted by urgency; the calibrations that are
due (machine axes by their interval, instruments by their certificates' due dates).

Every entry is read with one query (ordered by machine, axis and time), the tolerances and intervals with one
each; the rest is arithmetic in this process.  docs/fleet.md gives the rules.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from datetime import UTC, date, datetime, timedelta
from pathlib import Path
from typing import Any

import sqlalchemy as sa

from fleet.catalog.browse import DEFAULT_TREND_VALUE
from fleet.catalog.clock import future_cutoff
from fleet.catalog.database import Catalog, runs_table
from fleet.catalog.entry import Entry, run_facts
from fleet.catalog.settings import Interval, Tolerance, list_intervals, list_tolerances
from fleet.trend.fit import SIGNED_VALUES, Step, Trend, TrendPoint, fit_trend, parse_date
from saved_runs.errors import UserError
from saved_runs.store.files import read_run_file

COVERAGE_K = 2.0  # the expanded uncertainty U shown beside a run's value: k = 2 times the entry's standard u
AS_EVALUATED = "as evaluated"  # the decision rule of a verdict whose evaluation does not name one
NOT_RECORDED = "not recorded"


@dataclass(frozen=True)
class RunRef:
    """The latest complete run of a row: uid, directory, ``created`` (UTC) and operator."""

    uid: str
    path: str
    date: str
    operator: str

    @property
    def name(self) -> str:
        return self.path.replace("\\", "/").rstrip("/").rsplit("/", 1)[-1] or self.uid

    def to_dict(self) -> dict[str, Any]:
        return {"uid": self.uid, "name": self.name, "path": self.path, "date": self.date, "operator": self.operator}


@dataclass(frozen=True)
class FleetRow:
    """One machine, axis and value: its latest complete run and that run's value, verdict and compensation
    state; the trend of the value over the axis' complete runs; when the axis is due for calibration."""

    machine: str
    axis: str
    value: str
    unit: str = "um"
    limit_um: float | None = None
    limit_source: str = ""  # "catalogue", "[tolerance] of run NAME", or "" (no limit)
    run: RunRef | None = None
    value_um: float | None = None
    u_um: float | None = None  # standard uncertainty of the value (k = 1)
    verdict: str | None = None
    decision_rule: str = AS_EVALUATED
    trend: Trend | None = None
    compensation: dict[str, Any] = field(default_factory=lambda: {"active": None})
    interval_days: float | None = None
    calibration_due: str | None = None  # the latest run of the axis (any value) + its interval, UTC
    overdue: bool = False  # calibration_due has passed

    @property
    def expanded_u_um(self) -> float | None:
        return None if self.u_um is None else COVERAGE_K * self.u_um

    @property
    def beyond(self) -> bool:
        return self.trend is not None and self.trend.beyond_limit

    @property
    def crossing_date(self) -> str | None:
        return None if self.trend is None else self.trend.crossing_date

    @property
    def last_step(self) -> Step | None:
        return self.trend.steps[-1] if self.trend is not None and self.trend.steps else None

    def urgency(self) -> tuple[Any, ...]:
        """Beyond the limit first (the longest beyond first), then by crossing date (soonest first), then by
        the age of the last run (oldest first); a row without a run is the oldest."""
        last = self.run.date if self.run else ""
        if self.beyond and self.trend is not None and self.trend.beyond_since is not None:
            return (0, self.trend.beyond_since.date, last, self.machine, self.axis, self.value)
        if self.crossing_date is not None:
            return (1, self.crossing_date, last, self.machine, self.axis, self.value)
        return (2, last, "", self.machine, self.axis, self.value)

    def compensation_text(self) -> str:
        return compensation_state(self.compensation)

    def to_dict(self) -> dict[str, Any]:
        """The object of a row in ``guideway fleet --json``."""
        t = self.trend
        since = t.beyond_since if t is not None else None
        step = self.last_step
        return {"machine": self.machine, "axis": self.axis, "value": self.value, "unit": self.unit,
                "limit_um": self.limit_um, "limit_source": self.limit_source,
                "run": None if self.run is None else self.run.to_dict(),
                "value_um": self.value_um, "u_um": self.u_um, "U_um": self.expanded_u_um, "k": COVERAGE_K,
                "verdict": self.verdict, "decision_rule": self.decision_rule,
                "runs": 0 if t is None else len(t.points),
                "slope_um_per_year": None if t is None else t.slope_um_per_year,
                "u_slope_um_per_year": None if t is None else t.u_slope_um_per_year,
                "crossing_date": self.crossing_date, "u_crossing_days": None if t is None else t.u_crossing_days,
                "crossing_note": "" if t is None else t.crossing_note,
                "beyond_limit": self.beyond,
                "beyond_limit_since": None if since is None else {"run": since.run, "name": since.name,
                                                                   "date": since.date},
                "last_step": None if step is None else {"run": step.to_run, "name": step.to_name, "date": step.date,
                                                        "change_um": step.change_um, "u_um": step.u_um},
                "compensation": {**self.compensation, "state": self.compensation_text()},
                "interval_days": self.interval_days, "calibration_due": self.calibration_due,
                "overdue": self.overdue}


@dataclass(frozen=True)
class InstrumentDue:
    """An instrument's latest calibration record (``[[instrument]]``: role, model, serial, certificate,
    calibrated, due) as the newest run that used it states it."""

    record: dict[str, str]
    run: RunRef
    machine: str
    due: date | None  # None: no due date, or one that is not a date

    @property
    def label(self) -> str:
        r = self.record
        what = " ".join(x for x in (r.get("model", ""), r.get("serial", "")) if x) or r.get("certificate", "?")
        return f"{r['role']} {what}" if r.get("role") else what

    def to_dict(self) -> dict[str, Any]:
        return {**{k: self.record.get(k) for k in ("role", "model", "serial", "certificate", "calibrated", "due")},
                "due_date": None if self.due is None else self.due.isoformat(), "last_run": self.run.to_dict(),
                "machine": self.machine}


@dataclass(frozen=True)
class Attention:
    """One thing that needs attention within the days asked: ``what`` (beyond, fail, crossing, overdue, due,
    instrument), when (``when``: UTC date text) and the line ``fleet check`` prints."""

    rank: int
    when: str
    what: str
    line: str


@dataclass(frozen=True)
class Overview:
    """The rows sorted by urgency, the instruments (soonest due first), and ``now`` of the computation."""

    rows: list[FleetRow]
    instruments: list[InstrumentDue]
    now: datetime
    url: str = ""
    left_out: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"catalog": self.url, "now": _iso(self.now), "rows": [r.to_dict() for r in self.rows],
                "instruments": [i.to_dict() for i in self.instruments], "left_out": self.left_out}

    def attention(self, within_days: float) -> list[Attention]:
        """What needs attention within ``within_days`` of now, most urgent first: rows beyond the limit and
        latest runs that failed (the longest ago first), then whatever falls due (crossing dates, axis
        calibrations, instrument calibrations) by its date."""
        horizon = self.now + timedelta(days=within_days)
        out: list[Attention] = []
        due_axes: set[tuple[str, str]] = set()
        for r in self.rows:
            where = f"{r.machine or '-'} {r.axis or '-'} {r.value}"
            t = r.trend
            if r.beyond and t is not None and t.beyond_since is not None:
                out.append(Attention(0, t.beyond_since.date, "beyond", f"BEYOND   {where}: {r.value_um:.3f} {r.unit} "
                                     f"above the limit {r.limit_um:g} {r.unit} ({r.limit_source}) since run "
                                     f"{t.beyond_since.name} ({t.beyond_since.date[:10]})"))
            elif r.verdict == "fail" and r.run is not None:
                out.append(Attention(0, r.run.date, "fail", f"FAIL     {where}: the latest run {r.run.name} "
                                     f"({r.run.date[:10]}) failed its tolerance (decision rule {r.decision_rule})"))
            elif r.crossing_date is not None and parse_date(r.crossing_date) <= horizon and t is not None:
                ud = f" ± {t.u_crossing_days:.0f} days" if t.u_crossing_days is not None else ""
                out.append(Attention(1, r.crossing_date, "crossing", f"LIMIT    {where}: the trend reaches "
                                     f"{r.limit_um:g} {r.unit} on {r.crossing_date[:10]}{ud} "
                                     f"({t.slope_um_per_year:+.3f} {r.unit}/year)"))
            if (r.calibration_due is not None and (r.machine, r.axis) not in due_axes
                    and parse_date(r.calibration_due) <= horizon):
                due_axes.add((r.machine, r.axis))
                last = f"last run {r.run.date[:10]}" if r.run else "no complete run"
                word = "OVERDUE " if r.overdue else "DUE     "
                out.append(Attention(1, r.calibration_due, "overdue" if r.overdue else "due",
                                     f"{word} {r.machine or '-'} {r.axis or '-'}: calibration due "
                                     f"{r.calibration_due[:10]} ({last}, interval {r.interval_days:g} days)"))
        for i in self.instruments:
            if i.due is None and i.record.get("due"):
                out.append(Attention(0, i.run.date, "instrument", f"INSTRUMENT {i.label}: due date "
                                     f"{i.record.get('due', '(none)')!r} is not a date (YYYY-MM-DD); as stated "
                                     f"by run {i.run.name}"))
            elif i.due is not None and datetime.combine(i.due, datetime.min.time(), UTC) <= horizon:
                word = "overdue since" if datetime.combine(i.due, datetime.min.time(), UTC) < self.now else "due"
                cert = f", certificate {i.record['certificate']}" if i.record.get("certificate") else ""
                out.append(Attention(1, i.due.isoformat(), "instrument", f"INSTRUMENT {i.label}: calibration "
                                     f"{word} {i.due.isoformat()}{cert} (last used in run {i.run.name} on "
                                     f"{i.machine or '-'}, {i.run.date[:10]})"))
        return sorted(out, key=lambda a: (a.rank, a.when, a.line))


def _iso(when: datetime) -> str:
    return when.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def compensation_state(rec: dict[str, Any]) -> str:
    """``active FILE (sha256 …)``, ``none`` or ``not recorded`` (a run from before runs recorded it)."""
    if rec.get("active") is None:
        return NOT_RECORDED
    if not rec.get("active"):
        return "none"
    return f"active {rec.get('file') or '?'} (sha256 {rec.get('sha256') or '?'})"


def _facts(e: Entry) -> dict[str, Any]:
    """The entry's facts; for an entry of an older schema, read from run.json at its path (what it says now;
    nothing known when the directory is gone)."""
    if e.facts is not None:
        return e.facts
    try:
        meta = json.loads(read_run_file(Path(e.path) / "run.json"))
        if isinstance(meta, dict) and meta.get("uid") == e.uid:
            return run_facts(meta)
    except (OSError, ValueError, UserError):  # UserError: not a regular file (a FIFO)
        pass
    return {"operator": "", "compensation": {"active": None}, "instruments": [], "decision_rule": None}


def _due_date(text: str) -> date | None:
    try:
        return date.fromisoformat(text.strip()[:10])
    except ValueError:
        return None


def _unit(v: dict[str, Any]) -> str:
    return "arcsec" if "value_arcsec" in v else "um"


class CatalogRun:
    """An entry as the overview reads it: the columns it needs, the values parsed, the facts parsed when asked
    for (only the latest runs' facts are read: parsing 10,000 of them would cost the overview its second)."""

    __slots__ = ("uid", "path", "machine", "axis", "kind", "created", "status", "verdict", "values", "_facts_json",
                 "_facts")

    def __init__(self, row: Any) -> None:
        self.uid, self.path, self.machine, self.axis, self.kind, self.created, self.status, self.verdict = row[:8]
        self.values: dict[str, dict[str, Any]] = json.loads(row[8])
        self._facts_json: str | None = row[9]
        self._facts: dict[str, Any] | None = None

    @property
    def facts(self) -> dict[str, Any] | None:
        if self._facts is None and self._facts_json:
            self._facts = json.loads(self._facts_json)
        return self._facts


def read_entries(cat: Catalog, machine: str | None = None) -> list[CatalogRun]:
    """Every entry (of ``machine``), by machine, axis and time: one query, of the columns the overview needs."""
    t = runs_table
    q = sa.select(t.c.uid, t.c.path, t.c.machine, t.c.axis, t.c.kind, t.c.created, t.c.status, t.c.verdict,
                  t.c.values_json, t.c.facts_json).order_by(t.c.machine, t.c.axis, t.c.created, t.c.uid)
    if machine is not None:
        q = q.where(t.c.machine == machine)
    with cat.engine.connect() as conn:
        return [CatalogRun(r) for r in conn.execute(q)]


def fleet_overview(cat: Catalog, machine: str | None = None, now: datetime | None = None) -> Overview:
    """The overview of the catalogue ``cat`` (of one ``machine``), as of ``now`` (default: the clock)."""
    now = now or datetime.now(UTC)
    return build_overview(read_entries(cat, machine), list_tolerances(cat, machine), list_intervals(cat, machine),
                          now, cat.url)


def build_overview(entries: Iterable[Entry], tolerances: Iterable[Tolerance], intervals: Iterable[Interval],
                   now: datetime, url: str = "") -> Overview:
    """The rows and instruments of ``entries`` (any order) with the catalogue's ``tolerances`` and
    ``intervals``, as of ``now``.  Runs that are not complete, dated later than now + 1 day, or without a
    readable ``created`` take no part in a row (named in ``left_out`` when they are not complete or dated)."""
    cutoff = future_cutoff(now)
    groups: dict[tuple[str, str], list[tuple[datetime, Entry]]] = {}
    left_out: list[str] = []
    all_runs: list[tuple[datetime, Entry]] = []
    for e in entries:
        groups.setdefault((e.machine, e.axis), [])
        try:
            when = parse_date(e.created)
        except ValueError:
            left_out.append(f"{e.uid} (created {e.created!r} is not a time)")
            continue
        if when > cutoff:
            left_out.append(f"{e.uid} (created {e.created}, in the future)")
            continue
        all_runs.append((when, e))
        if e.status == "complete":
            groups[(e.machine, e.axis)].append((when, e))
        else:  # an aborted run's values cover only the points it had
            left_out.append(f"{e.uid} ({e.status or 'no status'})")
    tol: dict[tuple[str, str], dict[str, float]] = {}
    for t in tolerances:
        tol.setdefault((t.machine, t.axis), {})[t.value] = t.limit_um
        groups.setdefault((t.machine, t.axis), [])
    ivl = {(i.machine, i.axis): i.days for i in intervals}
    for key in ivl:
        groups.setdefault(key, [])
    rows: list[FleetRow] = []
    for (machine, axis), runs in groups.items():
        runs.sort(key=lambda we: (we[0], we[1].uid))
        rows += _axis_rows(machine, axis, runs, tol.get((machine, axis), {}), ivl.get((machine, axis)), now)
    rows.sort(key=FleetRow.urgency)
    return Overview(rows, _instruments(all_runs), now, url, left_out)


def _axis_rows(machine: str, axis: str, runs: list[tuple[datetime, Entry]], tolerances: dict[str, float],
               interval_days: float | None, now: datetime) -> list[FleetRow]:
    """The rows of one machine axis (``runs``: its complete runs, oldest first)."""
    # the values with a limit: the catalogue's, then those the newest run of each kind with a [tolerance] limits;
    # a kind with neither shows its first headline value (no limit)
    limits: dict[str, tuple[float, str]] = {v: (lim, "catalogue") for v, lim in tolerances.items()}
    kinds: list[str] = []  # the kinds of run of the axis, newest first
    limited_kinds: set[str] = set()
    for _, e in reversed(runs):
        if e.kind not in kinds:
            kinds.append(e.kind)
        if e.kind in limited_kinds:
            continue
        limited = {n: v for n, v in e.values.items() if v.get(f"limit_{_unit(v)}") is not None}
        if limited:  # the newest run of its kind with a [tolerance]: its limits
            limited_kinds.add(e.kind)
            name = RunRef(e.uid, e.path, "", "").name
            for n, v in limited.items():
                limits.setdefault(n, (float(v[f"limit_{_unit(v)}"]), f"[tolerance] of run {name}"))
    values: list[str] = list(limits)
    for kind in kinds:
        first = DEFAULT_TREND_VALUE.get(kind)
        if first and not any(_kind_has(runs, kind, v) for v in values) and first not in values:
            values.append(first)
    last_when = runs[-1][0] if runs else None
    due = None if interval_days is None or last_when is None else last_when + timedelta(days=interval_days)
    rows = []
    for value in values:
        points: list[TrendPoint] = []
        latest: Entry | None = None
        unit = "um"
        for _, e in runs:
            v = e.values.get(value)
            if not v:
                continue
            unit = _unit(v)
            points.append(TrendPoint(e.uid, e.created, float(v[f"value_{unit}"]), v.get(f"u_{unit}"), e.path))
            latest = e
        limit, source = limits.get(value, (None, ""))
        trend = fit_trend(points, limit, signed=value in SIGNED_VALUES) if points else None
        common = {"machine": machine, "axis": axis, "value": value, "limit_um": limit, "limit_source": source,
                  "trend": trend, "interval_days": interval_days,
                  "calibration_due": None if due is None else _iso(due), "overdue": due is not None and due < now}
        if interval_days is not None and last_when is None:  # an interval and no complete run: due now
            common.update(calibration_due=_iso(now), overdue=True)
        if latest is None:
            rows.append(FleetRow(**common))
            continue
        facts = _facts(latest)
        v = latest.values[value]
        rows.append(FleetRow(**common, unit=unit,
                             run=RunRef(latest.uid, latest.path, latest.created, str(facts.get("operator") or "")),
                             value_um=float(v[f"value_{unit}"]), u_um=v.get(f"u_{unit}"), verdict=latest.verdict,
                             decision_rule=str(facts.get("decision_rule") or AS_EVALUATED),
                             compensation=dict(facts.get("compensation") or {"active": None})))
    return rows


def _kind_has(runs: list[tuple[datetime, Entry]], kind: str, value: str) -> bool:
    return any(e.kind == kind and value in e.values for _, e in runs)


def _instruments(runs: list[tuple[datetime, Entry]]) -> list[InstrumentDue]:
    """Each instrument (by model and serial, else role, model and certificate) as the newest run that records
    it states its calibration, among the latest run of each machine axis and kind (the instruments in use: an
    instrument only older runs of an axis record has been replaced on it); an unreadable due date first, then
    the soonest due, those without one last."""
    latest: dict[tuple[str, str, str], tuple[datetime, Entry]] = {}
    for when, e in runs:
        key = (e.machine, e.axis, e.kind)
        if key not in latest or (when, e.uid) > (latest[key][0], latest[key][1].uid):
            latest[key] = (when, e)
    newest: dict[tuple[str, ...], InstrumentDue] = {}
    for _, e in sorted(latest.values(), key=lambda we: (we[0], we[1].uid)):
        facts = _facts(e)
        for rec in facts.get("instruments") or []:
            key = (rec.get("model", ""), rec.get("serial", "")) if rec.get("serial") else \
                (rec.get("role", ""), rec.get("model", ""), rec.get("certificate", ""))
            newest[key] = InstrumentDue(rec, RunRef(e.uid, e.path, e.created, str(facts.get("operator") or "")),
                                        e.machine, _due_date(rec["due"]) if rec.get("due") else None)

    def order(i: InstrumentDue) -> tuple[int, date, str]:
        return (1, i.due, i.label) if i.due is not None else (0 if i.record.get("due") else 2, date.min, i.label)

    return sorted(newest.values(), key=order)


def finite(x: float | None) -> bool:
    return x is not None and math.isfinite(x)
