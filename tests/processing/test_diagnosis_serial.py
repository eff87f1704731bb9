"""Serial correlation of residuals in time (processing/diagnosis/serial.py), tested function by function.

Every expected value is written here from its definition, never taken from the module:
- lag-1 autocorrelation r₁ = Σ r_t r_{t+1} / Σ r_t²;
- R(φ)_ij = φ^|i−j| and A (½ on the first off-diagonals) as explicit matrices;
- the expected residual lag-1 autocorrelation E[eᵀAe] / E[eᵀe] = tr(M A M R) / tr(M R), M = I − QQᵀ;
- the matched φ: the root of that expectation = observed r₁ (scipy's brentq on the explicit matrices);
- Prais–Winsten rows z₀ = √(1 − φ²) v₀, z_t = v_t − φ v_{t−1} written out by hand;
- Ljung–Box Q = n(n+2) Σ_{k≤h} ρ_k² / (n−k) with ρ_k of the mean-removed series, p from χ²(h − fitted);
- an earlier run's φ at another point interval: φ^(Δt'/Δt) (errors decaying as e^(−Δt/τ))."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize
from scipy.stats import chi2

from processing.diagnosis import serial
from processing.diagnosis.serial import (
    PHI_MAX,
    PHI_Z,
    Ar1Estimate,
    ar1_coefficient,
    expected_lag1,
    lag1,
    ljung_box,
    matched_phi,
    point_interval_s,
    prais_winsten,
    r_times,
    time_order,
)

# ---------------------------------------------------------------- independent references


def r_matrix(n: int, phi: float) -> np.ndarray:
    i = np.arange(n)
    return phi ** np.abs(i[:, None] - i[None, :])


def a_matrix(n: int) -> np.ndarray:
    return (np.eye(n, k=1) + np.eye(n, k=-1)) / 2


def lag1_ref(r: np.ndarray) -> float:
    return sum(r[t] * r[t + 1] for t in range(len(r) - 1)) / sum(x * x for x in r)


def expected_lag1_ref(q: np.ndarray, phi: float) -> float:
    n = q.shape[0]
    m = np.eye(n) - q @ q.T
    r = r_matrix(n, phi)
    return float(np.trace(m @ a_matrix(n) @ m @ r) / np.trace(m @ r))


def matched_ref(resid: np.ndarray, q: np.ndarray, low: float) -> float:
    r1 = lag1_ref(resid)
    n = q.shape[0]
    m = np.eye(n) - q @ q.T
    mam = m @ a_matrix(n) @ m
    # tr(M A M R) / tr(M R) as element-wise sums (R symmetric), M A M once for every φ
    f = lambda phi: float(np.sum(mam * r_matrix(n, phi)) / np.sum(m * r_matrix(n, phi))) - r1  # noqa: E731
    if f(low) >= 0:
        return math.nan
    if f(0.98) <= 0:
        return 0.98
    return optimize.brentq(f, low, 0.98, xtol=1e-12)


def line_basis(n: int) -> np.ndarray:
    """Orthonormal basis of [1, t] (offset and slope), by QR."""
    t = np.arange(n, dtype=float)
    q, _ = np.linalg.qr(np.column_stack([np.ones(n), t]))
    return q


def ar1_series(n: int, phi: float, seed: int) -> np.ndarray:
    """An exact AR(1) recursion u_t = φ u_{t−1} + w_t, stationary start."""
    w = np.random.default_rng(seed).standard_normal(n)
    u = np.empty(n)
    u[0] = w[0] / math.sqrt(1 - phi * phi)
    for t in range(1, n):
        u[t] = phi * u[t - 1] + w[t]
    return u


def residual_of_line(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q = line_basis(len(u))
    return u - q @ (q.T @ u), q


# ---------------------------------------------------------------- time order


def test_time_order_sorts_by_the_time_column() -> None:
    got = time_order({"time_min": np.array([3.0, 1.0, 2.0])}, 3)
    assert got.tolist() == [1, 2, 0]


def test_time_order_keeps_acquisition_order_among_equal_times() -> None:
    # 200 points with many ties: a non-stable sort (numpy's default introsort) reorders equal times
    t = np.random.default_rng(0).integers(0, 3, 200).astype(float)
    expected = sorted(range(200), key=lambda i: (t[i], i))
    assert time_order({"time_min": t}, 200).tolist() == expected


@pytest.mark.parametrize("values", [
    {},  # no time column
    {"x_mm": np.array([3.0, 2.0, 1.0, 0.0])},  # another column only
    {"time_min": np.array([3.0, 2.0, 1.0])},  # a time column of another length
    {"time_min": np.array([3.0, np.nan, 2.0, 1.0])},  # a point without time
    {"time_min": np.array([3.0, 2.0, np.inf, 1.0])},
])
def test_time_order_falls_back_to_acquisition_order(values: dict[str, np.ndarray]) -> None:
    assert time_order(values, 4).tolist() == [0, 1, 2, 3]


def test_time_order_of_a_single_point() -> None:
    assert time_order({"time_min": np.array([5.0])}, 1).tolist() == [0]
    assert time_order({}, 1).tolist() == [0]


# ---------------------------------------------------------------- point interval


def test_point_interval_is_the_median_step_in_seconds() -> None:
    # unsorted times (min); sorted 0, 0.1, 0.2, 0.5, 0.6: steps 0.1, 0.1, 0.3, 0.1 -> median 0.1 min = 6 s
    assert point_interval_s(np.array([0.2, 0.0, 0.6, 0.1, 0.5])) == pytest.approx(6.0)


def test_point_interval_below_a_second() -> None:
    assert point_interval_s(np.array([0.0, 0.5, 1.0]) / 60.0) == pytest.approx(0.5)


def test_point_interval_of_two_points() -> None:
    assert point_interval_s(np.array([1.0, 3.0])) == pytest.approx(120.0)


@pytest.mark.parametrize("time_min", [
    None,  # no time column
    np.array([2.0]),  # a single point: no step
    np.array([]),
    np.array([0.0, 1.0, np.nan, 2.0, 3.0]),  # a point without time
    np.array([0.0, 1.0, 2.0, np.inf]),
    np.array([4.0, 4.0, 4.0]),  # all at once: no interval
    np.array([0.0, 0.0, 0.0, 1.0]),  # median step 0
])
def test_point_interval_unknown(time_min: np.ndarray | None) -> None:
    assert point_interval_s(time_min) is None


# ---------------------------------------------------------------- Ar1Estimate


def test_at_interval_scales_by_the_decay_time() -> None:
    e = Ar1Estimate(0.8, 100, 1.5, "run-a")
    assert e.at_interval(3.0) == pytest.approx(0.8**2)  # twice the interval: φ²
    assert e.at_interval(0.75) == pytest.approx(0.8**0.5)
    assert e.at_interval(1.5) == pytest.approx(0.8)


def test_at_interval_is_capped_at_phi_max() -> None:
    e = Ar1Estimate(0.99, 100, 2.0)
    assert 0.99**0.5 > PHI_MAX
    assert e.at_interval(1.0) == PHI_MAX
    assert Ar1Estimate(0.95, 100, 2.0).at_interval(1.0) == pytest.approx(0.95**0.5)  # 0.975: under the cap


@pytest.mark.parametrize(("phi", "own", "other"), [
    (-0.3, 1.0, 2.0),  # negative: no decay time
    (0.6, None, 2.0),  # earlier run without times
    (0.6, 1.0, None),  # this run without times
    (0.6, 1.0, 0.0),
    (0.6, 0.0, 2.0),
])
def test_at_interval_unchanged(phi: float, own: float | None, other: float | None) -> None:
    assert Ar1Estimate(phi, 50, own).at_interval(other) == phi


def test_at_interval_of_zero_phi() -> None:
    assert Ar1Estimate(0.0, 50, 1.0).at_interval(2.0) == 0.0


def test_estimate_to_dict() -> None:
    assert Ar1Estimate(0.5, 40, 2.5, "r.parquet").to_dict() == {
        "run": "r.parquet", "phi": 0.5, "points": 40, "interval_s": 2.5}
    assert Ar1Estimate(0.5, 40, None).to_dict()["run"] == ""


# ---------------------------------------------------------------- lag-1 autocorrelation, R(φ) q, A v


def test_lag1_by_hand() -> None:
    assert lag1(np.array([1.0, 2.0, 3.0])) == pytest.approx((1 * 2 + 2 * 3) / (1 + 4 + 9))
    assert lag1(np.array([1.0, -1.0, 1.0, -1.0])) == pytest.approx(-3 / 4)
    r = np.random.default_rng(1).standard_normal(30)
    assert lag1(r) == pytest.approx(lag1_ref(r))


def test_lag1_of_small_values() -> None:
    assert lag1(np.array([0.1, 0.2, 0.3])) == pytest.approx((0.02 + 0.06) / 0.14)  # Σ r² < 1


def test_lag1_of_zeros_is_zero() -> None:
    assert lag1(np.zeros(5)) == 0.0


@pytest.mark.parametrize("phi", [0.0, 0.6, -0.4, 0.95])
def test_r_times_is_the_ar1_correlation_matrix(phi: float) -> None:
    q = np.random.default_rng(2).standard_normal((9, 3))
    assert r_times(q, phi) == pytest.approx(r_matrix(9, phi) @ q)
    assert r_times(q[:, 0], phi) == pytest.approx(r_matrix(9, phi) @ q[:, 0])


def test_half_shift_is_half_the_off_diagonals() -> None:
    v = np.random.default_rng(3).standard_normal((7, 2))
    got = serial._half_shift(v)
    assert got == pytest.approx(a_matrix(7) @ v)
    assert float(v[:, 0] @ got[:, 0]) == pytest.approx(sum(v[t, 0] * v[t + 1, 0] for t in range(6)))


# ---------------------------------------------------------------- expected residual lag-1 autocorrelation


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.9, -0.5])
def test_expected_lag1_is_the_trace_ratio(phi: float) -> None:
    q = line_basis(15)
    assert expected_lag1(q, phi) == pytest.approx(expected_lag1_ref(q, phi), abs=1e-12)
    q3, _ = np.linalg.qr(np.random.default_rng(4).standard_normal((12, 3)))
    assert expected_lag1(q3, phi) == pytest.approx(expected_lag1_ref(q3, phi), abs=1e-12)


def test_expected_lag1_without_fitted_model_is_phi() -> None:
    # M = I: tr(A R) / tr(R) = (n − 1) φ / n
    q = np.zeros((10, 0))
    assert expected_lag1(q, 0.7) == pytest.approx(9 * 0.7 / 10)


def test_expected_lag1_with_one_residual_direction() -> None:
    # Q spans all but the unit vector m: M = m mᵀ, tr(M A M R) / tr(M R) = mᵀ A m (tr(M R) = mᵀ R m < 1 here)
    n = 6
    m = np.array([1.0, -1, 1, -1, 1, -1]) / math.sqrt(n)
    full, _ = np.linalg.qr(np.column_stack([m, np.eye(n)[:, : n - 1]]))
    q = full[:, 1:]
    assert float(m @ r_matrix(n, 0.5) @ m) < 1
    assert expected_lag1(q, 0.5) == pytest.approx(-(n - 1) / n)


def test_expected_lag1_when_the_model_fits_every_point() -> None:
    assert expected_lag1(np.eye(6), 0.5) == 0.0  # no residual left: tr(M R) = 0


# ---------------------------------------------------------------- matched φ


@pytest.mark.parametrize(("phi", "seed"), [(0.7, 5), (0.3, 6), (0.0, 7), (-0.4, 8)])
def test_matched_phi_solves_expected_equals_observed(phi: float, seed: int) -> None:
    resid, q = residual_of_line(ar1_series(120, phi, seed))
    want = matched_ref(resid, q, -PHI_MAX)
    got = matched_phi(resid, q)
    assert got == pytest.approx(want, abs=2e-4)
    # the fitted line biases the raw r₁ low; the matched φ removes that bias
    assert got > lag1_ref(resid)


def test_matched_phi_on_a_short_run_with_a_large_bias() -> None:
    # 10 points, 3 fitted columns: the expectation's slope is far from 1, several fixed-point steps needed
    resid, q = residual_of_line(ar1_series(10, 0.6, 9))
    q, _ = np.linalg.qr(np.column_stack([q, np.arange(10.0) ** 2]))
    resid = resid - q @ (q.T @ resid)
    want = matched_ref(resid, q, -PHI_MAX)
    assert matched_phi(resid, q) == pytest.approx(want, abs=2e-3)


def test_matched_phi_on_a_long_run_takes_a_few_evaluations(monkeypatch: pytest.MonkeyPatch) -> None:
    # the bias is O(p / n): the fixed point φ ← φ − gap(φ) reaches 1e-3 in a few steps, far fewer evaluations
    # of the expectation (an n × p product each) than a bracketing search
    resid, q = residual_of_line(ar1_series(400, 0.8, 20))
    calls = []
    exact = serial.expected_lag1
    monkeypatch.setattr(serial, "expected_lag1", lambda *a: calls.append(1) or exact(*a))
    got = matched_phi(resid, q)
    assert got == pytest.approx(matched_ref(resid, q, -PHI_MAX), abs=1e-4)
    assert len(calls) <= 4


def test_matched_phi_is_capped_at_phi_max() -> None:
    resid, q = residual_of_line(np.cumsum(np.cumsum(np.random.default_rng(10).standard_normal(60))))
    assert expected_lag1_ref(q, PHI_MAX) < lag1_ref(resid)
    assert matched_phi(resid, q) == PHI_MAX


def test_matched_phi_below_low_is_nan() -> None:
    resid, q = residual_of_line(ar1_series(100, -0.5, 11))
    assert expected_lag1_ref(q, 0.1) > lag1_ref(resid)
    assert math.isnan(matched_phi(resid, q, low=0.1))
    assert not math.isnan(matched_phi(resid, q))  # from the default −PHI_MAX it is found


def test_matched_phi_at_the_low_bound_exactly_is_nan() -> None:
    # white residual whose r₁ equals the expectation at low: gap(low) = 0 -> nan
    resid, q = residual_of_line(ar1_series(80, 0.2, 12))
    low = matched_ref(resid, q, -PHI_MAX)
    assert math.isnan(matched_phi(resid, q, low=low + 1e-9))
    assert matched_phi(resid, q, low=low - 0.05) == pytest.approx(low, abs=2e-4)


def test_matched_phi_with_low_at_or_above_phi_max_is_nan() -> None:
    resid, q = residual_of_line(np.cumsum(np.cumsum(np.random.default_rng(10).standard_normal(60))))
    assert math.isnan(matched_phi(resid, q, low=PHI_MAX))
    assert matched_phi(resid, q, low=PHI_MAX - 0.01) == PHI_MAX


# ---------------------------------------------------------------- AR(1) coefficient of a run


def test_ar1_coefficient_of_a_correlated_run() -> None:
    resid, q = residual_of_line(ar1_series(200, 0.6, 13))
    want = matched_ref(resid, q, PHI_Z / math.sqrt(200))
    assert want > 0.4
    assert ar1_coefficient(resid, q) == pytest.approx(want, abs=2e-4)


def test_ar1_coefficient_is_zero_below_the_detection_gate() -> None:
    # matched φ ≈ 0.1: positive but φ·√n < 2.33 -> taken as none
    resid, q = residual_of_line(ar1_series(200, 0.1, 14))
    own = matched_ref(resid, q, -PHI_MAX)
    assert 0 < own * math.sqrt(200) < PHI_Z
    assert ar1_coefficient(resid, q) == 0.0


def test_ar1_coefficient_of_a_negatively_correlated_run_is_zero() -> None:
    resid, q = residual_of_line(ar1_series(200, -0.6, 15))
    assert ar1_coefficient(resid, q) == 0.0


def test_ar1_coefficient_needs_8_points_on_its_own() -> None:
    resid8, q8 = residual_of_line(np.array([0.0, 1, 2, 3, 4, 3, 2, 1]) ** 2)
    want = matched_ref(resid8, q8, PHI_Z / math.sqrt(8))
    assert want > 0.8
    assert ar1_coefficient(resid8, q8) == pytest.approx(want, abs=1e-3)
    resid7, q7 = residual_of_line(np.array([0.0, 1, 2, 3, 2, 1, 0]) ** 2)
    assert lag1_ref(resid7) > 0.3
    assert ar1_coefficient(resid7, q7) == 0.0


def test_ar1_coefficient_pools_earlier_runs_by_their_points() -> None:
    resid, q = residual_of_line(ar1_series(200, 0.6, 13))
    own = matched_ref(resid, q, -PHI_MAX)
    history = (Ar1Estimate(0.9, 300, 1.0, "a"), Ar1Estimate(0.5, 100, None, "b"))
    # run a at this run's 2 s interval: 0.9² ; run b without times: as is
    want = (0.81 * 300 + 0.5 * 100 + own * 200) / 600
    assert ar1_coefficient(resid, q, history, 2.0) == pytest.approx(want, abs=1e-4)


def test_ar1_coefficient_of_a_short_run_takes_the_history_alone() -> None:
    history = (Ar1Estimate(0.5, 50, None),)
    assert ar1_coefficient(np.array([1.0, -1.0, 1.0]), np.zeros((3, 0)), history) == pytest.approx(0.5)
    # 7 points: its own estimate is not used
    resid7, q7 = residual_of_line(np.array([0.0, 1, 2, 3, 2, 1, 0]) ** 2)
    assert ar1_coefficient(resid7, q7, history) == pytest.approx(0.5)


def test_ar1_coefficient_own_estimate_with_history_is_not_gated_alone() -> None:
    # 8 points: its own φ counts in the pool even though φ·√8 alone is below the gate
    resid8, q8 = residual_of_line(ar1_series(8, 0.0, 16))
    own = matched_ref(resid8, q8, -PHI_MAX)
    history = (Ar1Estimate(0.6, 40, None),)
    want = (0.6 * 40 + own * 8) / 48
    assert want * math.sqrt(48) > PHI_Z
    assert ar1_coefficient(resid8, q8, history) == pytest.approx(want, abs=1e-3)


def test_ar1_coefficient_drops_estimates_without_a_value() -> None:
    history = (Ar1Estimate(math.nan, 1000, None), Ar1Estimate(0.5, 50, None))
    assert ar1_coefficient(np.zeros(3), np.zeros((3, 0)), history) == pytest.approx(0.5)


def test_ar1_coefficient_with_history_of_no_points_is_zero() -> None:
    assert ar1_coefficient(np.zeros(3), np.zeros((3, 0)), (Ar1Estimate(0.5, 0, None),)) == 0.0


def test_ar1_coefficient_pooled_is_capped_and_gated() -> None:
    zeros = np.zeros(3), np.zeros((3, 0))
    assert ar1_coefficient(*zeros, (Ar1Estimate(0.99, 100, None),)) == PHI_MAX
    assert ar1_coefficient(*zeros, (Ar1Estimate(0.2, 100, None),)) == 0.0  # 0.2·√100 = 2 < 2.33
    assert ar1_coefficient(*zeros, (Ar1Estimate(0.3, 100, None),)) == pytest.approx(0.3)
    assert 0.466 * math.sqrt(25) == PHI_Z  # exactly at the gate: not beyond it
    assert ar1_coefficient(*zeros, (Ar1Estimate(0.466, 25, None),)) == 0.0
    assert ar1_coefficient(*zeros, (Ar1Estimate(-0.5, 100, None),)) == 0.0


def test_ar1_coefficient_converts_history_to_this_runs_interval() -> None:
    zeros = np.zeros(3), np.zeros((3, 0))
    history = (Ar1Estimate(0.8, 400, 0.5),)
    assert ar1_coefficient(*zeros, history, 1.0) == pytest.approx(0.64)
    assert ar1_coefficient(*zeros, history, None) == pytest.approx(0.8)


# ---------------------------------------------------------------- Prais–Winsten


def test_prais_winsten_rows_by_hand() -> None:
    v = np.array([10.0, 1.0, 4.0, 2.0])
    order = np.array([1, 3, 2, 0])  # in time: 1, 2, 4, 10
    phi = 0.6
    want = [math.sqrt(1 - 0.36) * 1.0, 2.0 - 0.6 * 1.0, 4.0 - 0.6 * 2.0, 10.0 - 0.6 * 4.0]
    assert prais_winsten(v, order, phi) == pytest.approx(want)
    assert v.tolist() == [10.0, 1.0, 4.0, 2.0]  # input untouched


def test_prais_winsten_of_a_design_matrix() -> None:
    x = np.array([[1.0, 0.0], [1.0, 3.0], [1.0, 1.0]])
    order = np.array([0, 2, 1])
    phi = -0.5
    c = math.sqrt(1 - 0.25)
    want = np.array([[c * 1.0, c * 0.0], [1.0 + 0.5, 1.0 + 0.5 * 0.0], [1.0 + 0.5, 3.0 + 0.5 * 1.0]])
    assert prais_winsten(x, order, phi) == pytest.approx(want)


def test_prais_winsten_without_correlation_only_orders() -> None:
    v = np.array([3.0, 1.0, 2.0])
    assert prais_winsten(v, np.array([1, 2, 0]), 0.0).tolist() == [1.0, 2.0, 3.0]


def test_prais_winsten_at_phi_one_differences() -> None:
    # φ = 1: first row weight √(1 − 1) = 0, the others first differences
    v = np.array([1.0, 4.0, 9.0])
    assert prais_winsten(v, np.arange(3), 1.0).tolist() == [0.0, 3.0, 5.0]


# ---------------------------------------------------------------- Ljung–Box


def ljung_box_ref(x: np.ndarray, h: int, df: int) -> tuple[float, float]:
    n = len(x)
    d = x - sum(x) / n
    den = sum(d * d)
    q = n * (n + 2) * sum((sum(d[t] * d[t + k] for t in range(n - k)) / den) ** 2 / (n - k) for k in range(1, h + 1))
    return q, chi2.sf(q, df)


@pytest.mark.parametrize(("n", "lags", "fitted", "h", "df"), [
    (40, 10, 0, 10, 10),
    (40, 10, 3, 10, 7),
    (20, 10, 0, 5, 5),  # at most n/4 lags
    (23, 10, 0, 5, 5),
    (40, 1, 0, 1, 1),
    (12, 10, 2, 3, 1),
    (12, 10, 5, 3, 1),  # at least one degree of freedom
    (8, 10, 0, 2, 2),  # 8 points: tested
])
def test_ljung_box_by_formula(n: int, lags: int, fitted: int, h: int, df: int) -> None:
    x = 5.0 + ar1_series(n, 0.5, n + lags + fitted)  # a mean far from 0: removed before the correlations
    q_want, p_want = ljung_box_ref(x, h, df)
    q, p, got_h = ljung_box(x, lags, fitted)
    assert got_h == h
    assert q == pytest.approx(q_want, rel=1e-12)
    assert p == pytest.approx(p_want, rel=1e-9)


def test_ljung_box_of_a_small_series() -> None:
    x = 1e-3 * ar1_series(30, 0.5, 19)  # Σ (x − x̄)² far below 1
    q_want, p_want = ljung_box_ref(x, 7, 7)
    q, p, h = ljung_box(x, 10)
    assert (h, q, p) == (7, pytest.approx(q_want, rel=1e-9), pytest.approx(p_want, rel=1e-9))


def test_ljung_box_detects_correlation() -> None:
    _, p, _ = ljung_box(ar1_series(200, 0.7, 17), 10)
    assert p < 1e-6
    _, p, _ = ljung_box(np.random.default_rng(18).standard_normal(200), 10)
    assert p > 0.01


@pytest.mark.parametrize(("x", "h"), [
    (np.array([1.0, 3.0, 2.0, 5.0, 4.0, 6.0, 0.0]), 1),  # fewer than 8 points
    (np.full(12, 4.0), 3),  # constant: nothing to correlate
    (np.array([2.0]), 1),
])
def test_ljung_box_untestable(x: np.ndarray, h: int) -> None:
    assert ljung_box(x, 10) == (0.0, 1.0, h)
