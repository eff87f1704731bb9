"""The Monte Carlo u of the ISO 230-2 values (saved_runs/evaluation/value_uncertainty.py) against cases whose
u is known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from processing.iso230_2 import iso230_2_from_arrays
from saved_runs.evaluation.value_uncertainty import axis_value_spread


def result_with(means_up: list[float], s_up: list[float], n: int, *, means_down: list[float] | None = None):
    """A result whose per-target means and s are exactly the given ones: n approaches x̄ ± s·z with z a fixed
    zero-mean, unit-s pattern."""
    z = np.arange(n) - (n - 1) / 2
    z = z / np.std(z, ddof=1)
    spread = np.array(s_up)[:, None] * z[None, :]
    up = np.array(means_up)[:, None] + spread
    down = np.full_like(up, np.nan) if means_down is None else np.array(means_down)[:, None] + spread
    return iso230_2_from_arrays(np.arange(len(means_up)) * 100.0, up, down)


def test_u_of_a_range_and_of_a_repeatability() -> None:
    n = 5
    r = result_with([0.0, 100.0, 50.0], [1.0, 2.0, 0.01], n)
    assert r.per_target["s_up"].tolist() == pytest.approx([1.0, 2.0, 0.01])
    spread = axis_value_spread(r, trials=1000)
    # E_up = x̄_2 - x̄_1 (the extremes never swap): u = sqrt(s_1^2/n + s_2^2/n)
    assert spread.u["E_up"] == pytest.approx(math.sqrt((1.0 + 4.0) / n), rel=0.08)
    assert spread.expected["E_up"] == pytest.approx(100.0, abs=0.1)
    # R_up = 2 k max s = 4 s_2 (s_2 is far the largest): u = 4 u(s), u(s) = s sqrt(1 - c4^2) for a normal sample
    c4 = math.sqrt(2 / (n - 1)) * math.gamma(n / 2) / math.gamma((n - 1) / 2)
    assert spread.u["R_up"] == pytest.approx(4 * 2.0 * math.sqrt(1 - c4**2), rel=0.08)
    # a one-direction run has no E: no u
    assert spread.u["E"] is None
    # a prediction from means that carry their own noise: the variance of a repeat doubles
    twice = axis_value_spread(r, means_uncertain=True, trials=1000)
    assert twice.u["E_up"] == pytest.approx(math.sqrt(2 * (1.0 + 4.0) / n), rel=0.08)


def test_the_range_of_noisy_means_is_biased_upwards() -> None:
    # all means 0: E at the means is 0, a repeat shows the range of 6 noisy means (expected ~2.53 sigma)
    n, s = 4, 1.0
    r = result_with([0.0, 0.0, 0.0], [s] * 3, n, means_down=[0.0, 0.0, 0.0])
    assert r.axis["E"] == pytest.approx(0.0, abs=1e-12)
    spread = axis_value_spread(r, trials=1000)
    sigma = s / math.sqrt(n)
    # expected range of 6 standard normal values: d2(6) = 2.534 (control-chart constant)
    assert spread.expected["E"] == pytest.approx(2.534 * sigma, rel=0.06)
