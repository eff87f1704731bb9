"""Minimum-zone line: worked example, brute force over every point pair on
random data (both hull paths), and its defining properties."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from processing import reference_lines
from processing.reference_lines import endpoint_line, least_squares_line, minimum_zone_line, minimum_zone_many

X = np.arange(0.0, 1001.0, 100.0)
Z = np.array([0.0, 2.1, 3.5, 3.0, 4.8, 6.2, 5.1, 6.9, 8.8, 8.1, 10.0])


def brute_force_zone(x: np.ndarray, h: np.ndarray) -> float:
    """Smallest vertical zone over every line through two points (O(N^3), exact)."""
    best = np.inf
    for i, j in itertools.combinations(range(len(x)), 2):
        if x[i] == x[j]:
            continue
        b = (h[j] - h[i]) / (x[j] - x[i])
        r = h - b * x
        best = min(best, r.max() - r.min())
    return best


def test_worked_example() -> None:
    """standards.md 2.2: 1.96667 um, slope 0.0086667, edge through points 5 and 8."""
    fit = minimum_zone_line(X, Z)
    assert fit.method == "minimum_zone"
    assert fit.slope_um_per_mm == pytest.approx((8.8 - 6.2) / 300.0, abs=1e-12)
    assert fit.straightness_um == pytest.approx(1.966667, abs=1e-6)
    # centre line: deviations symmetric about zero
    assert fit.deviations_um.max() == pytest.approx(-fit.deviations_um.min())


@pytest.mark.parametrize("force_qhull", [False, True])
def test_against_brute_force_on_random_data(force_qhull: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    if force_qhull:
        monkeypatch.setattr(reference_lines, "QHULL_ABOVE", 3)
    rng = np.random.default_rng(20261122)
    for case in range(300):
        n = int(rng.integers(2, 30))
        kind = case % 3
        if kind == 0:    # scattered
            x = np.sort(rng.uniform(0, 2000, n))
            h = rng.normal(0, 5, n)
        elif kind == 1:  # stations with a sine + noise and a tilt
            x = np.arange(n) * 100.0
            h = 3 * np.sin(x / 200.0 + rng.uniform(0, 6)) + rng.normal(0, 0.3, n) + rng.normal(0, 0.01) * x
        else:            # integer grid: many collinear triples and repeated x
            x = rng.integers(0, 8, n).astype(float) * 50.0
            h = rng.integers(-3, 4, n).astype(float)
            if np.all(x == x[0]):
                continue
        fit = minimum_zone_line(x, h)
        assert fit.straightness_um == pytest.approx(brute_force_zone(x, h), abs=1e-9), (case, x, h)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 100_000).map(lambda v: v / 100), st.floats(-50, 50)),
                min_size=2, max_size=25,
                unique_by=lambda p: p[0]))
def test_hypothesis_against_brute_force(pts: list[tuple[float, float]]) -> None:
    x = np.array([p[0] for p in pts])
    h = np.array([p[1] for p in pts])
    fit = minimum_zone_line(x, h)
    assert fit.straightness_um == pytest.approx(brute_force_zone(x, h), rel=1e-9, abs=1e-9)
    assert fit.straightness_um <= least_squares_line(x, h).straightness_um + 1e-9


@pytest.mark.parametrize("shape", ["noisy-sine", "parabola", "steps"])
def test_large_input_uses_the_same_answer_as_the_small_path(shape: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Prefilter + qhull (large inputs) against the plain monotone chain; a parabola
    puts every point on the hull."""
    rng = np.random.default_rng(4)
    x = np.arange(5000) * 1.0
    h = {"noisy-sine": 2 * np.sin(x / 300.0) + rng.normal(0, 0.2, x.size) + 1e-3 * x,
         "parabola": 1e-6 * (x - 1700.0) ** 2,
         "steps": np.floor(x / 700.0) + rng.integers(0, 2, x.size) * 0.5}[shape]
    big = minimum_zone_line(x, h)
    monkeypatch.setattr(reference_lines, "QHULL_ABOVE", 10**9)
    small = minimum_zone_line(x, h)
    assert big.straightness_um == pytest.approx(small.straightness_um, abs=1e-12)


def test_never_wider_than_the_other_lines_and_collinear_is_zero() -> None:
    rng = np.random.default_rng(9)
    for _ in range(50):
        x = np.arange(12) * 100.0
        h = rng.normal(0, 2, 12)
        mz = minimum_zone_line(x, h).straightness_um
        assert mz <= endpoint_line(x, h).straightness_um + 1e-12
        assert mz <= least_squares_line(x, h).straightness_um + 1e-12
    line = minimum_zone_line(X, 0.5 + 0.002 * X)
    assert line.straightness_um == pytest.approx(0.0, abs=1e-12)
    assert line.slope_um_per_mm == pytest.approx(0.002)


@pytest.mark.parametrize("n", [2, 7, 25, 45])
def test_many_rows_match_the_single_line(n: int) -> None:
    rng = np.random.default_rng(n)
    x = np.arange(n) * 100.0
    rows = rng.normal(0, 2, (60, n)) + np.sin(x / 300.0)
    many = minimum_zone_many(x, rows)
    for row, value in zip(rows, many, strict=True):
        assert value == pytest.approx(brute_force_zone(x, row), abs=1e-9)
