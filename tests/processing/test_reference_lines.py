"""Reference lines against the worked example of standards.md section 2.2 and
invariances that hold for any data."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from processing.reference_lines import endpoint_line, least_squares_line

X = np.arange(0.0, 1001.0, 100.0)
Z = np.array([0.0, 2.1, 3.5, 3.0, 4.8, 6.2, 5.1, 6.9, 8.8, 8.1, 10.0])


def test_worked_example_endpoint() -> None:
    fit = endpoint_line(X, Z)
    assert fit.slope_um_per_mm == pytest.approx(0.01)
    assert fit.straightness_um == pytest.approx(2.4, abs=1e-9)


def test_worked_example_least_squares() -> None:
    fit = least_squares_line(X, Z)
    assert fit.slope_um_per_mm == pytest.approx(0.0089091, abs=1e-7)
    assert fit.intercept_um == pytest.approx(0.8636, abs=1e-4)
    assert fit.straightness_um == pytest.approx(1.9909, abs=1e-4)


def test_least_squares_matches_normal_equations() -> None:
    rng = np.random.default_rng(2)
    x = np.sort(rng.uniform(0, 2000, 30))
    h = rng.normal(0, 3, 30)
    a = np.vstack([np.ones_like(x), x]).T
    coef = np.linalg.solve(a.T @ a, a.T @ h)
    fit = least_squares_line(x, h)
    assert fit.intercept_um == pytest.approx(coef[0]) and fit.slope_um_per_mm == pytest.approx(coef[1])


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-50, 50, allow_nan=False), min_size=3, max_size=40),
    st.floats(-1, 1), st.floats(-100, 100),
)
def test_straightness_is_invariant_to_an_added_line(h: list[float], slope: float, offset: float) -> None:
    x = np.arange(len(h)) * 100.0
    h0 = np.array(h)
    h1 = h0 + offset + slope * x
    for fn in (endpoint_line, least_squares_line):
        assert fn(x, h1).straightness_um == pytest.approx(fn(x, h0).straightness_um, abs=1e-6)


def test_bad_input_is_rejected() -> None:
    with pytest.raises(ValueError):
        endpoint_line(np.array([0.0]), np.array([1.0]))
    with pytest.raises(ValueError):
        least_squares_line(np.array([1.0, 1.0]), np.array([1.0, 2.0]))
    with pytest.raises(ValueError):
        least_squares_line(np.array([0.0, np.nan]), np.array([1.0, 2.0]))
