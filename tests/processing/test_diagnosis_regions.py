"""Where the residual stands out (processing/diagnosis/select.py, disagreement): the time groups.

Every expected value is written here from the definition: the points in time order split into
at most 8 consecutive groups, a group's z = its mean residual / (sigma / sqrt(its size)), and a
group stands out beyond the two-sided Bonferroni limit z_c = Phi^-1(1 - alpha / (2 groups))."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.stats import norm

from processing.diagnosis.observations import positioning_observations
from processing.diagnosis.select import disagreement


def observations(n: int):
    """n points of one bidirectional run, 10 s apart, targets 0, 100, 200 ... mm."""
    half = n // 2
    idx = list(range(half)) + list(range(n - half - 1, -1, -1))
    points = pd.DataFrame({"run": [1] * n, "direction": [1] * half + [-1] * (n - half), "target_index": idx,
                           "target_mm": [100.0 * i for i in idx], "time_s": 10.0 * np.arange(n)})
    return positioning_observations(points, np.zeros(n), None)


@pytest.mark.parametrize("n", [3, 4, 5, 6, 7])
def test_a_run_of_fewer_than_8_points_has_one_time_group_per_point(n: int) -> None:
    # 3 .. 7 points used to leave empty time bins, and their labels failed ("zero-size array")
    obs = observations(n)
    residual = np.zeros(n)
    residual[1] = 10.0  # sigma 1: z = 10 for the second point's group alone
    got = disagreement(obs, residual, 1.0)["time"]
    assert got["groups"] == n
    assert got["z_limit"] == pytest.approx(norm.isf(0.05 / (2 * n)))
    assert [(g["group"], g["n"], g["mean_um"], g["z"]) for g in got["stand_out"]] == [("10.0-10.0 s", 1, 10.0, 10.0)]


def test_eight_points_or_more_split_into_8_time_groups() -> None:
    obs = observations(12)  # 12 points in 8 groups: k * 8 // 12 -> sizes 2, 1, 2, 1, 2, 1, 2, 1
    residual = np.zeros(12)
    residual[:2] = 4.0  # the first group (0 and 10 s): mean 4, z = 4 sqrt(2)
    got = disagreement(obs, residual, 1.0)["time"]
    assert got["groups"] == 8
    assert got["stand_out"] == [{"group": "0.0-10.0 s", "n": 2, "mean_um": 4.0, "z": pytest.approx(4 * np.sqrt(2))}]
