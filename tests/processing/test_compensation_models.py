"""Error-curve models (processing/compensation/models.py).

Expected values come from hand computations, from the worked sketches in standards.md §5.1 /
§5.2, or from a natural cubic spline solved here from its defining tridiagonal system.
"""

from __future__ import annotations

import numpy as np
import pytest

from processing.compensation.models import (
    curvature_maxima,
    fit_adaptive_spline,
    fit_linear,
    fit_model,
    fit_polynomial,
    fit_segments,
    segment_breakpoints,
)


def natural_cubic_spline(xk: np.ndarray, yk: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Natural cubic spline through (xk, yk) evaluated at x, from first principles: solve for
    the knot second derivatives M (M_0 = M_n = 0) of the C² conditions
    h_{i-1} M_{i-1} + 2(h_{i-1}+h_i) M_i + h_i M_{i+1} = 6(g_i − g_{i-1})."""
    n = len(xk) - 1
    h = np.diff(xk)
    g = np.diff(yk) / h
    m = np.zeros(n + 1)
    if n > 1:
        a = np.zeros((n - 1, n - 1))
        for i in range(1, n):
            a[i - 1, i - 1] = 2 * (h[i - 1] + h[i])
            if i > 1:
                a[i - 1, i - 2] = h[i - 1]
            if i < n - 1:
                a[i - 1, i] = h[i]
        m[1:n] = np.linalg.solve(a, 6 * (g[1:] - g[:-1]))
    j = np.clip(np.searchsorted(xk, x, side="right") - 1, 0, n - 1)
    t0, t1 = x - xk[j], xk[j + 1] - x
    return (m[j] * t1**3 + m[j + 1] * t0**3) / (6 * h[j]) + (yk[j] / h[j] - m[j] * h[j] / 6) * t1 + (
        yk[j + 1] / h[j] - m[j + 1] * h[j] / 6
    ) * t0


# A polyline with corners at indices 10, 25 and 40, slopes 0, 0.25, -0.5, -0.375 per point (dyadic,
# so the finite differences are exact).  Curvature over the point index (uniform parameter), by
# hand: κ_10 = 0.125/1.0156^1.5 = 0.122 (neighbours 0.0625, 0.057), κ_25 = 0.375/1.0156^1.5 = 0.366
# (0.171, 0.134), κ_40 = 0.0625/1.191^1.5 = 0.048 (0.022, 0.026), zero elsewhere: the maxima are
# the corners, largest first 25, 10, 40.
X_CORNER = np.arange(51) * 10.0
SLOPES = np.r_[np.zeros(10), np.full(15, 0.25), np.full(15, -0.5), np.full(10, -0.375)]
E_CORNER = np.r_[0.0, np.cumsum(SLOPES)]


def test_curvature_maxima_are_the_corners_largest_first() -> None:
    assert list(curvature_maxima(E_CORNER)) == [25, 10, 40]


def test_spline_initial_knots_are_ends_plus_largest_maxima() -> None:
    big = 1e9  # no insertion: the initial knots are the result
    assert list(fit_adaptive_spline(X_CORNER, E_CORNER, tolerance=big, initial_maxima=2).knots) == [0, 10, 25, 50]
    assert list(fit_adaptive_spline(X_CORNER, E_CORNER, tolerance=big, initial_maxima=1).knots) == [0, 25, 50]
    assert list(fit_adaptive_spline(X_CORNER, E_CORNER, tolerance=big).knots) == [0, 10, 25, 40, 50]


def test_spline_matches_first_principles_natural_spline_and_inserts_all_points_over_tolerance() -> None:
    tol = 0.3
    initial = np.array([0, 10, 25, 40, 50])
    s0 = natural_cubic_spline(X_CORNER[initial], E_CORNER[initial], X_CORNER)
    over = np.flatnonzero(np.abs(E_CORNER - s0) > tol)
    assert over.size > 1  # the case exercises batch insertion
    knots1 = np.union1d(initial, over)
    s1 = natural_cubic_spline(X_CORNER[knots1], E_CORNER[knots1], X_CORNER)
    assert np.max(np.abs(E_CORNER - s1)) <= tol  # so the algorithm stops after one insertion pass

    model = fit_adaptive_spline(X_CORNER, E_CORNER, tolerance=tol)
    assert list(model.knots) == list(knots1)
    assert model.iterations == 2
    xq = np.linspace(0, 500, 333)
    np.testing.assert_allclose(model(xq), natural_cubic_spline(X_CORNER[knots1], E_CORNER[knots1], xq), atol=1e-9)


def test_spline_residual_within_tolerance_and_natural_end_conditions() -> None:
    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(0, 360, 40))
    e = 3 * np.sin(np.radians(x)) + np.sin(np.radians(3 * x)) + rng.normal(0, 0.1, x.size)
    for tol in (0.5, 0.2, 0.05, 0.0):
        model = fit_adaptive_spline(x, e, tolerance=tol)
        assert np.max(np.abs(model.residual)) <= tol + 1e-12
        kx = x[model.knots]
        if len(kx) > 2:  # S'' = 0 at both end knots
            assert abs(model.spline(kx[0], 2)) < 1e-9 and abs(model.spline(kx[-1], 2)) < 1e-9


def test_spline_reproduces_the_standards_sketch() -> None:
    # standards.md §5.1: 37 points of 3 sin θ + sin 3θ + 0.2 cos 7θ, tol 0.3 → 14 knots
    th = np.radians(np.linspace(0, 360, 37))
    e = 3 * np.sin(th) + np.sin(3 * th) + 0.2 * np.cos(7 * th)
    assert len(fit_adaptive_spline(np.degrees(th), e, tolerance=0.3).knots) == 14


def test_spline_default_tolerance_is_a_twentieth_of_max_error() -> None:
    assert fit_adaptive_spline(X_CORNER, E_CORNER).tolerance == pytest.approx(np.max(np.abs(E_CORNER)) / 20)


def test_segments_hand_computed_cases() -> None:
    # up 0..4 then down to 0: default τ = 4/20 = 0.2; the LS line through 0..5 misses point 5 by
    # 0.95 (slope 12.5/17.5), so the first segment closes at 4 and the second runs 4..8.
    x = np.arange(9.0)
    e = np.array([0, 1, 2, 3, 4, 3, 2, 1, 0], dtype=float)
    m = fit_segments(x, e)
    assert m.threshold == pytest.approx(0.2)
    assert list(m.breakpoints) == [0, 4, 8] and m.segments == [(0, 4), (4, 8)]
    np.testing.assert_allclose(m(np.array([0, 2, 4, 6, 8, 1.5])), [0, 2, 4, 2, 0, 1.5], atol=1e-12)
    # flat then a ramp: τ = 3/20; adding point 4 to 0..3 gives slope 0.2 and a residual 0.4 at x = 4
    assert list(segment_breakpoints(np.arange(7.0), np.array([0, 0, 0, 0, 1, 2, 3.0]), 0.15)) == [0, 3, 6]


def test_segments_reproduce_the_standards_sketch() -> None:
    # standards.md §5.2: 51 points of 0.01x + 3 sin(x/80), τ = 0.490 → breakpoints 0, 6, 13, 19, 26, 32, 43, 49, 50
    x = np.linspace(0, 1000, 51)
    m = fit_segments(x, 0.01 * x + 3 * np.sin(x / 80))
    assert m.threshold == pytest.approx(0.490, abs=5e-4)
    assert list(m.breakpoints) == [0, 6, 13, 19, 26, 32, 43, 49, 50]


def test_every_point_within_threshold_of_its_segment_and_segments_are_maximal() -> None:
    rng = np.random.default_rng(4)
    x = np.cumsum(rng.uniform(5, 15, 84))
    e = 4 * np.sin(x / 90) + rng.normal(0, 0.3, x.size)
    tau = np.max(np.abs(e)) / 20
    m = fit_segments(x, e)
    assert m.segments[0][0] == 0 and m.segments[-1][1] == len(x) - 1
    for i, j in m.segments:
        coef = np.polyfit(x[i : j + 1], e[i : j + 1], 1)
        assert np.max(np.abs(e[i : j + 1] - np.polyval(coef, x[i : j + 1]))) <= tau + 1e-12
        if j + 1 < len(x):  # the segment could not take one more point
            coef = np.polyfit(x[i : j + 2], e[i : j + 2], 1)
            assert np.max(np.abs(e[i : j + 2] - np.polyval(coef, x[i : j + 2]))) > tau
    assert len(m.nodes) < len(x)  # the point of the exercise: fewer table points


def test_linear_model_interpolates_and_holds_the_ends() -> None:
    m = fit_linear(np.array([0.0, 10.0, 30.0]), np.array([1.0, 3.0, -1.0]))
    np.testing.assert_allclose(m(np.array([-5.0, 0.0, 5.0, 20.0, 30.0, 99.0])), [1, 1, 2, 1, -1, -1])


def test_polynomial_reproduces_its_own_degree() -> None:
    x = np.linspace(-50, 250, 9)
    e = 0.5 - 0.02 * x + 3e-4 * x**2 - 1e-6 * x**3
    m = fit_polynomial(x, e, degree=3)
    np.testing.assert_allclose(m(np.array([-50.0, 17.0, 250.0])), [
        0.5 + 1.0 + 0.75 + 0.125, 0.5 - 0.34 + 0.0867 - 0.004913, 0.5 - 5 + 18.75 - 15.625], atol=1e-9)
    with pytest.raises(ValueError, match="at least 4"):
        fit_polynomial(x[:3], e[:3], degree=3)


def test_fit_model_names_and_bad_input() -> None:
    x, e = np.arange(8.0), np.sin(np.arange(8.0))
    for name in ("linear", "spline", "segments", "polynomial"):
        assert fit_model(name, x, e).name == name
    with pytest.raises(ValueError, match="unknown model"):
        fit_model("nurbs", x, e)
    with pytest.raises(ValueError, match="strictly increasing"):
        fit_linear(np.array([0.0, 0.0, 1.0]), np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        fit_linear(np.array([0.0, 1.0]), np.array([0.0, np.nan]))


def test_spline_on_a_straight_line_needs_only_the_end_knots() -> None:
    x = np.array([0.0, 10.0, 25.0, 40.0, 60.0])
    m = fit_adaptive_spline(x, 1.5 - 0.1 * x, tolerance=1e-9)
    assert list(m.knots) == [0, 4] and m.iterations == 1
    assert m(np.array([30.0]))[0] == pytest.approx(-1.5)


@pytest.mark.parametrize("seed", range(40))
def test_fast_natural_spline_is_scipys_natural_cubic_spline_to_the_bit(seed: int) -> None:
    # fit_adaptive_spline builds its splines without CubicSpline's checks (cross-validation refits
    # hundreds of times); the knot choice compares residuals with the tolerance, so the splines
    # must be the same to the last bit, not only close
    from scipy.interpolate import CubicSpline

    from processing.compensation.models import _natural_spline

    rng = np.random.default_rng(seed)
    x = np.unique(rng.uniform(-50, 1000, int(rng.integers(3, 300))))
    e = rng.normal(0, 1, len(x)) * 10.0 ** rng.uniform(-2, 2)
    knots = np.union1d([0, len(x) - 1], rng.choice(len(x), int(rng.integers(1, len(x) + 1)), replace=False))
    fast, scipy_spline = _natural_spline(x, e, knots), CubicSpline(x[knots], e[knots], bc_type="natural")
    xq = np.linspace(x[0] - 10, x[-1] + 10, 500)
    np.testing.assert_array_equal(fast(xq), scipy_spline(xq))
    np.testing.assert_array_equal(fast(x[knots], 2), scipy_spline(x[knots], 2))


def test_curvature_maxima_are_scipys_strict_relative_maxima() -> None:
    from scipy.signal import argrelextrema

    rng = np.random.default_rng(0)
    e = np.round(rng.normal(0, 1, 400), 1)  # rounded: equal neighbours (plateaus are not maxima)
    # kappa = |e''| / (1 + e'^2)^(3/2) over the point index (standards.md §5.1), central differences
    d1 = np.gradient(e)
    kappa = np.abs(np.gradient(d1)) / (1 + d1**2) ** 1.5
    (idx,) = argrelextrema(kappa, np.greater)
    assert sorted(curvature_maxima(e)) == list(idx)


def test_segment_values_are_the_least_squares_polyline() -> None:
    # the node values solve the least-squares problem over the hat functions of the breakpoints
    # (written here as a dense matrix and solved by numpy's SVD-based lstsq)
    rng = np.random.default_rng(5)
    x = np.unique(rng.uniform(0, 1000, 300))
    e = 4 * np.sin(x / 70) + rng.normal(0, 0.3, len(x))
    model = fit_segments(x, e)
    nodes = model.nodes
    basis = np.stack([np.interp(x, nodes, np.eye(len(nodes))[j]) for j in range(len(nodes))], axis=1)
    expected = np.linalg.lstsq(basis, e, rcond=None)[0]
    np.testing.assert_allclose(model.node_values, expected, rtol=0, atol=1e-11)


@pytest.mark.timeout(20)
def test_spline_with_zero_tolerance_ends_with_every_point_a_knot() -> None:
    # a spline evaluated at its own last knot is off by rounding (~1e-16): with tolerance 0 that
    # point was "over" the tolerance, re-added as a knot it already was, and the fit never ended
    # (guideway export --tolerance 0 hung)
    rng = np.random.default_rng(1)
    x = np.unique(rng.uniform(0, 1000, 40))
    e = rng.normal(0, 3, len(x))
    model = fit_adaptive_spline(x, e, tolerance=0.0)
    assert list(model.knots) == list(range(len(x)))
    np.testing.assert_allclose(model(x), natural_cubic_spline(x, e, x), rtol=0, atol=1e-9)
