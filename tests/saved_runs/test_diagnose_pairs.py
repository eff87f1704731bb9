"""The greedy search and a pair of effects (issue 25): a sag (quadratic) and a dead path whose air index rises
with the square of time look, together, much like one thermal growth P·t.  The growth then explains more than
either true effect alone and the forward selection takes it first; neither true effect is significant after it.
The backward pass tries a pair of candidates in the place of an added effect: the true pair is named.

The runs are written by the first-principles helpers of test_diagnose_positioning.py (an ISO 230-2 cycle, the
documented effect equations, Gaussian reading noise of σ 0.15 µm); the criteria the test relies on (growth
beats each true effect alone, the pair beats the growth) are computed here by ordinary least squares.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tests.saved_runs.test_diagnose_positioning import (
    N_REF,
    P_REF_PA,
    SIGMA_UM,
    TARGETS_MM,
    check_recovered,
    diagnose,
    effect_um,
    linear_cycle,
    true_standard_errors,
    write_run,
)

SAG = ("quadratic", {"um_per_m2": 0.5})
DEAD_PATH = ("dead_path", {"length_mm": 600.0})
GROWTH = ("thermal_growth", {"ppm_per_min": 0.05})
MARGIN = 6.0  # the positioning rule's BIC margin (docs/diagnosis.md)


def rising_pressure(t_s: np.ndarray) -> np.ndarray:
    """The air pressure rises by 300 Pa over the run, as the square of time (a front coming in)."""
    return P_REF_PA + 300.0 * (t_s / t_s.max()) ** 2


def bic_of(y: np.ndarray, columns: list[np.ndarray]) -> float:
    """n ln(RSS/n) + k ln n of an ordinary least-squares fit of an offset and ``columns``."""
    x = np.column_stack([np.ones(len(y)), *columns])
    r = y - x @ np.linalg.lstsq(x, y, rcond=None)[0]
    return len(y) * math.log(float(r @ r) / len(y)) + x.shape[1] * math.log(len(y))


def deviations_um(rows: list[dict], seed: int, effects: list) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The deviations write_run writes for ``seed`` (its noise drawn the same way) and each effect's column."""
    rng = np.random.default_rng(seed)
    n = len(rows)
    rng.normal(0, 0.1, n)  # write_run draws the pitch noise first, then the yaw noise, then the reading noise
    rng.normal(0, 0.1, n)
    noise = rng.normal(0, SIGMA_UM, n)
    t_s = np.array([r["time_s"] for r in rows])
    pres = rising_pressure(t_s)
    dn = (N_REF - 1) * (pres - pres[0]) / P_REF_PA
    zero = np.zeros(n)
    unit = {"quadratic": {"um_per_m2": 1.0}, "dead_path": {"length_mm": 1.0}, "thermal_growth": {"ppm_per_min": 1.0}}
    cols = {k: effect_um(k, q, rows, zero, zero, dn) for k, q in unit.items()}
    y = noise + sum(effect_um(k, q, rows, zero, zero, dn) for k, q in effects)
    return y, cols


@pytest.mark.parametrize("seed", [1, 2])
def test_a_sag_and_a_dead_path_are_named_not_the_growth_that_mimics_them(tmp_path: Path, seed: int) -> None:
    rows = linear_cycle(TARGETS_MM, 5)
    y, cols = deviations_um(rows, seed, [SAG, DEAD_PATH])
    alone = {k: bic_of(y, [c]) for k, c in cols.items()}
    pair = bic_of(y, [cols["quadratic"], cols["dead_path"]])
    # the trap: the growth explains more than either true effect alone, the pair much more than the growth
    assert alone["thermal_growth"] < min(alone["quadratic"], alone["dead_path"]), alone
    assert pair < alone["thermal_growth"] - 3 * MARGIN, (pair, alone)

    run = write_run(tmp_path / "run", rows, [SAG, DEAD_PATH], seed=seed, pressure_pa=rising_pressure)
    d = diagnose(run)
    assert sorted(d.named) == ["dead_path", "quadratic"], (d.named, d.ambiguous)
    assert d.ambiguous == []
    ch = d.primary
    final = {e.type: (e, se) for e, se in zip(ch.final.effects, ch.final.se, strict=True)}
    true_se = true_standard_errors([SAG, DEAD_PATH], rows, pressure_pa=rising_pressure)
    for (kind, params), s in zip([SAG, DEAD_PATH], true_se, strict=True):
        check_recovered(final[kind][0], final[kind][1], params, s)
    assert ch.final.rms_um <= 1.2 * SIGMA_UM


@pytest.mark.parametrize("seed", [1, 2])
def test_a_growth_alone_under_the_same_air_is_still_named_alone(tmp_path: Path, seed: int) -> None:
    """The pair is only taken when it fits better by the margin and both are significant together: a true
    growth (which the sag and the dead path mimic in turn) stays the one effect named."""
    rows = linear_cycle(TARGETS_MM, 5)
    run = write_run(tmp_path / "run", rows, [GROWTH], seed=seed, pressure_pa=rising_pressure)
    d = diagnose(run)
    assert d.named == ["thermal_growth"], (d.named, d.ambiguous)
    assert d.ambiguous == []
    ch = d.primary
    (true_se,) = true_standard_errors([GROWTH], rows, pressure_pa=rising_pressure)
    check_recovered(ch.final.effects[0], ch.final.se[0], GROWTH[1], true_se)
