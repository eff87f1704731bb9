"""A version-1 run written by the first release stays readable and processable.

The directory under tests/data/runs/v1-straightness is frozen: never regenerate it."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from saved_runs.evaluation.evaluate import process_run_dir

V1 = Path(__file__).resolve().parents[1] / "data" / "runs" / "v1-straightness"


def test_v1_run_loads_and_processes() -> None:
    run, evaluation = process_run_dir(V1, method="first-order", mc_trials=0)
    result = evaluation.result
    assert run.meta["version"] == 1 and run.meta["status"] == "complete"
    assert len(result.profile) == 8
    assert run.points["pass"].tolist() == [0] * 8  # v1 has no return pass: all forward

    # Independent evaluation straight from the CSV text with the documented formula.
    with open(V1 / "points.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    geo = run.meta["setup"]["geometry"]
    (xp, _, zp), (xq, _, zq) = geo["mirror_mm"], geo["sensor_mm"]
    r0 = rows[0]
    expected = []
    for r in rows:
        d = {k: float(r[k]) - float(r0[k]) for k in ("stry_um", "pitch_urad", "roll_urad", "sensor_mm")}
        s = d["sensor_mm"] * 1000 * (1 if geo["sensor_sign"] == "height" else -1)
        expected.append(d["stry_um"] + s + (xq - xp) * d["pitch_urad"] * 1e-3 - (zq - zp) * d["roll_urad"] * 1e-3)
    assert result.profile["height_um"].tolist() == pytest.approx(expected, abs=1e-9)
    # The default (exact) method expresses the profile in the datum's block frame: the datum
    # capture's own angles (zeroing noise) tilt it by a straight line and nothing else here.
    _, exact = process_run_dir(V1, mc_trials=0)
    diff = exact.result.profile["height_um"].to_numpy() - result.profile["height_um"].to_numpy()
    x = result.profile["x_mm"].to_numpy()
    line = np.polyval(np.polyfit(x, diff, 1), x)
    assert np.max(np.abs(diff - line)) < 0.005
