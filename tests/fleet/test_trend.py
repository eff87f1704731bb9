"""``guideway trend``: slope, its uncertainty and the limit crossing against a weighted least-squares
line computed here from the normal equations (2 x 2 matrix inverse, Jacobian propagation), steps, and
the command on SQLite and PostgreSQL."""

from __future__ import annotations

import json
import math
import random
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest

from fleet.trend.fit import TrendPoint, fit_trend
from tests.cli import guideway, one_line_error

from .runs import positioning_summary, straightness_summary, write_run

YEAR_S = 365.25 * 86400.0
T0 = datetime(2024, 1, 15, 8, 0, tzinfo=UTC)


def iso(d: datetime) -> str:
    return d.strftime("%Y-%m-%dT%H:%M:%SZ")


def reference_fit(dates: list[datetime], y: list[float], u: list[float], birge: bool = True) -> dict[str, float]:
    """Weighted LSQ from the normal equations N p = r, N = [[Σw, Σwt], [Σwt, Σwt²]], cov = N⁻¹, multiplied by
    χ²/dof when that exceeds 1 (``birge``: the scatter, not the stated u, sets the uncertainty)."""
    t = [(d - dates[0]).total_seconds() / YEAR_S for d in dates]
    w = [1 / x**2 for x in u]
    wty = list(zip(w, t, y, strict=True))
    n11, n12, n22 = sum(w), sum(wi * ti for wi, ti, _ in wty), sum(wi * ti * ti for wi, ti, _ in wty)
    r1, r2 = sum(wi * yi for wi, _, yi in wty), sum(wi * ti * yi for wi, ti, yi in wty)
    det = n11 * n22 - n12 * n12
    inv = [[n22 / det, -n12 / det], [-n12 / det, n11 / det]]
    a = inv[0][0] * r1 + inv[0][1] * r2
    b = inv[1][0] * r1 + inv[1][1] * r2
    chi2_dof = sum(wi * (yi - a - b * ti) ** 2 for wi, ti, yi in wty) / (len(y) - 2) if len(y) > 2 else 0.0
    f = max(1.0, chi2_dof) if birge else 1.0
    return {"a": a, "b": b, "var_a": f * inv[0][0], "var_b": f * inv[1][1], "cov": f * inv[0][1],
            "chi2_dof": chi2_dof}


def crossing(f: dict[str, float], limit: float, origin: datetime) -> tuple[datetime, float]:
    """Date where a + b t = limit (t in years from ``origin``), and its standard uncertainty in days
    (Jacobian J cov Jᵀ)."""
    t_star = (limit - f["a"]) / f["b"]
    j = (-1 / f["b"], -(limit - f["a"]) / f["b"] ** 2)  # ∂t*/∂a, ∂t*/∂b
    var = j[0] ** 2 * f["var_a"] + j[1] ** 2 * f["var_b"] + 2 * j[0] * j[1] * f["cov"]
    return origin + timedelta(seconds=t_star * YEAR_S), math.sqrt(var) * 365.25


def series(n: int = 9, slope_per_year: float = 0.8, seed: int = 4, noise: bool = True
           ) -> tuple[list[datetime], list[float], list[float]]:
    """Runs about every quarter on a rising line, each with its own uncertainty u, scattered by u (or,
    without ``noise``, by a fixed ±0.02 µm)."""
    rng = random.Random(seed)
    dates = [T0 + timedelta(days=91 * i + rng.randint(0, 20), hours=rng.randint(0, 9)) for i in range(n)]
    u = [0.1 + 0.05 * rng.random() for _ in range(n)]
    y = [4.0 + slope_per_year * (d - T0).total_seconds() / YEAR_S + (rng.gauss(0, ui) if noise else (-1) ** i * 0.02)
         for i, (d, ui) in enumerate(zip(dates, u, strict=True))]
    return dates, y, u


def test_slope_uncertainty_and_crossing_match_the_normal_equations() -> None:
    dates, y, u = series()
    pts = [TrendPoint(f"r{i}", iso(d), yi, ui) for i, (d, yi, ui) in enumerate(zip(dates, y, u, strict=True))]
    trend = fit_trend(list(reversed(pts)), limit_um=8.0)  # any order: sorted oldest first
    ref = reference_fit(dates, y, u)
    assert [p.run for p in trend.points] == [f"r{i}" for i in range(len(pts))]
    assert trend.slope_um_per_year == pytest.approx(ref["b"], rel=1e-9)
    assert trend.u_slope_um_per_year == pytest.approx(math.sqrt(ref["var_b"]), rel=1e-9)
    when, u_days = crossing(ref, 8.0, dates[0])
    got = datetime.fromisoformat(trend.crossing_date.replace("Z", "+00:00"))
    assert abs((got - when).total_seconds()) <= 1.0  # the date is given to the second
    assert trend.u_crossing_days == pytest.approx(u_days, rel=1e-9)


def test_equal_weights_when_uncertainties_are_unknown() -> None:
    dates, y, _ = series(seed=9)
    trend = fit_trend([TrendPoint(f"r{i}", iso(d), yi, None) for i, (d, yi) in enumerate(zip(dates, y, strict=True))])
    t = [(d - dates[0]).total_seconds() / YEAR_S for d in dates]
    tm, ym = sum(t) / len(t), sum(y) / len(y)
    sxx = sum((ti - tm) ** 2 for ti in t)
    b = sum((ti - tm) * (yi - ym) for ti, yi in zip(t, y, strict=True)) / sxx
    s2 = sum((yi - ym - b * (ti - tm)) ** 2 for ti, yi in zip(t, y, strict=True)) / (len(t) - 2)
    assert trend.slope_um_per_year == pytest.approx(b, rel=1e-9)
    assert trend.u_slope_um_per_year == pytest.approx(math.sqrt(s2 / sxx), rel=1e-9)
    assert trend.steps == []  # unknown uncertainties: no step can be judged


def test_a_step_is_a_jump_against_the_line_of_the_runs_before_it() -> None:
    pts = [TrendPoint("a", "2025-01-01T00:00:00Z", 5.0, 0.1), TrendPoint("b", "2025-04-01T00:00:00Z", 5.2, 0.1),
           TrendPoint("c", "2025-07-01T00:00:00Z", 3.1, 0.1), TrendPoint("d", "2025-10-01T00:00:00Z", 3.35, 0.1)]
    steps = fit_trend(pts).steps
    # c against the line through a and b (90 days apart) extrapolated 181 days: ŷ = 5.0 + 0.2 λ, λ = 181/90,
    # u²(ŷ) = u² ((1 − λ)² + λ²); d starts the new stretch after the step (one run: not judged)
    lam = 181 / 90
    assert [(s.from_run, s.to_run) for s in steps] == [("b", "c")]
    assert steps[0].expected_um == pytest.approx(5.0 + 0.2 * lam)
    assert steps[0].change_um == pytest.approx(3.1 - 5.0 - 0.2 * lam)
    assert steps[0].u_um == pytest.approx(0.1 * math.sqrt(1 + (1 - lam) ** 2 + lam**2))


def test_no_crossing_when_the_value_does_not_grow() -> None:
    pts = [TrendPoint("a", "2025-01-01T00:00:00Z", 5.0, 0.1), TrendPoint("b", "2026-01-01T00:00:00Z", 4.0, 0.1),
           TrendPoint("c", "2027-01-01T00:00:00Z", 3.0, 0.1)]
    trend = fit_trend(pts, limit_um=8.0)
    assert trend.crossing_date is None and "does not grow" in trend.crossing_note
    assert not trend.beyond_limit


def test_trend_command(catalog_url: str, tmp_path: Path) -> None:
    dates, y, u = series(n=8, slope_per_year=0.3, noise=False)  # quarterly changes well below 2 u: no step
    y[5:] = [v - 3.0 for v in y[5:]]  # a new compensation between runs 4 and 5
    for i, (d, yi, ui) in enumerate(zip(dates, y, u, strict=True)):
        write_run(tmp_path, f"r{i}", created=iso(d), summary=straightness_summary(yi, ui, k=2.0),
                  tolerance={"straightness_um": 9.0, "reference_line": "minimum_zone"} if i == 7 else None)
    write_run(tmp_path, "other-axis", axis="Y", created=iso(T0), summary=straightness_summary(50.0, 0.1))
    assert guideway("catalog", "add", "--scan", tmp_path, "--catalog", catalog_url).returncode == 0
    report = tmp_path / "trend.html"
    res = guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "minimum_zone", "--json",
                   "--report", report, "--catalog", catalog_url)
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert {"machine", "axis", "value", "points", "slope_um_per_year", "u_slope_um_per_year", "limit_um",
            "crossing_date", "steps"} <= set(out)
    assert (out["machine"], out["axis"], out["value"]) == ("mill-1", "X", "minimum_zone")
    assert [p["date"] for p in out["points"]] == [iso(d) for d in dates]
    assert set(out["points"][0]) == {"run", "name", "date", "value_um", "u_um"}
    assert [p["name"] for p in out["points"]] == [f"r{i}" for i in range(8)]  # the run directories' names
    assert [p["u_um"] for p in out["points"]] == pytest.approx(u, rel=1e-12)
    ref = reference_fit(dates, y, u)
    assert out["slope_um_per_year"] == pytest.approx(ref["b"], rel=1e-9)
    assert out["u_slope_um_per_year"] == pytest.approx(math.sqrt(ref["var_b"]), rel=1e-9)
    assert out["limit_um"] == 9.0  # the newest run's [tolerance]
    names = {p["run"]: i for i, p in enumerate(out["points"])}
    assert [(names[s["from_run"]], names[s["to_run"]]) for s in out["steps"]] == [(4, 5)]
    html = report.read_text()
    assert "data:image/png;base64," in html and "minimum_zone" in html
    # the jump down makes the whole line fall: it never reaches a limit; without the jump's runs it rises
    assert ref["b"] < 0 and out["crossing_date"] is None
    lim = guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "minimum_zone", "--limit", "5.5",
                   "--json", "--catalog", catalog_url)
    assert json.loads(lim.stdout)["crossing_date"] is None
    for i in range(5, 8):
        assert guideway("catalog", "remove", tmp_path / f"r{i}", "--catalog", catalog_url).returncode == 0
    lim = guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "minimum_zone", "--limit", "5.5",
                   "--json", "--catalog", catalog_url)
    out = json.loads(lim.stdout)
    ref = reference_fit(dates[:5], y[:5], u[:5])
    when, u_days = crossing(ref, 5.5, dates[0])
    got = datetime.fromisoformat(out["crossing_date"].replace("Z", "+00:00"))
    assert abs((got - when).total_seconds()) <= 1.0 and out["u_crossing_days"] == pytest.approx(u_days, rel=1e-9)
    assert out["limit_um"] == 5.5 and out["steps"] == []


def test_trend_bad_input(catalog_url: str, tmp_path: Path) -> None:
    write_run(tmp_path, "p", kind="positioning", summary=positioning_summary({"E": 3.0, "A": 5.0}))
    guideway("catalog", "add", "--scan", tmp_path, "--catalog", catalog_url)
    one_line_error(guideway("trend", "--machine", "nope", "--axis", "X", "--value", "E", "--catalog", catalog_url),
                   "no catalogued run of machine 'nope'")
    one_line_error(guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "Q", "--catalog", catalog_url),
                   "no run", "A, E")
    one_line_error(guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "E", "--limit", "-1",
                            "--catalog", catalog_url), "--limit")


def test_trend_of_a_run_whose_created_is_not_a_time_is_one_line(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'catalog.sqlite'}"
    runs = tmp_path / "runs"
    write_run(runs, "good", created="2025-01-01T00:00:00Z", summary=straightness_summary(5.0, 0.2))
    write_run(runs, "bad", created="26/11/2026", summary=straightness_summary(5.5, 0.2))
    assert guideway("catalog", "add", "--scan", runs, "--catalog", url).returncode == 0
    one_line_error(guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "minimum_zone",
                            "--catalog", url), "26/11/2026", "not an ISO 8601 time")


def test_a_run_that_is_not_complete_is_left_out_of_the_trend(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'catalog.sqlite'}"
    runs = tmp_path / "runs"
    # E rises 1 um a year over three complete runs; an aborted run over part of the axis has a small E
    for name, created, e in (("r0", "2024-01-01T00:00:00Z", 4.0), ("r1", "2025-01-01T00:00:00Z", 5.0),
                             ("r2", "2026-01-01T00:00:00Z", 6.0)):
        write_run(runs, name, kind="positioning", created=created, summary=positioning_summary({"E": e}))
    aborted = write_run(runs, "cut", kind="positioning", created="2025-07-02T12:00:00Z", status="aborted",
                        summary=positioning_summary({"E": 1.0}))
    assert guideway("catalog", "add", "--scan", runs, "--catalog", url).returncode == 0
    res = guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "E", "--json", "--catalog", url)
    out = json.loads(res.stdout)
    assert [p["value_um"] for p in out["points"]] == [4.0, 5.0, 6.0]
    # the three points: t = 0, 366/365.25, 731/365.25 years (2024 is a leap year); OLS slope
    t = [0.0, 366 / 365.25, 731 / 365.25]
    tm = sum(t) / 3
    b = sum((ti - tm) * yi for ti, yi in zip(t, [4.0, 5.0, 6.0], strict=True)) / sum((ti - tm) ** 2 for ti in t)
    assert out["slope_um_per_year"] == pytest.approx(b, rel=1e-12)
    uid = json.loads((aborted / "run.json").read_text())["uid"]
    assert out["left_out"] == [f"{uid} (aborted)"]
