"""The standard error of a named effect under errors correlated in time (issue 25).

The ordinary σ²(XᵀX)⁻¹ takes AR(1) errors for independent ones: for a drift at φ 0.9 it is about a fifth of the
estimate's true spread.  Under an estimated φ the diagnosis reports the least-squares value's standard error under
the AR(1) covariance (docs/diagnosis.md).  The AR(1) series and the ordinary standard errors are computed here;
the expected spread is the test's own simulation (and the sandwich (XᵀX)⁻¹XᵀΣX(XᵀX)⁻¹ at the true φ and σ).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from processing.diagnosis.observations import positioning_observations
from processing.diagnosis.select import POSITIONING_RULE, diagnose_channel
from tests.saved_runs.test_diagnose_positioning import TARGETS_MM, linear_cycle, write_run
from tests.saved_runs.test_diagnose_real_data import SIGMA_UM, ar1, gls_se_um_per_min
from tui.cli import main

PHI = 0.9
RUNS = 200


def drift_columns(rows: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    t = np.array([r["time_s"] for r in rows]) / 60.0
    t -= t.min()
    return t, np.column_stack([np.ones_like(t), t])


def test_the_reported_standard_error_of_a_drift_matches_its_spread_under_ar1_noise() -> None:
    """200 runs of 210 points, AR(1) noise at φ 0.9 (σ 0.2 µm), a drift of 8 GLS standard errors (named in
    nearly every run): the standard deviation of the named rate over the runs and the mean reported standard
    error agree within 20 %; the ordinary least-squares standard error (computed here) is about 0.2 of it."""
    rows = linear_cycle(TARGETS_MM, 5)
    points = pd.DataFrame(rows)
    t, x = drift_columns(rows)
    n = len(t)
    xtx_inv = np.linalg.inv(x.T @ x)
    k = np.arange(n)
    cov = SIGMA_UM**2 * PHI ** np.abs(k[:, None] - k[None, :])
    true_sd = math.sqrt((xtx_inv @ x.T @ cov @ x @ xtx_inv)[1, 1])  # least squares under the true covariance
    rate = 8.0 * gls_se_um_per_min(t, PHI)
    named, reported, ordinary = [], [], []
    for seed in range(RUNS):
        y = rate * t + ar1(n, PHI, 60_000 + seed)
        ch = diagnose_channel(positioning_observations(points, y, None), [], POSITIONING_RULE)
        coef, rss = np.linalg.lstsq(x, y, rcond=None)[:2]
        ordinary.append(math.sqrt(float(rss[0]) / (n - 2) * xtx_inv[1, 1]))
        if ch.named == ["thermal_drift"]:
            (effect,), (se,) = ch.final.effects, ch.final.se
            named.append(effect.params["um_per_min"])
            reported.append(se["um_per_min"])
            assert ch.final.se_ar1_phi > 0.5
    assert len(named) >= 0.95 * RUNS, len(named)
    spread = float(np.std(named, ddof=1))
    assert abs(spread / true_sd - 1) < 0.15, (spread, true_sd)  # the simulation itself: 200 runs, SE of sd ≈ 5 %
    assert abs(np.mean(reported) / spread - 1) < 0.2, (np.mean(reported), spread)
    assert np.mean(ordinary) / spread < 0.35, (np.mean(ordinary), spread)  # the former ± (about 0.22)


def test_the_corrected_standard_error_is_printed_in_the_summary_json_and_report(tmp_path: Path, capsys) -> None:
    """One run at φ 0.9 with a drift of 10 GLS standard errors: the summary's ± says what it stands for, the
    JSON carries the coefficient, and the ± printed is the JSON's (the corrected one, over 2.5 × the ordinary
    standard error computed here)."""
    rows = linear_cycle(TARGETS_MM, 5)
    t, x = drift_columns(rows)
    rate = 10.0 * gls_se_um_per_min(t, PHI)
    noise = ar1(len(rows), PHI, 71)
    run = write_run(tmp_path / "run", rows, [("thermal_drift", {"um_per_min": rate})], seed=5, noise_um=noise)
    report = tmp_path / "diagnosis.html"
    assert main(["diagnose", str(run), "--json", "--report", str(report)]) == 0
    out = json.loads(capsys.readouterr().out)
    (step,) = out["steps"]
    assert step["effect"] == "thermal_drift" and step["se_ar1_phi"] > 0.5 and out["final"]["se_ar1_phi"] > 0.5
    y = rate * t + noise
    coef, rss = np.linalg.lstsq(x, y, rcond=None)[:2]
    ordinary = math.sqrt(float(rss[0]) / (len(y) - 2) * np.linalg.inv(x.T @ x)[1, 1])
    assert step["se"]["um_per_min"] > 2.5 * ordinary, (step["se"], ordinary)
    assert "AR(1) coefficient" in report.read_text()
    assert main(["diagnose", str(run)]) == 0
    text = capsys.readouterr().out
    line = next(s for s in text.splitlines() if "step 1: thermal_drift" in s)
    assert f"± {step['se']['um_per_min']:.2g}" in line
    assert f"(± for errors correlated in time, AR(1) coefficient {step['se_ar1_phi']:.2f})" in line
