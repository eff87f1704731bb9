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


def exhaustive_zone(x: np.ndarray, h: np.ndarray) -> float:
    """The least vertical spread over every line through two points of distinct x, vectorised over
    the pairs (O(N^3) work, exact): the minimum zone has a hull edge, so a pair of points, on one side."""
    i, j = np.triu_indices(len(x), 1)
    keep = x[i] != x[j]
    i, j = i[keep], j[keep]
    best = np.inf
    for s in range(0, len(i), 2000):
        b = (h[j[s:s + 2000]] - h[i[s:s + 2000]]) / (x[j[s:s + 2000]] - x[i[s:s + 2000]])
        r = h[None, :] - b[:, None] * x[None, :]
        best = min(best, float(np.min(r.max(axis=1) - r.min(axis=1))))
    return best


def _profiles(rng: np.random.Generator, n: int, kind: int, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """``rows`` random profiles of ``n`` points sharing one x, of several shapes."""
    x = np.arange(n) * 25.0
    if kind == 0:    # noise
        h = rng.normal(0, 2, (rows, n))
    elif kind == 1:  # wave + noise + a tilt per row
        h = (3 * np.sin(x / 700.0) + rng.normal(0, 0.2, (rows, n)) + rng.normal(0, 1e-3, (rows, 1)) * x)
    elif kind == 2:  # integer heights: many collinear triples
        h = rng.integers(-2, 3, (rows, n)).astype(float)
    else:            # smooth, every point on a hull (a parabola), some rows exactly straight
        h = 1e-5 * (x - x.mean()) ** 2 * rng.choice([-1.0, 0.0, 1.0], (rows, 1)) + 0.01 * x
    return x, h


@pytest.mark.parametrize("n", [2, 3, 4, 7, 20, 41, 200])
def test_many_equals_the_exhaustive_width(n: int) -> None:
    """The vectorised hulls give the exhaustive pair width, on noise, waves, collinear grids and curves."""
    rng = np.random.default_rng(100 + n)
    for kind in range(4):
        x, rows = _profiles(rng, n, kind, 40)
        many = minimum_zone_many(x, rows)
        for row, value in zip(rows, many, strict=True):
            assert value == pytest.approx(exhaustive_zone(x, row), abs=1e-9), (kind, row)


@pytest.mark.parametrize("n", [2, 3, 25, 200, 2001, 2500])
def test_many_equals_the_single_profile_function(n: int) -> None:
    """Row by row as minimum_zone_line (the single-profile hull; qhull above 2,000 points) to 1e-12 um."""
    rng = np.random.default_rng(n)
    for kind in range(4):
        x, rows = _profiles(rng, n, kind, 30 if n > 1000 else 200)
        many = minimum_zone_many(x, rows)
        single = np.array([minimum_zone_line(x, row).straightness_um for row in rows])
        assert np.max(np.abs(many - single)) <= 1e-12, kind


def test_many_above_2000_points_equals_the_exhaustive_width() -> None:
    """> 2,000 points: the exhaustive width over every pair of qhull's hull vertices (a zone side passes
    through two of them; qhull is independent of the code under test), the spread over all points."""
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(77)
    for kind in (0, 1):
        x, rows = _profiles(rng, 2100, kind, 3)
        for row, value in zip(rows, minimum_zone_many(x, rows), strict=True):
            v = np.unique(ConvexHull(np.column_stack([x / x[-1], row / np.ptp(row)])).vertices)
            best = min(float(np.ptp(row - (row[j] - row[i]) / (x[j] - x[i]) * x))
                       for i, j in itertools.combinations(v, 2))
            assert value == pytest.approx(best, abs=1e-9)


def test_many_with_repeated_x_and_unsorted_x() -> None:
    """A forward and a return reading at one station (repeated x), x in any order: the highest reading
    of an x bounds the zone from above, the lowest from below, as for the exhaustive width."""
    rng = np.random.default_rng(5)
    for _ in range(40):
        n = int(rng.integers(3, 30))
        x = rng.integers(0, max(2, n // 2), n).astype(float) * 10.0
        if np.all(x == x[0]):
            x[-1] += 10.0
        rows = rng.normal(0, 1, (5, n))
        many = minimum_zone_many(x, rows)
        for row, value in zip(rows, many, strict=True):
            assert value == pytest.approx(exhaustive_zone(x, row), abs=1e-9)
            assert value == pytest.approx(minimum_zone_line(x, row).straightness_um, abs=1e-12)


def test_many_does_not_depend_on_the_block_it_is_given_in(monkeypatch: pytest.MonkeyPatch) -> None:
    """A trial's value is the same evaluated alone or among many (the Monte Carlo chunks its trials)."""
    rng = np.random.default_rng(8)
    x, rows = _profiles(rng, 60, 1, 300)
    whole = minimum_zone_many(x, rows)
    monkeypatch.setattr(reference_lines, "MANY_BLOCK_ELEMENTS", 7 * 60)
    assert np.array_equal(minimum_zone_many(x, rows), whole)
    assert np.array_equal(np.concatenate([minimum_zone_many(x, rows[k:k + 1]) for k in range(5)]), whole[:5])


def test_many_refuses_bad_input() -> None:
    with pytest.raises(ValueError, match="same x"):
        minimum_zone_many(np.zeros(3), np.ones((2, 3)))
    with pytest.raises(ValueError, match="finite"):
        minimum_zone_many(np.arange(3.0), np.array([[0.0, np.nan, 1.0]]))
    with pytest.raises(ValueError, match="one column per x"):
        minimum_zone_many(np.arange(3.0), np.ones((2, 4)))
