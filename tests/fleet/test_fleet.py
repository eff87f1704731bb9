"""``guideway fleet``: a fleet of 50+ machines x 3 axes x five years of runs built here, on SQLite and on a
PostgreSQL server; the urgency order and every crossing date against an independent computation (NumPy
weighted least squares written here), ``fleet check``'s exit codes, the CSV header, the JSON keys, and a few
real run directories end to end (operator, compensation state, instrument calibrations)."""

from __future__ import annotations

import csv
import io
import json
import os
import uuid
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from fleet.catalog.database import open_catalog
from fleet.catalog.entry import Entry
from fleet.catalog.runs import write_entries
from fleet.catalog.settings import set_tolerance
from fleet.overview.overview import fleet_overview
from tests.cli import guideway, one_line_error

from .runs import straightness_summary, write_run

NOW = datetime(2026, 11, 1, tzinfo=UTC)
DAYS_PER_YEAR = 365.25


def iso(d: datetime) -> str:
    return d.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


@dataclass
class Axis:
    """What the test made of one machine axis: its runs (date, value, u, status) and limits."""

    machine: str
    axis: str
    kind: str
    value: str
    runs: list[tuple[datetime, float, float | None, str]] = field(default_factory=list)
    run_limit: float | None = None  # the runs' [tolerance]
    catalogue_limit: float | None = None  # guideway catalog tolerance

    @property
    def limit(self) -> float | None:
        return self.catalogue_limit if self.catalogue_limit is not None else self.run_limit


def build_fleet(seed: int = 29) -> list[Axis]:
    """52 machines x 3 axes, runs every quarter (± 20 days) from 2021 to 2026 with wear from -0.3 to +1.5 µm
    per year: some beyond their limit, some reaching it soon, some short histories (2 runs; 4 runs within
    20 days), aborted and future-dated runs, two machines measured by positioning (no u: equal weights)."""
    rng = np.random.default_rng(seed)
    axes = []
    for m in range(52):
        for a in "XYZ":
            kind = "positioning" if m in (7, 8) else "straightness"
            ax = Axis(f"mc-{m:02d}", a, kind, "E" if kind == "positioning" else "minimum_zone")
            start = datetime(2021, 1, 15, tzinfo=UTC) + timedelta(days=int(rng.integers(0, 400)))
            slope = float(rng.uniform(-0.3, 1.5))
            y0 = float(rng.uniform(2.0, 6.0))
            n = int(rng.integers(8, 22))
            dates = [(start + timedelta(days=91.3 * i + float(rng.uniform(-20, 20)))).replace(microsecond=0)
                     for i in range(n)]
            if m == 3 and a == "X":  # two runs: no crossing date
                dates = dates[:2]
            if m == 4 and a == "Y":  # four runs within 20 days: no crossing date
                dates = [NOW - timedelta(days=100 - 5 * i) for i in range(4)]
            dates = [d for d in dates if d < NOW - timedelta(days=2)]
            for d in dates:
                t = (d - dates[0]).total_seconds() / 86400 / DAYS_PER_YEAR
                u = None if kind == "positioning" else float(rng.uniform(0.08, 0.3))
                y = y0 + slope * t + float(rng.normal(0, u if u else 0.2))
                ax.runs.append((d, y, u, "complete"))
            if m == 5 and a == "Z" and len(ax.runs) > 6:  # a jump of 30 u: a step at the 6th run on
                ax.runs[5:] = [(d, y + 30 * (u or 0.2), u, s) for d, y, u, s in ax.runs[5:]]
            newest = ax.runs[-1][1]
            # limits around the newest values: about one axis in five beyond it, many reached within years
            ax.run_limit = round(newest + float(rng.uniform(-1.0, 4.0)), 1)
            if m % 10 == 9:  # the catalogue's tolerance replaces the runs' own
                ax.catalogue_limit = round(newest + float(rng.uniform(-0.5, 2.0)), 1)
            if m == 6:  # an aborted run (left out) and a run dated 2099 (left out)
                ax.runs.append((NOW - timedelta(days=1), 99.0, 0.1, "aborted"))
                ax.runs.append((datetime(2099, 1, 1, tzinfo=UTC), 0.1, 0.1, "complete"))
            axes.append(ax)
    return axes


def entries_of(axes: list[Axis]) -> list[Entry]:
    out = []
    for ax in axes:
        for i, (d, y, u, status) in enumerate(ax.runs):
            v: dict[str, float | None] = {"value_um": y, "u_um": u}
            if ax.run_limit is not None:
                v["limit_um"] = ax.run_limit
            out.append(Entry(uid=uuid.uuid4().hex, path=f"/archive/{ax.machine}/{ax.axis}/run-{i:02d}",
                             machine=ax.machine, axis=ax.axis, kind=ax.kind, created=iso(d), status=status,
                             content_hash="0" * 64, values={ax.value: v}, verdict="pass",
                             facts={"operator": f"op-{i % 3}", "compensation": {"active": False}, "instruments": [],
                                    "decision_rule": None}))
    return out


def expected_row(ax: Axis) -> dict:
    """The row of ``ax`` computed here: weighted least squares by NumPy's lstsq on √w-scaled equations, the
    covariance (AᵀWA)⁻¹ scaled by χ²/dof when above 1 (by s² when no u is known), the crossing
    t* = (L − a)/b with u(t*) by the Jacobian (−1/b, −t*/b) of (a, b)."""
    runs = [(d, y, u) for d, y, u, s in ax.runs if s == "complete" and d <= NOW + timedelta(days=1)]
    d0 = runs[0][0]
    t = np.array([(d - d0).total_seconds() / 86400 / DAYS_PER_YEAR for d, _, _ in runs])
    y = np.array([r[1] for r in runs])
    known = all(r[2] is not None for r in runs)
    u = np.array([r[2] for r in runs], dtype=float) if known else np.ones(len(runs))
    limit = ax.limit
    out = {"last": iso(runs[-1][0]), "beyond_since": None, "crossing": None, "u_days": None, "slope": None}
    n_beyond = 0
    for _, yi, _ in reversed(runs):
        if yi <= limit:
            break
        n_beyond += 1
    if n_beyond:
        out["beyond_since"] = iso(runs[-n_beyond][0])
    if len(runs) < 2:
        return out
    a_mat = np.column_stack([np.ones_like(t), t]) / u[:, None]
    coef, *_ = np.linalg.lstsq(a_mat, y / u, rcond=None)
    a, b = coef
    cov = np.linalg.inv(a_mat.T @ a_mat)
    dof = len(runs) - 2
    chi2 = float(np.sum(((y - a - b * t) / u) ** 2))
    if dof >= 1 and (not known or chi2 / dof > 1):
        cov = cov * chi2 / dof
    out["slope"] = float(b)
    span_days = (t[-1] - t[0]) * DAYS_PER_YEAR
    if len(runs) >= 3 and span_days >= 30 and b > 0:
        t_star = (limit - a) / b
        jac = np.array([-1 / b, -t_star / b])
        out["crossing"] = d0 + timedelta(days=float(t_star) * DAYS_PER_YEAR)
        out["u_days"] = float(np.sqrt(jac @ cov @ jac)) * DAYS_PER_YEAR
    return out


def expected_order(axes: list[Axis]) -> list[tuple[str, str, str]]:
    """Beyond the limit first (longest beyond first), then by crossing date, then by the age of the last run."""
    keys = []
    for ax in axes:
        e = expected_row(ax)
        if e["beyond_since"] is not None:
            k = (0, e["beyond_since"], e["last"])
        elif e["crossing"] is not None:
            k = (1, iso(e["crossing"]), e["last"])
        else:
            k = (2, e["last"], "")
        keys.append((*k, ax.machine, ax.axis, ax.value))
    return [k[3:] for k in sorted(keys)]


def write_fleet(url: str, axes: list[Axis]) -> None:
    with open_catalog(url) as cat:
        write_entries(cat, entries_of(axes))
        for ax in axes:
            if ax.catalogue_limit is not None:
                set_tolerance(cat, ax.machine, ax.axis, ax.value, ax.catalogue_limit)


def test_fleet_order_and_crossing_dates_against_numpy(catalog_url: str) -> None:
    axes = build_fleet()
    assert len({a.machine for a in axes}) >= 50 and sum(len(a.runs) for a in axes) > 2000
    write_fleet(catalog_url, axes)
    import sqlalchemy as sa

    statements: list[str] = []
    with open_catalog(catalog_url, create=False) as cat:
        sa.event.listen(cat.engine, "before_cursor_execute", lambda c, cur, stmt, *a: statements.append(stmt))
        ov = fleet_overview(cat, now=NOW)
    assert sum("FROM guideway_runs" in s for s in statements) == 1, statements  # one query for all entries
    assert [(r.machine, r.axis, r.value) for r in ov.rows] == expected_order(axes)
    by_key = {(r.machine, r.axis, r.value): r for r in ov.rows}
    kinds = {"beyond": 0, "dated": 0, "undated": 0}
    for ax in axes:
        r, e = by_key[(ax.machine, ax.axis, ax.value)], expected_row(ax)
        assert r.limit_um == ax.limit
        assert r.limit_source == ("catalogue" if ax.catalogue_limit is not None else "[tolerance] of run run-"
                                  f"{len([x for x in ax.runs if x[3] == 'complete' and x[0] < NOW]) - 1:02d}")
        assert r.run is not None and r.run.date == e["last"]
        assert r.run.operator.startswith("op-") and r.compensation_text() == "none" and r.verdict == "pass"
        assert r.beyond == (e["beyond_since"] is not None)
        if e["beyond_since"] is not None:
            kinds["beyond"] += 1
            assert r.trend.beyond_since.date == e["beyond_since"]
        if e["crossing"] is None:
            kinds["undated"] += 1
            assert r.crossing_date is None, (ax.machine, ax.axis, r.trend.crossing_note)
        else:
            kinds["dated"] += 1
            got = datetime.fromisoformat(r.crossing_date.replace("Z", "+00:00"))
            assert abs((got - e["crossing"]).total_seconds()) <= 1.0
            assert r.trend.u_crossing_days == pytest.approx(e["u_days"], rel=1e-6)
        assert r.trend.slope_um_per_year == pytest.approx(e["slope"], rel=1e-9, abs=1e-12)
    assert min(kinds.values()) >= 5, kinds  # the fleet exercises every group of the order
    # the planted step, the runs left out, and the short histories
    stepped = by_key[("mc-05", "Z", "minimum_zone")]
    assert iso(axes[3 * 5 + 2].runs[5][0]) in [s.date for s in stepped.trend.steps]
    assert stepped.last_step == stepped.trend.steps[-1] and stepped.to_dict()["last_step"]["date"] == \
        stepped.trend.steps[-1].date
    assert len(ov.left_out) == 6  # 3 aborted + 3 future-dated runs of mc-06
    assert "2 runs" in by_key[("mc-03", "X", "minimum_zone")].trend.crossing_note
    assert "span" in by_key[("mc-04", "Y", "minimum_zone")].trend.crossing_note
    # the command gives the same order (with the clock's now: every run is in the past)
    res = guideway("fleet", "--json", "--catalog", catalog_url)
    assert res.returncode == 0, res.stderr
    rows = json.loads(res.stdout)["rows"]
    assert [(r["machine"], r["axis"], r["value"]) for r in rows] == expected_order(axes)


def test_one_machine_and_the_catalogue_tolerance_commands(catalog_url: str) -> None:
    axes = [a for a in build_fleet() if a.machine in ("mc-01", "mc-02")]
    write_fleet(catalog_url, axes)
    res = guideway("fleet", "--machine", "mc-02", "--json", "--catalog", catalog_url)
    assert res.returncode == 0, res.stderr
    assert {r["machine"] for r in json.loads(res.stdout)["rows"]} == {"mc-02"}
    # a tolerance kept in the catalogue replaces the runs' own; removed, the runs' applies again
    res = guideway("catalog", "tolerance", "--machine", "mc-02", "--axis", "X", "--value", "minimum_zone",
                   "--limit", "0.5", "--catalog", catalog_url)
    assert res.returncode == 0, res.stderr
    listed = json.loads(guideway("catalog", "tolerance", "--list", "--json", "--catalog", catalog_url).stdout)
    assert [(t["machine"], t["axis"], t["value"], t["limit_um"]) for t in listed["tolerances"]] == [
        ("mc-02", "X", "minimum_zone", 0.5)]
    rows = json.loads(guideway("fleet", "--machine", "mc-02", "--json", "--catalog", catalog_url).stdout)["rows"]
    assert rows[0]["axis"] == "X" and rows[0]["limit_um"] == 0.5 and rows[0]["beyond_limit"]
    assert guideway("catalog", "tolerance", "--remove", "--machine", "mc-02", "--axis", "X", "--value",
                    "minimum_zone", "--catalog", catalog_url).returncode == 0
    rows = json.loads(guideway("fleet", "--machine", "mc-02", "--json", "--catalog", catalog_url).stdout)["rows"]
    x = next(r for r in rows if r["axis"] == "X")
    assert x["limit_um"] == axes[3].run_limit and x["limit_source"].startswith("[tolerance] of run")
    one_line_error(guideway("catalog", "tolerance", "--remove", "--machine", "mc-02", "--axis", "X", "--value",
                            "minimum_zone", "--catalog", catalog_url), "no tolerance of 'minimum_zone'")
    one_line_error(guideway("catalog", "tolerance", "--machine", "mc-02", "--axis", "X", "--value", "Q",
                            "--limit", "2", "--catalog", catalog_url), "not a headline value")
    one_line_error(guideway("catalog", "tolerance", "--machine", "mc-02", "--axis", "X", "--value", "E",
                            "--limit", "-2", "--catalog", catalog_url), "positive")
    one_line_error(guideway("catalog", "tolerance", "--machine", "mc-02", "--catalog", catalog_url), "--axis")
    # the interval: set, listed, replaced, removed
    assert guideway("catalog", "interval", "--machine", "mc-02", "--axis", "Y", "--days", "90", "--catalog",
                    catalog_url).returncode == 0
    assert guideway("catalog", "interval", "--machine", "mc-02", "--axis", "Y", "--days", "365", "--catalog",
                    catalog_url).returncode == 0
    listed = json.loads(guideway("catalog", "interval", "--list", "--json", "--catalog", catalog_url).stdout)
    assert [(i["machine"], i["axis"], i["days"]) for i in listed["intervals"]] == [("mc-02", "Y", 365.0)]
    assert guideway("catalog", "interval", "--remove", "--machine", "mc-02", "--axis", "Y", "--catalog",
                    catalog_url).returncode == 0
    assert json.loads(guideway("catalog", "interval", "--list", "--json", "--catalog",
                               catalog_url).stdout)["intervals"] == []
    one_line_error(guideway("catalog", "interval", "--machine", "m", "--axis", "Y", "--days", "0", "--catalog",
                            catalog_url), "--days must be a positive number")


def recent_catalogue(url: str, tmp_path: Path, slope_um_per_year: float = 0.5) -> datetime:
    """Real run directories of machine "mill-1" axis X, one a quarter for two years up to 10 days ago, wear
    ``slope_um_per_year`` from 3 µm, limit 8 µm; the last run records its operator, compensation and two
    instruments (one due 20 days from now).  Returns the newest run's date."""
    now = datetime.now(UTC).replace(microsecond=0)
    runs = tmp_path / "runs"
    dates = [now - timedelta(days=10 + 91 * (8 - i)) for i in range(9)]
    for i, d in enumerate(dates):
        t = (d - dates[0]).days / DAYS_PER_YEAR
        run = write_run(runs, f"x{i}", created=iso(d), summary=straightness_summary(3.0 + slope_um_per_year * t, 0.1),
                        tolerance={"straightness_um": 8.0, "reference_line": "minimum_zone"})
        meta = json.loads((run / "run.json").read_text())
        meta["operator"] = f"tech {i}"
        if i == 8:
            meta["compensation"] = {"active": True, "file": "x.comp", "sha256": "ab" * 32, "format": "linuxcnc"}
            meta["setup"]["instruments"] = [
                {"role": "interferometer", "model": "XL-80", "serial": "S1", "certificate": "C-1",
                 "calibrated": iso(now - timedelta(days=345))[:10], "due": iso(now + timedelta(days=20))[:10]},
                {"role": "sensor", "model": "ILD1420", "serial": "S2", "certificate": "C-2",
                 "calibrated": iso(now - timedelta(days=30))[:10], "due": iso(now + timedelta(days=335))[:10]}]
        elif i == 7:
            meta["compensation"] = {"active": False}
        (run / "run.json").write_text(json.dumps(meta))
        summary = run / "results" / "summary.json"
        later = (run / "run.json").stat().st_mtime_ns + 1_000_000
        os.utime(summary, ns=(later, later))  # results newer than run.json: taken as they are
    # a second axis whose newest run predates the compensation record: "not recorded"
    write_run(runs, "y0", axis="Y", created=iso(now - timedelta(days=40)), summary=straightness_summary(2.0, 0.1))
    res = guideway("catalog", "add", "--scan", runs, "--catalog", url)
    assert res.returncode == 0 and "not evaluated" not in res.stdout, res.stdout
    return dates[-1]


def test_run_directories_end_to_end_and_fleet_check(catalog_url: str, tmp_path: Path) -> None:
    newest = recent_catalogue(catalog_url, tmp_path)
    rows = json.loads(guideway("fleet", "--json", "--catalog", catalog_url).stdout)["rows"]
    x = next(r for r in rows if r["axis"] == "X")
    assert x["run"]["operator"] == "tech 8" and x["run"]["name"] == "x8" and x["run"]["date"] == iso(newest)
    assert x["compensation"]["state"] == f"active x.comp (sha256 {'ab' * 32})"
    assert x["value_um"] == pytest.approx(3.0 + 0.5 * (newest - (newest - timedelta(days=8 * 91))).days / 365.25)
    assert x["U_um"] == pytest.approx(0.2) and x["limit_source"] == "[tolerance] of run x8"
    # 3 + 0.5 t reaches 8 µm 10 years after the first run: far beyond a year
    assert x["crossing_date"][:4] == str((newest - timedelta(days=8 * 91) + timedelta(days=3652.5)).year)
    y = next(r for r in rows if r["axis"] == "Y")
    assert y["compensation"]["state"] == "not recorded" and y["limit_um"] is None
    # nothing within 10 days; the interferometer's certificate (20 days) within 30; the crossing within 4000
    res = guideway("fleet", "check", "--within", "10", "--catalog", catalog_url)
    assert res.returncode == 0 and res.stdout == "", res
    res = guideway("fleet", "check", "--within", "30", "--catalog", catalog_url)
    assert res.returncode == 1 and res.stdout.splitlines() == [res.stdout.splitlines()[0]], res.stdout
    assert res.stdout.startswith("INSTRUMENT interferometer XL-80 S1: calibration due")
    # an interval of 30 days: axis Y (40 days ago) is overdue, X (10 days ago) due in 20 days; most urgent first
    assert guideway("catalog", "interval", "--machine", "mill-1", "--axis", "Y", "--days", "30", "--catalog",
                    catalog_url).returncode == 0
    assert guideway("catalog", "interval", "--machine", "mill-1", "--axis", "X", "--days", "30", "--catalog",
                    catalog_url).returncode == 0
    res = guideway("fleet", "check", "--within", "5", "--catalog", catalog_url)
    assert res.returncode == 1 and [ln.split()[0] for ln in res.stdout.splitlines()] == ["OVERDUE"], res.stdout
    assert "mill-1 Y: calibration due" in res.stdout
    res = guideway("fleet", "check", "--within", "4000", "--catalog", catalog_url)
    assert [ln.split()[0] for ln in res.stdout.splitlines()] == ["OVERDUE", "INSTRUMENT", "DUE", "INSTRUMENT",
                                                                 "LIMIT"], res.stdout
    # a tolerance below the newest value: beyond the limit, first of all
    assert guideway("catalog", "tolerance", "--machine", "mill-1", "--axis", "X", "--value", "minimum_zone",
                    "--limit", "3.5", "--catalog", catalog_url).returncode == 0
    res = guideway("fleet", "check", "--within", "0", "--catalog", catalog_url)
    assert res.returncode == 1 and res.stdout.splitlines()[0].startswith("BEYOND   mill-1 X minimum_zone"), res.stdout
    # --machine before or after `check`
    res = guideway("fleet", "--machine", "nobody", "check", "--within", "0", "--catalog", catalog_url)
    assert res.returncode == 0, res
    res = guideway("fleet", "check", "--within", "0", "--machine", "nobody", "--catalog", catalog_url)
    assert res.returncode == 0, res
    # errors: exit 2, one line
    one_line_error(guideway("fleet", "check", "--within", "-1", "--catalog", catalog_url), "--within")
    one_line_error(guideway("fleet", "check", "--within", "x", "--catalog", catalog_url), "--within")
    one_line_error(guideway("fleet", "check", "--catalog", catalog_url), "--within")


def test_fleet_check_without_a_catalogue_is_exit_2(tmp_path: Path) -> None:
    one_line_error(guideway("fleet", "check", "--within", "30", "--catalog", f"sqlite:///{tmp_path / 'none.sqlite'}"),
                   "no catalogue")
    assert not (tmp_path / "none.sqlite").exists()


def test_csv_json_and_report(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    recent_catalogue(url, tmp_path)
    res = guideway("fleet", "--csv", "--catalog", url)
    assert res.returncode == 0, res.stderr
    lines = list(csv.reader(io.StringIO(res.stdout)))
    assert lines[0] == ["machine", "axis", "value", "unit", "limit", "limit_source", "run_date", "operator", "run",
                        "value_measured", "U_k2", "verdict", "decision_rule", "runs", "slope_per_year",
                        "u_slope_per_year", "crossing_date", "u_crossing_days", "beyond_limit_since",
                        "last_step_date", "last_step_change", "compensation", "compensation_sha256", "interval_days",
                        "calibration_due", "overdue"]
    assert len(lines) == 3 and sum(1 for ln in lines if ln[0] == "machine") == 1  # one header line
    assert all(len(ln) == len(lines[0]) for ln in lines)
    assert float(lines[1][lines[0].index("slope_per_year")]) == pytest.approx(0.5, rel=1e-6)
    out = json.loads(guideway("fleet", "--json", "--catalog", url).stdout)
    assert set(out) == {"catalog", "now", "rows", "instruments", "left_out"}
    assert set(out["rows"][0]) == {
        "machine", "axis", "value", "unit", "limit_um", "limit_source", "run", "value_um", "u_um", "U_um", "k",
        "verdict", "decision_rule", "runs", "slope_um_per_year", "u_slope_um_per_year", "crossing_date",
        "u_crossing_days", "crossing_note", "beyond_limit", "beyond_limit_since", "last_step", "compensation",
        "interval_days", "calibration_due", "overdue"}
    assert set(out["rows"][0]["run"]) == {"uid", "name", "path", "date", "operator"}
    assert [i["serial"] for i in out["instruments"]] == ["S1", "S2"]  # soonest due first
    assert set(out["instruments"][0]) == {"role", "model", "serial", "certificate", "calibrated", "due", "due_date",
                                          "last_run", "machine"}
    report = tmp_path / "fleet.html"
    res = guideway("fleet", "--report", report, "--catalog", url)
    assert res.returncode == 0 and f"report written to {report}" in res.stdout
    page = report.read_text()
    assert page.count("<svg") == 2 and "@media print" in page and "XL-80" in page
    assert page.count("<circle") == 9 + 1  # one dot per run of X and of Y


def test_schema_2_is_migrated_to_3_and_entries_without_facts_read_run_json(tmp_path: Path) -> None:
    """A catalogue of schema 2 (no facts column, no tolerance and interval tables) is brought to schema 3 when
    opened; its entries' operator and compensation are read from their run.json."""
    import sqlalchemy as sa

    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    recent_catalogue(url, tmp_path)
    engine = sa.create_engine(url)
    with engine.begin() as conn:  # as guideway with schema 2 left it
        conn.execute(sa.text("ALTER TABLE guideway_runs DROP COLUMN facts_json"))
        conn.execute(sa.text("DROP TABLE guideway_tolerances"))
        conn.execute(sa.text("DROP TABLE guideway_intervals"))
        conn.execute(sa.text("UPDATE guideway_catalog SET value = '2' WHERE key = 'schema_version'"))
    res = guideway("fleet", "--json", "--catalog", url)
    assert res.returncode == 0, res.stderr
    x = next(r for r in json.loads(res.stdout)["rows"] if r["axis"] == "X")
    assert x["run"]["operator"] == "tech 8" and x["compensation"]["active"] is True
    with engine.connect() as conn:
        assert conn.execute(sa.text("SELECT value FROM guideway_catalog")).scalar() == "3"
        assert {"guideway_tolerances", "guideway_intervals"} <= set(sa.inspect(conn).get_table_names())
    engine.dispose()
    assert guideway("catalog", "tolerance", "--machine", "mill-1", "--axis", "X", "--value", "minimum_zone",
                    "--limit", "3", "--catalog", url).returncode == 0


def test_instrument_records_are_read_from_setup_instruments_and_tolerated_when_absent() -> None:
    from fleet.catalog.entry import instrument_records

    rec = {"role": "interferometer", "model": "XL-80", "serial": "1", "certificate": "C", "calibrated": "2026-01-02",
           "due": "2027-01-02"}
    assert instrument_records({"setup": {"instruments": [rec]}}) == [rec]
    assert instrument_records({"instruments": [rec]}) == [rec]
    # the devices' identities (no due date) are no calibration records; a member with one is
    assert instrument_records({"instruments": {"sensor": {"protocol": "x", "model": "ILD"}}}) == []
    assert instrument_records({"instruments": {"sensor": {"model": "ILD", "due": "2027-01-01"}}}) == [
        {"role": "sensor", "model": "ILD", "due": "2027-01-01"}]
    assert instrument_records({}) == [] and instrument_records({"setup": {"instruments": "x"}}) == []


def test_the_verdict_and_decision_rule_the_entry_carries(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    now = datetime.now(UTC)
    for i, (axis, rule, result) in enumerate((("X", "guard-band", "fail"), ("Y", None, "pass"))):
        summary = straightness_summary(4.0, 0.1)
        summary["verdict"] = {"result": result, "checks": [], **({"decision_rule": rule} if rule else {})}
        write_run(tmp_path / "runs", f"r{i}", axis=axis, created=iso(now - timedelta(days=3)), summary=summary,
                  tolerance={"straightness_um": 5.0, "reference_line": "minimum_zone"})
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0
    rows = {r["axis"]: r for r in json.loads(guideway("fleet", "--json", "--catalog", url).stdout)["rows"]}
    assert (rows["X"]["verdict"], rows["X"]["decision_rule"]) == ("fail", "guard-band")
    assert (rows["Y"]["verdict"], rows["Y"]["decision_rule"]) == ("pass", "as evaluated")
    assert not rows["X"]["beyond_limit"]  # 4.0 within 5.0: the verdict is the evaluation's, under its rule
    res = guideway("fleet", "check", "--within", "0", "--catalog", url)
    assert res.returncode == 1 and res.stdout.splitlines() == [
        "FAIL     mill-1 X minimum_zone: the latest run r0 "
        f"({iso(now - timedelta(days=3))[:10]}) failed its tolerance (decision rule guard-band)"], res.stdout
