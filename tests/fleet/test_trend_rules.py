"""``guideway trend``'s rules of issue 25: an axis beyond its limit, uncertainties scaled by the scatter
(checked against NumPy's weighted least squares), no crossing date from two runs or a short span, steps as
jumps against the trend (false-step rate by simulation against the normal tail), signed values (B_mean) and
runs dated in the future (left out of trends, flagged by ``catalog list``)."""

from __future__ import annotations

import json
import math
import random
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from fleet.catalog.clock import is_future
from fleet.catalog.database import open_catalog
from fleet.trend.fit import STEP_K, TrendPoint, fit_trend
from fleet.trend.of_catalog import axis_trend
from tests.cli import guideway

from .runs import positioning_summary, straightness_summary, write_run

YEAR_S = 365.25 * 86400.0
T0 = datetime(2024, 1, 15, 8, 0, tzinfo=UTC)


def iso(d: datetime) -> str:
    return d.strftime("%Y-%m-%dT%H:%M:%SZ")


def years(dates: list[datetime]) -> np.ndarray:
    return np.array([(d - dates[0]).total_seconds() / YEAR_S for d in dates])


def normal_two_sided_tail(k: float) -> float:
    """P(|Z| > k), Z standard normal."""
    return math.erfc(k / math.sqrt(2.0))


def phi(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


def trend_json(url: str, *args: str) -> dict:
    res = guideway("trend", "--machine", "mill-1", "--axis", "X", *args, "--json", "--catalog", url)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


# --- beyond the limit -------------------------------------------------------------------------------------


def test_an_axis_beyond_its_limit_says_so_in_text_and_json(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    for i, e in enumerate((7.1, 5.9, 4.6, 3.5)):  # every run above --limit 2, the value falling
        write_run(tmp_path / "runs", f"q{i}", kind="positioning", created=f"{2023 + i}-03-01T00:00:00Z",
                  summary=positioning_summary({"E": e}))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0
    out = trend_json(url, "--value", "E", "--limit", "2")
    assert out["beyond_limit"] is True
    assert out["beyond_limit_since"]["name"] == "q0" and out["beyond_limit_since"]["date"] == "2023-03-01T00:00:00Z"
    assert out["crossing_date"] is None
    text = guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "E", "--limit", "2",
                    "--catalog", url).stdout
    assert "never" not in text
    assert "beyond the limit since run q0 (2023-03-01): every run above 2 um" in text
    # the newest run back within the limit: not beyond
    assert trend_json(url, "--value", "E", "--limit", "4")["beyond_limit"] is False


def test_beyond_since_is_the_first_run_of_the_last_stretch_beyond() -> None:
    values = [1.0, 3.0, 1.5, 2.5, 3.0]  # limit 2: runs 1, 3, 4 beyond; the stretch ending at the newest starts at 3
    pts = [TrendPoint(f"r{i}", iso(T0 + timedelta(days=90 * i)), v, 0.1, f"/runs/n{i}") for i, v in enumerate(values)]
    t = fit_trend(pts, limit_um=2.0)
    assert t.beyond_limit and t.beyond_since is not None and t.beyond_since.name == "n3" and t.beyond_count == 2
    assert not fit_trend(pts, limit_um=3.0).beyond_limit  # 3.0 is at the limit, not beyond


# --- uncertainty scaled by the scatter ----------------------------------------------------------------------


def test_u_is_scaled_by_the_scatter_as_numpy_weighted_least_squares_does() -> None:
    rng = random.Random(7)
    dates = [T0 + timedelta(days=91 * i + rng.randint(0, 10)) for i in range(6)]
    u = [0.1] * 6
    y = [4.0 + 0.8 * ti + rng.gauss(0, 1.0) for ti in years(dates)]  # scatter ~10 u: χ²/dof ~ 100
    pts = [TrendPoint(f"r{i}", iso(d), yi, ui) for i, (d, yi, ui) in enumerate(zip(dates, y, u, strict=True))]
    trend = fit_trend(pts, limit_um=12.0)
    t = years(dates)
    # np.polyfit with w = 1/σ and cov=True scales the covariance by χ²/(n − 2)
    (b, a), cov = np.polyfit(t, y, 1, w=1 / np.array(u), cov=True)
    chi2_dof = float(np.sum(((np.array(y) - a - b * t) / np.array(u)) ** 2) / 4)
    assert chi2_dof > 20
    assert trend.chi2_per_dof == pytest.approx(chi2_dof, rel=1e-9)
    assert trend.slope_um_per_year == pytest.approx(b, rel=1e-9)
    assert trend.u_slope_um_per_year == pytest.approx(math.sqrt(cov[0, 0]), rel=1e-9)
    assert trend.u_scale == pytest.approx(math.sqrt(chi2_dof), rel=1e-9)
    # t* = (L − a)/b, Jacobian (∂t*/∂b, ∂t*/∂a) with NumPy's (b, a) covariance
    t_star = (12.0 - a) / b
    j = np.array([-(12.0 - a) / b**2, -1 / b])
    u_days = math.sqrt(j @ cov @ j) * 365.25
    assert trend.u_crossing_days == pytest.approx(u_days, rel=1e-9)
    got = datetime.fromisoformat(trend.crossing_date.replace("Z", "+00:00"))
    assert abs((got - (dates[0] + timedelta(seconds=t_star * YEAR_S))).total_seconds()) <= 1


def test_u_is_not_scaled_when_the_runs_scatter_less_than_they_say() -> None:
    dates = [T0 + timedelta(days=91 * i) for i in range(6)]
    u = [0.1, 0.12, 0.1, 0.15, 0.1, 0.11]
    y = [4.0 + 0.8 * ti + 0.01 * (-1) ** i for i, ti in enumerate(years(dates))]
    trend = fit_trend([TrendPoint(f"r{i}", iso(d), yi, ui) for i, (d, yi, ui) in enumerate(zip(dates, y, u,
                                                                                              strict=True))])
    _, cov = np.polyfit(years(dates), y, 1, w=1 / np.array(u), cov="unscaled")
    assert trend.chi2_per_dof < 1 and trend.u_scale is None
    assert trend.u_slope_um_per_year == pytest.approx(math.sqrt(cov[0, 0]), rel=1e-9)


def test_the_scaling_is_said(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    for i, v in enumerate((5.0, 6.5, 5.2, 7.0, 5.8, 7.4)):
        write_run(tmp_path / "runs", f"s{i}", created=iso(T0 + timedelta(days=91 * i)),
                  summary=straightness_summary(v, 0.05))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0
    text = guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "minimum_zone", "--catalog", url).stdout
    assert "u scaled by √(χ²/dof) = " in text
    assert trend_json(url, "--value", "minimum_zone")["u_scaled_by"] > 1


# --- no crossing date from too little ------------------------------------------------------------------------


def rising(dates: list[datetime]) -> list[TrendPoint]:
    return [TrendPoint(f"r{i}", iso(d), 5.0 + i * 0.3 + 0.02 * (-1) ** i, 0.1) for i, d in enumerate(dates)]


def test_two_runs_give_no_crossing_date() -> None:
    t = fit_trend(rising([T0, T0 + timedelta(days=365)]), limit_um=8.0)
    assert t.slope_um_per_year is not None and t.crossing_date is None and t.u_crossing_days is None
    assert "2 runs" in t.crossing_note and "at least 3" in t.crossing_note
    assert fit_trend(rising([T0, T0 + timedelta(days=180), T0 + timedelta(days=365)]), limit_um=8.0).crossing_date


def test_a_span_shorter_than_30_days_gives_no_crossing_date() -> None:
    minutes = [T0 + timedelta(minutes=5 * i) for i in range(4)]  # four runs within minutes
    t = fit_trend(rising(minutes), limit_um=8.0)
    assert t.crossing_date is None and "span 0.0 days" in t.crossing_note and "30 days" in t.crossing_note
    # the boundary: 30 days between the first and the newest run give a date; one second less does not
    span = [T0, T0 + timedelta(days=15), T0 + timedelta(days=30)]
    assert fit_trend(rising(span), limit_um=8.0).crossing_date is not None
    short = [T0, T0 + timedelta(days=15), T0 + timedelta(days=30, seconds=-1)]
    assert fit_trend(rising(short), limit_um=8.0).crossing_date is None


# --- steps: jumps against the trend ---------------------------------------------------------------------------


def steady_wear(rng: random.Random, n: int, jump_at: int | None = None, jump_u: float = 0.0
                ) -> tuple[list[TrendPoint], list[datetime], list[float]]:
    """Quarterly runs (± 10 days) of an axis wearing 1 µm a year, each scattered by its own u (0.08–0.15 µm),
    optionally with a jump of ``jump_u`` times its u at run ``jump_at`` and after."""
    dates = [T0 + timedelta(days=91 * i + rng.randint(-10, 10)) for i in range(n)]
    u = [0.08 + 0.07 * rng.random() for _ in range(n)]
    t = years(dates)
    y = [5.0 + 1.0 * t[i] + rng.gauss(0, u[i]) for i in range(n)]
    if jump_at is not None:
        y = [yi + (jump_u * u[jump_at] if i >= jump_at else 0.0) for i, yi in enumerate(y)]
    pts = [TrendPoint(f"r{i}", iso(d), yi, ui) for i, (d, yi, ui) in enumerate(zip(dates, y, u, strict=True))]
    return pts, dates, u


def test_steady_wear_gives_false_steps_at_the_normal_tail_rate() -> None:
    rng = random.Random(2025)
    series, n = 20, 1000
    flagged = sum(len(fit_trend(steady_wear(rng, n)[0]).steps) for _ in range(series))
    alpha = normal_two_sided_tail(STEP_K)  # 0.27 % for k = 3
    judged = series * (n - 2)  # every run after the first two is judged (less one after each step)
    expected = alpha * judged
    # binomial spread of the count: 4 sigma (the old rule, change between consecutive runs > 2 u, flagged ~40 %)
    assert abs(flagged - expected) <= 4 * math.sqrt(expected), (flagged, expected)


def scatter_scale(y: list[float], u: list[float], t: np.ndarray) -> float:
    """docs/fleet.md: c = max(1, 1.4826 MAD(d)), d_i = (Δy_i − b̃ Δt_i)/√(u_i² + u_{i+1}²), b̃ = median Δy/Δt."""
    dy, dt = np.diff(y), np.diff(t)
    d = (dy - np.median(dy / dt) * dt) / np.hypot(u[:-1], u[1:])
    return max(1.0, 1.4826 * float(np.median(np.abs(d - np.median(d)))))


def test_a_jump_of_5_u_is_flagged_at_the_rate_the_normal_distribution_gives() -> None:
    rng = random.Random(11)
    trials, n, at = 200, 30, 20
    hits, powers = 0, []
    for _ in range(trials):
        pts, dates, u = steady_wear(rng, n, jump_at=at, jump_u=5.0)
        hits += any(s.to_run == f"r{at}" for s in fit_trend(pts).steps)
        # the power for this trial: run 20 against the line of runs 0..19 (NumPy WLS, unscaled covariance = the
        # stated u), z = 5 u / √(u² + u²(ŷ)), with the scatter scale c: P(|N(z, 1)| > k c)
        t = years(dates)
        _, cov = np.polyfit(t[:at], [0.0] * at, 1, w=1 / np.array(u[:at]), cov="unscaled")
        x = np.array([t[at], 1.0])
        z = 5.0 * u[at] / math.sqrt(u[at] ** 2 + x @ cov @ x)
        c = scatter_scale([p.value_um for p in pts], np.array(u), t)
        powers.append(phi(z - STEP_K * c) + phi(-z - STEP_K * c))
    power = sum(powers) / trials
    assert power > 0.7
    # binomial spread, and a margin for the trials where a false step earlier shortened the runs before the jump
    # (about 18 x 0.27 % = 5 % of them)
    assert hits / trials >= power - 4 * math.sqrt(power * (1 - power) / trials) - 0.05, (hits, power)


def test_runs_scattering_10_times_their_u_are_not_all_steps() -> None:
    rng = random.Random(8)
    series, n, flagged = 10, 200, 0
    for _ in range(series):
        dates = [T0 + timedelta(days=91 * i + rng.randint(-10, 10)) for i in range(n)]
        u = [0.08 + 0.07 * rng.random() for _ in range(n)]
        y = [5.0 + ti + rng.gauss(0, 10 * ui) for ti, ui in zip(years(dates), u, strict=True)]  # set-up variation
        trend = fit_trend([TrendPoint(f"r{i}", iso(d), yi, ui) for i, (d, yi, ui) in enumerate(zip(dates, y, u,
                                                                                                   strict=True))])
        flagged += len(trend.steps)
        assert 8 < trend.step_scale < 12
    # judged against the stated u, P(|N(0, 10²)| > 3) = 76 % of the runs would be steps; scaled, about the
    # nominal 0.27 % (a little more: c is estimated)
    assert normal_two_sided_tail(STEP_K / 10) > 0.7
    assert flagged / (series * (n - 2)) < 0.01


def test_a_jump_is_flagged_once_and_the_runs_after_it_are_judged_against_the_new_state() -> None:
    pts, _, _ = steady_wear(random.Random(3), 40, jump_at=25, jump_u=8.0)
    steps = fit_trend(pts).steps
    assert [s.to_run for s in steps] == ["r25"]
    assert steps[0].from_run == "r24" and steps[0].change_um / steps[0].u_um > STEP_K


# --- signed values --------------------------------------------------------------------------------------------


def test_b_mean_trends_the_signed_reversal_and_b_is_said_to_be_a_magnitude(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    b_mean = [3.0, 0.8, -1.4, -4.0]  # the reversal drifts from + to −
    for i, v in enumerate(b_mean):
        write_run(tmp_path / "runs", f"b{i}", kind="positioning", created=f"{2022 + i}-06-01T00:00:00Z",
                  summary=positioning_summary({"E": 5.0, "B": abs(v), "B_mean": v}))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0
    out = trend_json(url, "--value", "B_mean", "--limit", "3.5")
    assert [p["value_um"] for p in out["points"]] == b_mean and out["signed"] is True
    t = years([datetime(2022 + i, 6, 1, tzinfo=UTC) for i in range(4)])
    b, a = np.polyfit(t, b_mean, 1)  # equal weights: positioning values have no u
    assert out["slope_um_per_year"] == pytest.approx(b, rel=1e-9) and b < -2
    # the limit bounds |B_mean|: the falling line reaches −3.5
    when = datetime(2022, 6, 1, tzinfo=UTC) + timedelta(seconds=(-3.5 - a) / b * YEAR_S)
    got = datetime.fromisoformat(out["crossing_date"].replace("Z", "+00:00"))
    assert abs((got - when).total_seconds()) <= 1
    assert out["beyond_limit"] is True and out["beyond_limit_since"]["name"] == "b3"  # |−4.0| > 3.5
    text = guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "B", "--catalog", url).stdout
    assert "B is a magnitude" in text and "B_mean" in text
    assert trend_json(url, "--value", "B")["signed"] is False


# --- runs dated in the future ---------------------------------------------------------------------------------


def test_the_future_is_later_than_now_plus_one_day() -> None:
    now = datetime(2026, 11, 28, 9, 0, tzinfo=UTC)
    assert not is_future("2026-11-29T09:00:00Z", now)  # now + 1 day exactly: not in the future
    assert is_future("2026-11-29T09:00:01Z", now)
    assert not is_future("2026-11-29T09:00:00", now)  # no zone: UTC
    assert not is_future("26/11/2026", now)  # not a time: not judged here


def test_a_run_dated_in_the_future_is_left_out_of_the_trend_and_flagged_by_catalog_list(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    runs = tmp_path / "runs"
    dates = [datetime(2023, 1, 1, tzinfo=UTC), datetime(2024, 1, 1, tzinfo=UTC), datetime(2025, 1, 1, tzinfo=UTC)]
    for i, (d, v) in enumerate(zip(dates, (4.0, 30.0, 56.0), strict=True)):  # +26 um/year
        write_run(runs, f"f{i}", created=iso(d), summary=straightness_summary(v, 0.5))
    rig = write_run(runs, "rig-2099", created="2099-03-01T00:00:00Z", summary=straightness_summary(56.5, 0.5))
    uid = json.loads((rig / "run.json").read_text())["uid"]
    assert guideway("catalog", "add", "--scan", runs, "--catalog", url).returncode == 0
    out = trend_json(url, "--value", "minimum_zone")
    assert [p["name"] for p in out["points"]] == ["f0", "f1", "f2"]
    b = np.polyfit(years(dates), [4.0, 30.0, 56.0], 1, w=[2.0] * 3)[0]
    assert out["slope_um_per_year"] == pytest.approx(b, rel=1e-9) and b > 25
    assert len(out["left_out"]) == 1 and out["left_out"][0].startswith(f"{uid} (created 2099-03-01T00:00:00Z, in "
                                                                       "the future")
    text = guideway("trend", "--machine", "mill-1", "--axis", "X", "--value", "minimum_zone", "--catalog", url).stdout
    assert f"left out: {uid} (created 2099-03-01" in text
    # catalog list: the row is marked, a note on stderr, and JSON says which
    res = guideway("catalog", "list", "--catalog", url)
    lines = res.stdout.splitlines()
    row = next(i for i, ln in enumerate(lines) if ln.endswith("rig-2099"))
    assert lines[row + 1].startswith("  ^ dated in the future (created 2099-03-01T00:00:00Z)")
    assert sum("dated in the future" in ln for ln in lines) == 1
    assert "1 run(s) created later than" in res.stderr
    listed = json.loads(guideway("catalog", "list", "--json", "--catalog", url).stdout)
    assert len(listed["runs"]) == 4 and listed["future_dated"] == [uid]


def test_future_is_judged_against_the_now_given(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'c.sqlite'}"
    now = datetime(2025, 6, 1, tzinfo=UTC)
    for name, when in (("a", now - timedelta(days=400)), ("b", now - timedelta(days=100)),
                       ("edge", now + timedelta(days=1)), ("over", now + timedelta(days=1, seconds=1))):
        write_run(tmp_path / "runs", name, created=iso(when), summary=straightness_summary(5.0, 0.1))
    assert guideway("catalog", "add", "--scan", tmp_path / "runs", "--catalog", url).returncode == 0
    with open_catalog(url, create=False) as cat:
        at = axis_trend(cat, "mill-1", "X", "minimum_zone", now=now)
    assert [p.name for p in at.trend.points] == ["a", "b", "edge"]
    assert len(at.left_out) == 1 and "2025-06-02T00:00:01Z" in at.left_out[0]
