"""Standard uncertainties of the ISO 230-2 axis values of one run, from the run's own repeated approaches
(docs/compensation.md, "Verify").

ISO 230-2 gives no uncertainty of E, M, B, R or A.  Each is a function (a max, a min, a sum) of the
per-target means x̄_i and standard deviations s_i; their scatter from run to run is what a repeat of the
measurement would change.  Estimated by a parametric Monte Carlo: at every target and direction n new
approaches are drawn from N(x̄_i, s_i²) (n, x̄_i, s_i of the run), the values are evaluated with the same
formulas (processing.iso230_2), and u = the standard deviation of each value over the trials.  A drawn
sample has mean x̄ + (s/√n)·z and a standard deviation distributed as s·χ_{n−1}/√(n−1), as a real repeat
would.  The laser's and the environment compensation's uncertainties are not in it (they are common to
both runs of a before/after comparison).  Targets with fewer than 2 approaches (no s) give no u.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from processing.iso230_2 import AXIS_QUANTITIES, Iso2302Result, iso230_2_from_arrays

TRIALS = 300
SEED = 20260  # fixed: the same run gives the same u every time


@dataclass(frozen=True)
class ValueSpread:
    """Per quantity of :data:`AXIS_QUANTITIES`: ``u`` the standard deviation over the trials, ``expected`` their
    mean — what a repeat of the run is expected to show.  A max − min of noisy means (E, M, B) is biased
    upwards: a run whose means are all 0 still shows E > 0 when repeated, so a value is judged against
    another run's by its expected value, not by the value at the means.  None where not evaluable."""

    u: dict[str, float | None]
    expected: dict[str, float | None]


def axis_value_spread(result: Iso2302Result, *, means_uncertain: bool = False, trials: int = TRIALS,
                      seed: int = SEED) -> ValueSpread:
    """The :class:`ValueSpread` of ``result``'s axis values (their unit).  ``means_uncertain``: ``result`` is a
    prediction whose means carry the noise of the means it was made from (u = s/√n each: the as-found means
    plus a table's correction); each trial first moves every mean by that much, so the spread is that of a
    repeat measurement around the prediction, not around the true values."""
    pt = result.per_target
    targets = pt["target"].to_numpy(float)
    rng = np.random.default_rng(seed)
    sides = []
    for name in ("up", "down"):
        n = pt[f"n_{name}"].to_numpy(int)
        mean, s = pt[f"mean_{name}"].to_numpy(float), pt[f"s_{name}"].to_numpy(float)
        sides.append((n, mean, s))
    width = [max(1, int(n.max())) for n, _, _ in sides]
    samples: dict[str, list[float]] = {q: [] for q in AXIS_QUANTITIES}
    for _ in range(trials):
        arrays = []
        for (n, mean, s), w in zip(sides, width, strict=True):
            centre = mean + s / np.sqrt(np.maximum(n, 1)) * rng.standard_normal(len(targets)) if means_uncertain \
                else mean
            draw = centre[:, None] + s[:, None] * rng.standard_normal((len(targets), w))
            draw[np.arange(w)[None, :] >= n[:, None]] = np.nan  # as many approaches as the run had
            arrays.append(draw)
        try:
            axis = iso230_2_from_arrays(targets, arrays[0], arrays[1], axis_type=result.axis_type, k=result.k,
                                        edition=result.edition).axis
        except ValueError:
            return ValueSpread(dict.fromkeys(AXIS_QUANTITIES), dict.fromkeys(AXIS_QUANTITIES))
        for q in AXIS_QUANTITIES:
            samples[q].append(axis[q])
    u: dict[str, float | None] = {}
    expected: dict[str, float | None] = {}
    for q in AXIS_QUANTITIES:
        v = np.asarray(samples[q], dtype=float)
        ok = math.isfinite(result.axis[q]) and bool(np.all(np.isfinite(v)))
        u[q] = float(np.std(v, ddof=1)) if ok else None
        expected[q] = float(np.mean(v)) if ok else None
    return ValueSpread(u, expected)
