"""Reference lines: profiles that do not start at x = 0 and forward/return passes that
measure the same station twice (issue 28).  Expected values from standards.md 2.1/2.2:
the end-point line written out, and the minimum zone by brute force over every pair slope."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from processing.reference_lines import endpoint_line, least_squares_line, minimum_zone_line, minimum_zone_many

# standards.md 2.2 worked example: end-point straightness 2.4 um (slope 0.01 um/mm),
# LS 1.9909 um, minimum zone 1.96667 um
X = np.arange(0.0, 1001.0, 100.0)
Z = np.array([0.0, 2.1, 3.5, 3.0, 4.8, 6.2, 5.1, 6.9, 8.8, 8.1, 10.0])


def endpoint_deviations(x: list[float], z: list[float]) -> list[float]:
    """d_k = z_k - [z_0 + m (x_k - x_0)], m = (z_N - z_0) / (x_N - x_0)."""
    m = (z[-1] - z[0]) / (x[-1] - x[0])
    return [zk - (z[0] + m * (xk - x[0])) for xk, zk in zip(x, z, strict=True)]


def brute_force_zone(x: list[float], z: list[float]) -> float:
    """min over every pair slope (distinct x) of max(z - b x) - min(z - b x)."""
    best = float("inf")
    for i, j in itertools.combinations(range(len(x)), 2):
        if x[i] == x[j]:
            continue
        b = (z[j] - z[i]) / (x[j] - x[i])
        r = [zk - b * xk for xk, zk in zip(x, z, strict=True)]
        best = min(best, max(r) - min(r))
    return best


@pytest.mark.parametrize("x0", [0.0, 250.0, -1300.0, 4000.5])
def test_endpoint_line_of_a_profile_that_does_not_start_at_zero(x0: float) -> None:
    x = X + x0
    z = Z + 7.0  # the first reading is not zero either
    fit = endpoint_line(x, z)
    assert fit.slope_um_per_mm == pytest.approx(0.01, abs=1e-15)
    assert fit.intercept_um == pytest.approx(7.0 - 0.01 * x0, abs=1e-9)
    np.testing.assert_allclose(fit.deviations_um, endpoint_deviations(x.tolist(), z.tolist()), rtol=0, atol=1e-9)
    assert abs(fit.deviations_um[0]) < 1e-9 and abs(fit.deviations_um[-1]) < 1e-9
    assert fit.straightness_um == pytest.approx(2.4, abs=1e-9)


def test_endpoint_line_of_a_descending_profile() -> None:
    """A return pass recorded from the far end: the same line, the same straightness."""
    x, z = (X + 250.0)[::-1], Z[::-1]
    fit = endpoint_line(x, z)
    np.testing.assert_allclose(fit.deviations_um, endpoint_deviations(x.tolist(), z.tolist()), rtol=0, atol=1e-9)
    assert fit.straightness_um == pytest.approx(2.4, abs=1e-9)


def test_endpoint_line_with_equal_end_x_refused() -> None:
    """A forward and return pass ends where it started: no end-point line through one x."""
    x = np.r_[X, X[::-1]]
    with pytest.raises(ValueError, match="same x"):
        endpoint_line(x, np.r_[Z, Z[::-1] + 0.3])


@pytest.mark.parametrize("x0", [0.0, 250.0])
def test_forward_and_return_pass_at_the_same_stations(x0: float) -> None:
    """Every station measured twice (forward, then return with a 0.3-0.6 um offset)."""
    rng = np.random.default_rng(3)
    back = Z[::-1] + 0.3 + rng.uniform(0.0, 0.3, len(Z))
    x = np.r_[X, X[::-1]] + x0
    z = np.r_[Z, back]
    zone = minimum_zone_line(x, z)
    assert zone.straightness_um == pytest.approx(brute_force_zone(x.tolist(), z.tolist()), abs=1e-9)
    assert zone.straightness_um >= 1.96667 - 1e-5  # more points: never narrower than the forward pass's zone
    assert minimum_zone_many(x, z[None, :])[0] == pytest.approx(zone.straightness_um, abs=1e-9)
    # least squares of z on x, written out
    xm, zm = x.mean(), z.mean()
    slope = float(np.sum((x - xm) * (z - zm)) / np.sum((x - xm) ** 2))
    ls = least_squares_line(x, z)
    assert ls.slope_um_per_mm == pytest.approx(slope, rel=1e-12)
    assert ls.intercept_um == pytest.approx(zm - slope * xm, abs=1e-9)
    assert ls.straightness_um >= zone.straightness_um - 1e-12


def test_repeated_x_where_only_the_repeat_sets_the_zone() -> None:
    """Two readings 5 um apart at one station, the rest on a line: the zone is the 5 um
    between them (a vertical edge of the hull), whatever the slope."""
    x = np.array([0.0, 100.0, 200.0, 200.0, 300.0, 400.0]) + 50.0
    z = 0.02 * x + np.array([0.0, 0.0, 0.0, 5.0, 0.0, 0.0])
    assert minimum_zone_line(x, z).straightness_um == pytest.approx(5.0, abs=1e-9)
    assert brute_force_zone(x.tolist(), z.tolist()) == pytest.approx(5.0, abs=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_minimum_zone_with_repeats_against_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    stations = np.sort(rng.choice(np.arange(0.0, 2000.0, 25.0), 12, replace=False)) + 130.0
    x = np.r_[stations, stations[::-1], stations[rng.integers(0, 12, 4)]]
    z = rng.normal(0.0, 2.0, len(x)) + 0.003 * x
    expected = brute_force_zone(x.tolist(), z.tolist())
    assert minimum_zone_line(x, z).straightness_um == pytest.approx(expected, abs=1e-9)
    assert minimum_zone_many(x, z[None, :])[0] == pytest.approx(expected, abs=1e-9)
