"""Residual after compensation evaluated at every measured point (each run, each direction):
processing/compensation/residuals.py with the evaluation's ``deviations``.  The synthetic run
has known means and a known run-to-run scatter, so every expected figure follows from the
definitions written here."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from processing.compensation.residuals import (
    MeasuredPoints,
    compare_models,
    format_comparison,
    point_residuals,
)
from processing.compensation.tables import build_table

TARGET = np.array([0.0, 100.0, 200.0, 300.0, 400.0])
CURVE = np.array([0.0, 2.5, 4.0, 1.5, -1.5])  # mean bidirectional curve, um
REVERSAL = np.array([2.0, 3.0, 1.0, 3.0, 1.0])  # B_i = x̄↑ − x̄↓, mean 2.0
UP = CURVE + REVERSAL / 2
DOWN = CURVE - REVERSAL / 2
A_UM = 0.8
OFFSETS = np.array([+A_UM, 0.0, -A_UM])  # run j deviates by OFFSETS[j] from the mean: mean unchanged


def deviations(up: np.ndarray = UP, down: np.ndarray = DOWN) -> pd.DataFrame:
    rows = []
    for direction, means in ((1, up), (-1, down)):
        for run, off in enumerate(OFFSETS, start=1):
            for i, (t, m) in enumerate(zip(TARGET, means, strict=True)):
                rows.append((i + 1, t, direction, run, m + off))
    return pd.DataFrame(rows, columns=["target_index", "target", "direction", "run", "deviation"])


def test_linear_table_leaves_exactly_the_run_to_run_scatter() -> None:
    dev = deviations()
    df = compare_models(TARGET, UP, DOWN, models=["linear"], deviations=dev).set_index("model")
    lin = df.loc["linear"]
    assert df.attrs["basis"] == "points" and df.attrs["n_points"] == 30
    # the table reproduces the means at the targets, so each point keeps its run offset
    assert lin.range == pytest.approx(2 * A_UM)
    assert lin.max_abs == pytest.approx(A_UM)
    assert lin.rms == pytest.approx(np.sqrt(np.mean(OFFSETS**2)))
    assert lin.E == pytest.approx(0.0, abs=1e-12) and lin.M == pytest.approx(0.0, abs=1e-12)
    # ... and at every target, per direction, the range is the scatter range 2a
    table = build_table(TARGET, UP, DOWN, model="linear")
    r = point_residuals(MeasuredPoints.from_deviations(dev), table)
    per_target = pd.Series(r).groupby([dev["target"], dev["direction"]]).agg(lambda v: v.max() - v.min())
    np.testing.assert_allclose(per_target.to_numpy(), 2 * A_UM)
    assert "every measured point (30" in format_comparison(df.reset_index(), "um")


def test_none_row_is_the_raw_deviations() -> None:
    dev = deviations()
    none = compare_models(TARGET, UP, DOWN, models=["linear"], deviations=dev).iloc[0]
    e = dev["deviation"].to_numpy()
    assert none.model == "none"
    assert none.range == pytest.approx(e.max() - e.min())
    assert none.max_abs == pytest.approx(np.abs(e).max())
    assert none.rms == pytest.approx(np.sqrt(np.mean(e**2)))
    # ISO 230-2: E = max − min over all directional means, M = max − min of the bidirectional means
    assert none.E == pytest.approx(np.r_[UP, DOWN].max() - np.r_[UP, DOWN].min())
    assert none.M == pytest.approx(CURVE.max() - CURVE.min())


def test_backlash_mode_leaves_the_reversal_minus_its_mean() -> None:
    dev = deviations()
    lin = compare_models(TARGET, UP, DOWN, models=["linear"], mode="backlash", deviations=dev).iloc[1]
    # table: mean curve ± B̄/2 → compensated means ±(B_i − B̄)/2, each run adds its offset
    half = (REVERSAL - REVERSAL.mean()) / 2
    r = np.concatenate([np.add.outer(OFFSETS, half).ravel(), np.add.outer(OFFSETS, -half).ravel()])
    assert lin.range == pytest.approx(r.max() - r.min())
    assert lin.max_abs == pytest.approx(np.abs(r).max())
    assert lin.rms == pytest.approx(np.sqrt(np.mean(r**2)))
    assert lin.E == pytest.approx(np.r_[half, -half].max() - np.r_[half, -half].min())
    assert lin.M == pytest.approx(0.0, abs=1e-12)  # the mean curve itself is compensated exactly


def test_means_only_comparison_says_so() -> None:
    df = compare_models(TARGET, UP, DOWN, models=["linear"])
    assert df.attrs["basis"] == "means"
    assert df.iloc[1].range == pytest.approx(0.0, abs=1e-12)  # a table through the means fits the means
    assert "MEAN deviations only" in format_comparison(df, "um")


def test_bad_deviations_are_refused() -> None:
    dev = deviations().drop(columns="direction")
    with pytest.raises(ValueError, match="direction"):
        compare_models(TARGET, UP, DOWN, deviations=dev)
    dev = deviations()
    dev.loc[0, "direction"] = 0
    with pytest.raises(ValueError, match=r"\+1 or -1"):
        compare_models(TARGET, UP, DOWN, deviations=dev)
