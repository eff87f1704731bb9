"""Table building and residual after compensation (processing/compensation/tables.py,
residuals.py); expected values computed by hand."""

from __future__ import annotations

import numpy as np
import pytest

from processing.compensation.models import polynomial_degree
from processing.compensation.residuals import ResidualStats, compare_models, format_comparison
from processing.compensation.tables import build_table, equidistant_grid, split_directions

TARGET = np.array([0.0, 100.0, 200.0, 300.0])
UP = np.array([1.0, 3.0, 2.0, -1.0])
DOWN = np.array([-1.0, 0.0, 1.0, -4.0])


def test_bidirectional_table_keeps_both_curves() -> None:
    t = build_table(TARGET, UP, DOWN, model="linear")
    np.testing.assert_array_equal(t.position, TARGET)
    np.testing.assert_allclose(t.directional()[0], UP)
    np.testing.assert_allclose(t.directional()[1], DOWN)
    t = build_table(TARGET, UP, DOWN, positions=np.array([50.0, 250.0, 400.0]))
    np.testing.assert_allclose(t.error_up, [2.0, 0.5, -1.0])  # held beyond the last target
    np.testing.assert_allclose(t.error_down, [-0.5, -1.5, -4.0])


def test_backlash_mode_is_mean_curve_plus_mean_reversal() -> None:
    t = build_table(TARGET, UP, DOWN, mode="backlash")
    # B_i = up − down = 2, 3, 1, 3 → B̄ = 2.25; mean curve 0, 1.5, 1.5, −2.5
    assert t.backlash == pytest.approx(2.25)
    np.testing.assert_allclose(t.error_up, [0.0, 1.5, 1.5, -2.5])
    e_up, e_dn = t.directional()
    np.testing.assert_allclose(e_up, [1.125, 2.625, 2.625, -1.375])
    np.testing.assert_allclose(e_dn, [-1.125, 0.375, 0.375, -3.625])


def test_unmeasured_directions() -> None:
    d = split_directions(TARGET, UP, np.array([np.nan, 0.0, 1.0, np.nan]))
    np.testing.assert_array_equal(d.x_down, [100.0, 200.0])
    d = split_directions(TARGET, UP, np.full(4, np.nan))  # unidirectional run: same curve both ways
    np.testing.assert_array_equal(d.e_down, UP)
    with pytest.raises(ValueError, match="no measured"):
        split_directions(TARGET, np.full(4, np.nan), np.full(4, np.nan))
    with pytest.raises(ValueError, match="at least 2 targets measured in both"):
        build_table(TARGET, UP, np.array([np.nan, np.nan, np.nan, 1.0]), mode="backlash")


def test_equidistant_grid_covers_the_range_from_its_anchor() -> None:
    np.testing.assert_allclose(equidistant_grid(0.0, 300.0, 100.0), [0, 100, 200, 300])
    np.testing.assert_allclose(equidistant_grid(0.0, 250.0, 100.0), [0, 100, 200, 300])
    np.testing.assert_allclose(equidistant_grid(-30.0, 120.0, 50.0, anchor=0.0), [-50, 0, 50, 100, 150])
    with pytest.raises(ValueError):
        equidistant_grid(0.0, 1.0, 0.0)


def test_residual_statistics_by_hand() -> None:
    # degree-0 polynomial = mean 1/3 of (0, 1, 0); residuals −1/3, 2/3, −1/3 in both directions
    df = compare_models(np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 1.0, 0.0]),
                        models=["polynomial", "linear"], degree=0)
    none, poly, lin = (df.iloc[i] for i in range(3))
    assert none.model == "none" and none.max_abs == pytest.approx(1.0) and none.range == pytest.approx(1.0)
    assert poly.max_abs == pytest.approx(2 / 3) and poly.range == pytest.approx(1.0)
    assert poly.rms == pytest.approx(np.sqrt(2 / 9))
    assert lin.max_abs == pytest.approx(0.0) and lin.reduction_pct == pytest.approx(100.0)
    assert "polynomial" in format_comparison(df, "um")


def test_a_model_that_cannot_be_fitted_is_reported_not_fatal() -> None:
    # backlash mode needs 2 targets measured in both directions; here only the last one is
    down = np.array([np.nan, np.nan, np.nan, 1.0])
    df = compare_models(TARGET, UP, down, models=["linear", "polynomial"], mode="backlash")
    poly = df.set_index("model").loc["polynomial"]
    assert np.isnan(poly.max_abs) and "at least 2 targets measured in both" in poly.note
    assert "not fitted: backlash mode needs" in format_comparison(df, "um")


def test_polynomial_degree_drops_to_n_minus_2_when_targets_are_few() -> None:
    assert polynomial_degree(6, 5) == 3 and polynomial_degree(6, 2) == 1 and polynomial_degree(6, 3) == 1
    assert polynomial_degree(2, 10) == 2 and polynomial_degree(0, 3) == 0
    # 4 targets, degree 6 requested → degree 2: the residual is that of the least-squares parabola
    df = compare_models(TARGET, UP, UP, models=["polynomial"], degree=6)
    poly = df.iloc[1]
    x = TARGET / 100.0
    a = np.vstack([np.ones(4), x, x**2]).T  # normal equations of the parabola, solved independently
    coef = np.linalg.solve(a.T @ a, a.T @ UP)
    r = UP - a @ coef
    assert poly.note == "" and "degree 2 (of 6 requested" in poly.detail
    assert poly.max_abs == pytest.approx(np.max(np.abs(r))) and poly.rms == pytest.approx(np.sqrt(np.mean(r**2)))
    assert "degree 2" in format_comparison(df, "um")


def test_residual_on_a_coarser_controller_grid() -> None:
    # linear model on a 0/300 grid: the table is the chord from 1 (up) to −1; at 100 and 200 the
    # chord is 1/3 and −1/3, so the residuals are 0, 3 − 1/3, 2 + 1/3, 0.
    df = compare_models(TARGET, UP, UP, models=["linear"], positions=np.array([0.0, 300.0]))
    lin = df.iloc[1]
    assert lin.table_points == 2
    assert lin.max_abs == pytest.approx(8 / 3) and lin.range == pytest.approx(8 / 3)
    assert lin.rms == pytest.approx(np.sqrt((64 / 9 + 49 / 9) / 4))
    assert ResidualStats.of(np.array([3.0, -4.0])).rms == pytest.approx(np.sqrt(12.5))


def test_a_nan_target_is_refused() -> None:
    with pytest.raises(ValueError, match="finite"):
        split_directions(np.array([0.0, np.nan, 2.0]), np.zeros(3), np.zeros(3))


def test_equidistant_grid_inside_the_range_never_reaches_outside() -> None:
    # 4.404 … 995.31 mm with a 247.726 mm step: 4 steps end at 995.308, a fifth would be 1243.034
    np.testing.assert_allclose(equidistant_grid(4.404, 995.31, 247.726, inside=True),
                               [4.404, 252.13, 499.856, 747.582, 995.308])
    np.testing.assert_allclose(equidistant_grid(0.0, 300.0, 100.0, inside=True), [0, 100, 200, 300])
    np.testing.assert_allclose(equidistant_grid(-30.0, 120.0, 50.0, anchor=0.0, inside=True), [0, 50, 100])
    np.testing.assert_allclose(equidistant_grid(12.0, 95.0, 20.0, anchor=500.0, inside=True), [20, 40, 60, 80])
