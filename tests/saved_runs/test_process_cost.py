"""What makes `process` slow stays out (issue 28): the Monte Carlo's minimum zone is never fitted
profile by profile, and writing the results draws the profile figure once (when it is saved)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from processing import reference_lines
from saved_runs.evaluation.evaluate import process_run_dir

V1 = Path(__file__).resolve().parents[1] / "data" / "runs" / "v1-straightness"


def test_the_monte_carlo_minimum_zone_is_not_fitted_trial_by_trial(monkeypatch: pytest.MonkeyPatch) -> None:
    """All trials at once: the single-profile fit (a Python loop per trial) is not called per row."""
    calls = []
    single = reference_lines.minimum_zone_line
    monkeypatch.setattr(reference_lines, "minimum_zone_line", lambda x, h: calls.append(1) or single(x, h))
    x = np.arange(300) * 10.0
    rows = np.random.default_rng(1).normal(0, 1, (50, 300))
    reference_lines.minimum_zone_many(x, rows)
    assert calls == []


def test_writing_the_results_draws_the_figure_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The legend is placed from the renderer's measure; only the save draws the figure."""
    draws = []
    draw = FigureCanvasAgg.draw

    def counting(self: FigureCanvasAgg) -> None:
        draws.append(1)
        draw(self)

    monkeypatch.setattr(FigureCanvasAgg, "draw", counting)
    _, ev = process_run_dir(V1, method="first-order", mc_trials=0)
    out = ev.write(tmp_path / "results")
    assert (out / "profile.png").read_bytes()[:4] == b"\x89PNG"
    assert len(draws) == 1
