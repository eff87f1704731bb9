"""The serial correlation of a machine's errors from its earlier runs (issue 19, item 1).

One run of 210 points fixes the AR(1) coefficient φ only to about ±0.03 at φ 0.9, which moves a slow
effect's test statistic by ±30 % (docs/diagnosis.md, "Under correlated noise"); ``guideway diagnose RUN
--noise-from EARLIER...`` pools the estimates of earlier runs of the same machine with the run's own.

The AR(1) series are generated here (e_t = φ e_{t−1} + w_t, marginal σ stated); the decay of a
correlation with the time between points is that of a first-order process, e^(−Δt/τ), written here.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from processing.diagnosis import serial
from saved_runs.diagnosis.diagnose import diagnose_run
from tests.cli import guideway, one_line_error
from tests.saved_runs.test_diagnose_positioning import TARGETS_MM, linear_cycle, write_run
from tests.saved_runs.test_diagnose_real_data import ar1, gls_se_um_per_min

N = 210


def residual_and_basis(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Residual of y fitted with an offset and a slope in time, and the fit's orthonormal basis."""
    x = np.column_stack([np.ones(len(y)), np.arange(len(y), dtype=float)])
    q = np.linalg.qr(x)[0]
    return y - q @ (q.T @ y), q


def estimate(y: np.ndarray) -> serial.Ar1Estimate:
    r, q = residual_and_basis(y)
    return serial.Ar1Estimate(serial.matched_phi(r, q), len(y), 3.0)


def test_a_coefficient_is_converted_to_another_point_interval_by_the_decay_time() -> None:
    """Errors decaying as e^(−Δt/τ), τ = 40 s: φ e^(−3/40) for points 3 s apart is e^(−6/40) at 6 s and
    e^(−1.5/40) at 1.5 s; an unknown interval, or no positive correlation, leaves it as it is."""
    e = serial.Ar1Estimate(math.exp(-3.0 / 40.0), N, 3.0)
    assert math.isclose(e.at_interval(6.0), math.exp(-6.0 / 40.0), rel_tol=1e-12)
    assert math.isclose(e.at_interval(1.5), math.exp(-1.5 / 40.0), rel_tol=1e-12)
    assert e.at_interval(None) == e.phi
    assert serial.Ar1Estimate(math.exp(-3.0 / 40.0), N, None).at_interval(6.0) == e.phi
    assert serial.Ar1Estimate(-0.1, N, 3.0).at_interval(6.0) == -0.1


def test_pooling_four_earlier_runs_keeps_the_estimate_unbiased_and_halves_its_spread() -> None:
    """φ 0.9, 300 machines of 5 runs each: the estimate pooled over the five centres on 0.9 (within 0.01)
    and spreads about 1/√5 as much as one run's (allowed: below 0.6 of it)."""
    single, pooled = [], []
    for trial in range(300):
        runs = [ar1(N, 0.9, 10_000 + 5 * trial + k, 1.0) for k in range(5)]
        r, q = residual_and_basis(runs[4])
        single.append(serial.ar1_coefficient(r, q))
        pooled.append(serial.ar1_coefficient(r, q, tuple(estimate(y) for y in runs[:4]), 3.0))
    assert abs(np.mean(pooled) - 0.9) < 0.01, np.mean(pooled)
    assert np.std(pooled) < 0.6 * np.std(single), (np.std(pooled), np.std(single))
    assert np.std(single) > 0.025  # one run's estimate is as loose as the Cramér–Rao bound says (≥ 0.03)


def test_a_weak_correlation_is_used_once_enough_points_show_it() -> None:
    """φ 0.12: one run of 210 points shows it at 1.7 of its standard errors (1/√210), below the 2.33 the tests
    require before whitening; pooled over five runs (1050 points) it stands at 3.9 and is used."""
    used_single = used_pooled = 0
    for trial in range(60):
        runs = [ar1(N, 0.12, 20_000 + 5 * trial + k, 1.0) for k in range(5)]
        r, q = residual_and_basis(runs[4])
        used_single += serial.ar1_coefficient(r, q) > 0
        used_pooled += serial.ar1_coefficient(r, q, tuple(estimate(y) for y in runs[:4]), 3.0) > 0
    assert used_pooled >= 51, used_pooled  # expected ~0.94 of 60
    assert used_single <= 30, used_single  # expected ~0.3 of 60


def machine_runs(tmp_path: Path, seed: int, phi: float, drift_um_per_min: float = 0.0) -> tuple[Path, list[Path]]:
    """A run of one machine (AR(1) noise at ``phi``, a drift if given) and four earlier null runs of it."""
    rows = linear_cycle(TARGETS_MM, 5)
    earlier = [write_run(tmp_path / f"m{seed}_earlier{k}", rows, [], seed=seed * 10 + k,
                         noise_um=ar1(len(rows), phi, 40_000 + seed * 10 + k)) for k in range(4)]
    effects = [("thermal_drift", {"um_per_min": drift_um_per_min})] if drift_um_per_min else []
    run = write_run(tmp_path / f"m{seed}_{'drift' if effects else 'null'}", rows, effects, seed=seed,
                    noise_um=ar1(len(rows), phi, 50_000 + seed))
    return run, earlier


def test_with_four_earlier_runs_a_5_se_drift_at_phi_09_is_named_and_null_runs_stay_quiet(tmp_path: Path) -> None:
    """φ 0.9, σ 0.2 µm: a thermal drift of 5 GLS standard errors (computed here under the true noise) is named
    in at least 18 of 20 runs when φ comes from four earlier runs and the run (benchmark: 0.97; from the run
    alone 0.82; no test on one run reaches 0.9 while holding its false alarms up to φ 0.98, docs/diagnosis.md), and
    at most one of 20 null runs names anything (benchmark: under 1 in 100)."""
    rows = linear_cycle(TARGETS_MM, 5)
    t = np.array([r["time_s"] for r in rows]) / 60.0
    rate = 5.0 * gls_se_um_per_min(t - t.min(), 0.9)
    named, alarms = 0, []
    for seed in range(20):
        run, earlier = machine_runs(tmp_path, seed, 0.9, rate)
        d = diagnose_run(run, noise_from=earlier)
        named += d.named == ["thermal_drift"]
        assert len(d.primary.rule.ar1_history) == 4
        run, earlier = machine_runs(tmp_path, 100 + seed, 0.9)
        d = diagnose_run(run, noise_from=earlier)
        if d.named or d.ambiguous:
            alarms.append((seed, d.named, d.ambiguous))
    assert named >= 18, named
    assert len(alarms) <= 1, alarms


def test_diagnose_noise_from_on_the_command_line(tmp_path: Path) -> None:
    """--noise-from: the earlier runs' coefficients in the JSON rule and a line of the summary; the run itself,
    a run named twice, a run of another kind or a missing directory is one line and exit 2."""
    run, earlier = machine_runs(tmp_path, 3, 0.7)
    code, out, _ = guideway("diagnose", str(run), "--noise-from", *map(str, earlier[:2]), "--json")
    assert code == 0
    history = json.loads(out)["rule"]["ar1_history"]
    assert [h["run"] for h in history] == [str(p) for p in earlier[:2]]
    assert all(h["points"] == 210 and 0.4 < h["phi"] < 0.95 and h["interval_s"] > 0 for h in history)
    code, out, _ = guideway("diagnose", str(run), "--noise-from", *map(str, earlier))
    assert code == 0 and "serial correlation: estimated from this run and 4 earlier run(s) (840 points" in out

    straightness = tmp_path / "straightness"
    scenario = tmp_path / "s.toml"
    scenario.write_text('kind = "straightness"\n[block]\nlength_mm = 100.0\nstations = 12\n')
    assert guideway("simulate", str(scenario), "--out", str(straightness))[0] == 0
    for bad, says in ((run, "the run being diagnosed"), (earlier[0], "named twice"),
                      (straightness, "a straightness run"), (tmp_path / "nothing", "nothing")):
        args = [str(earlier[0]), str(bad)] if bad == earlier[0] else [str(bad)]
        one_line_error(guideway("diagnose", str(run), "--noise-from", *args), says)


def correlation_notes(d) -> list[str]:
    return [n for n in d.notes if "correlated in time (AR(1) coefficient" in n]


def test_a_strong_correlation_from_one_run_is_said_with_its_remedy(tmp_path: Path) -> None:
    """φ 0.9 from the run alone: a note says the slow effects' tests are less reliable (the measured figures) and
    names --noise-from / --noise-history; with the earlier runs given the note says the coefficient is pooled, and
    gives no remedy."""
    run, earlier = machine_runs(tmp_path, 7, 0.9)
    d = diagnose_run(run)
    (said,) = correlation_notes(d)
    assert "strongly correlated in time" in said and "--noise-history N" in said and "from this run alone" in said
    assert "about 2 of 100" in said
    assert f"AR(1) coefficient {d.primary.final.se_ar1_phi:.2f}, from this run alone" in said
    (pooled,) = correlation_notes(diagnose_run(run, noise_from=earlier))
    assert "pooled from this run and 4 earlier run(s)" in pooled and "--noise-history" not in pooled


def test_the_correlation_note_is_said_whenever_the_tests_used_an_estimated_coefficient(tmp_path: Path) -> None:
    """Issue 25: not only from 0.8 on.  φ 0.3 (seen on 210 points: φ̂·√n ≈ 4 > 2.33): the note, not "strongly",
    with the coefficient the ± rest on, the range the tests were whitened for (their evidence's ar1_phi) and the
    remedy; independent errors (φ 0, nothing detected, no test whitened): no note."""
    weak, _ = machine_runs(tmp_path, 8, 0.3)
    d = diagnose_run(weak)
    (said,) = correlation_notes(d)
    ch = d.primary
    phis = [t.ar1_phi for t in ch.last_round]
    assert 0.1 < ch.final.se_ar1_phi < 0.5 and min(phis) > 0
    assert "strongly" not in said and "--noise-history N" in said
    assert f"correlated in time (AR(1) coefficient {ch.final.se_ar1_phi:.2f}, from this run alone)" in said
    assert f"({min(phis):.2f} … {max(phis):.2f})" in said
    white, _ = machine_runs(tmp_path, 9, 0.0)
    d = diagnose_run(white)
    assert all(t.ar1_phi == 0 for t in d.primary.last_round) and correlation_notes(d) == []


def test_an_earlier_run_of_another_axis_is_used_with_a_note(tmp_path: Path) -> None:
    """An earlier run whose set-up names another axis (Y, this run X) is pooled, and the notes say so."""
    run, earlier = machine_runs(tmp_path, 9, 0.7)
    meta = json.loads((earlier[0] / "run.json").read_text())
    meta["setup"]["axis_name"] = "Y"
    (earlier[0] / "run.json").write_text(json.dumps(meta))
    d = diagnose_run(run, noise_from=earlier[:2])
    assert len(d.primary.rule.ar1_history) == 2
    assert [n for n in d.notes if n.startswith("noise history:")] == [
        f"noise history: {earlier[0]} is of axis 'Y', this run of 'X'"]
