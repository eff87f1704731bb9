"""Cross-validated residuals of the compensation models (processing/compensation/crossval.py).

A small positioning data set is written here (targets, runs, directions); every expected value
is computed in the test from the definition: refit without the held-out run (or target) - by
hand for the linear model, with numpy.polyfit for the polynomial - and score on the held-out
points only, pooled over the folds."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from processing.compensation.crossval import (
    Score,
    Unavailable,
    cross_validate,
    leave_one_run_out,
    leave_one_target_out,
    target_folds,
)
from processing.compensation.models import fit_segments, segment_breakpoints
from processing.compensation.residuals import MeasuredPoints

TARGET = np.array([0.0, 95.0, 210.0, 300.0, 405.0, 500.0])
UP = np.array([0.0, 3.0, 4.5, 2.0, -1.0, 0.5])  # per-target error in + travel, um
DOWN = UP - np.array([2.0, 2.5, 1.5, 2.0, 3.0, 2.0])
RUN_OFFSET = {1: np.array([0.3, -0.2, 0.1, 0.4, -0.3, 0.2]),  # each run scatters differently per target
              2: np.array([-0.1, 0.5, -0.4, 0.0, 0.2, -0.3]),
              3: np.array([-0.2, -0.3, 0.3, -0.4, 0.1, 0.1])}


def deviations() -> pd.DataFrame:
    rows = []
    for run, off in RUN_OFFSET.items():
        for direction, mean in ((1, UP), (-1, DOWN)):
            sign = 1.0 if direction == 1 else -0.5  # the down runs scatter differently again
            for t, m, o in zip(TARGET, mean, off, strict=True):
                rows.append((t, direction, run, m + sign * o))
    return pd.DataFrame(rows, columns=["target", "direction", "run", "deviation"])


def points() -> MeasuredPoints:
    return MeasuredPoints.from_deviations(deviations())


def pooled(residuals: list[float]) -> tuple[float, float]:
    r = np.array(residuals)
    return float(np.sqrt(np.mean(r**2))), float(np.max(np.abs(r)))


def lerp(x: float, xs: np.ndarray, ys: np.ndarray) -> float:
    """Straight line between the two neighbours of x; the end value held outside (by hand)."""
    if x <= xs[0]:
        return float(ys[0])
    if x >= xs[-1]:
        return float(ys[-1])
    k = int(np.flatnonzero(xs <= x)[-1])
    if xs[k] == x:
        return float(ys[k])
    w = (x - xs[k]) / (xs[k + 1] - xs[k])
    return float((1 - w) * ys[k] + w * ys[k + 1])


def test_linear_leave_one_run_out_by_hand() -> None:
    dev = deviations()
    expected = []
    for j in RUN_OFFSET:
        train, test = dev[dev.run != j], dev[dev.run == j]
        for d in (1, -1):
            means = train[train.direction == d].groupby("target")["deviation"].mean()  # the other runs
            for t, e in test[test.direction == d][["target", "deviation"]].itertuples(index=False):
                expected.append(e - lerp(t, means.index.to_numpy(), means.to_numpy()))  # a node: its mean
    got = leave_one_run_out(points(), model="linear")
    assert isinstance(got, Score) and got.folds == 3 and got.points == len(dev)
    assert (got.rms, got.max_abs) == pytest.approx(pooled(expected), abs=1e-12)


def test_linear_leave_one_target_out_by_hand() -> None:
    dev = deviations()
    expected = []
    for i, t in enumerate(TARGET):
        others = np.delete(TARGET, i)
        for d in (1, -1):
            means = np.array([dev[(dev.target == o) & (dev.direction == d)].deviation.mean() for o in others])
            held = dev[(dev.target == t) & (dev.direction == d)].deviation
            expected += list(held - lerp(t, others, means))  # an end target: the neighbour's mean held
    got = leave_one_target_out(points(), model="linear")
    assert isinstance(got, Score) and got.folds == got.of_folds == len(TARGET)
    assert (got.rms, got.max_abs) == pytest.approx(pooled(expected), abs=1e-12)


def test_polynomial_cross_validation_with_numpy_polyfit() -> None:
    dev = deviations()
    per_run, per_target = [], []
    for j in RUN_OFFSET:
        train, test = dev[dev.run != j], dev[dev.run == j]
        for d in (1, -1):
            means = train[train.direction == d].groupby("target")["deviation"].mean()
            coef = np.polyfit(means.index.to_numpy(), means.to_numpy(), 2)
            sel = test[test.direction == d]
            per_run += list(sel.deviation - np.polyval(coef, sel.target))  # every target inside the range
    for i, t in enumerate(TARGET):
        others = np.delete(TARGET, i)
        for d in (1, -1):
            means = np.array([dev[(dev.target == o) & (dev.direction == d)].deviation.mean() for o in others])
            coef = np.polyfit(others, means, 2)
            # the table holds the polynomial at its nodes (the other targets); the controller
            # interpolates linearly between them and holds the end values
            table_at_t = lerp(t, others, np.polyval(coef, others))
            per_target += list(dev[(dev.target == t) & (dev.direction == d)].deviation - table_at_t)
    cv = cross_validate(points(), models=["polynomial"], degree=2)["polynomial"]
    assert (cv["leave_one_run_out"].rms, cv["leave_one_run_out"].max_abs) == pytest.approx(pooled(per_run))
    assert (cv["leave_one_target_out"].rms, cv["leave_one_target_out"].max_abs) == pytest.approx(pooled(per_target))


def test_backlash_mode_refits_the_mean_curve_and_the_mean_reversal() -> None:
    dev = deviations()
    expected = []
    for j in RUN_OFFSET:
        train, test = dev[dev.run != j], dev[dev.run == j]
        up = train[train.direction == 1].groupby("target")["deviation"].mean().to_numpy()
        down = train[train.direction == -1].groupby("target")["deviation"].mean().to_numpy()
        mean, b = (up + down) / 2, np.mean(up - down)  # table: mean curve; backlash B̄ as ±B̄/2
        for t, d, e in test[["target", "direction", "deviation"]].itertuples(index=False):
            expected.append(e - (lerp(t, TARGET, mean) + d * b / 2))
    got = leave_one_run_out(points(), model="linear", mode="backlash")
    assert (got.rms, got.max_abs) == pytest.approx(pooled(expected), abs=1e-12)


def test_out_of_sample_is_worse_than_in_sample_for_a_table_through_the_means() -> None:
    # in sample the linear table leaves only the scatter about each mean; held out, it does not
    pts = points()
    dev = deviations()
    in_sample = dev.deviation - dev.groupby(["target", "direction"])["deviation"].transform("mean")
    cv = cross_validate(pts, models=["linear"])["linear"]
    assert cv["leave_one_run_out"].rms > float(np.sqrt(np.mean(in_sample**2)))
    assert cv["leave_one_target_out"].rms > cv["leave_one_run_out"].rms


def test_what_cannot_be_cross_validated_says_why() -> None:
    one_run = MeasuredPoints.from_deviations(deviations().query("run == 1"))
    got = leave_one_run_out(one_run, model="linear")
    assert isinstance(got, Unavailable) and "1 run" in got.reason
    means_only = MeasuredPoints(TARGET, np.ones(len(TARGET), dtype=np.int64), UP)
    assert "each run" in leave_one_run_out(means_only, model="linear").reason  # type: ignore[union-attr]
    two = MeasuredPoints.from_deviations(deviations().query("target in (0.0, 95.0)"))
    assert "at least 3" in leave_one_target_out(two, model="linear").reason  # type: ignore[union-attr]
    # a fold that cannot be refitted names the fold
    got = leave_one_target_out(points(), model="polynomial", degree=-1)
    assert isinstance(got, Unavailable) and "without target 0" in got.reason


def test_many_targets_hold_out_an_evenly_spread_subset() -> None:
    folds = target_folds(1000, 100)
    assert len(folds) == 100 and folds[0] == 0 and folds[-1] == 999
    assert np.all(np.diff(folds) >= 9) and np.all(np.diff(folds) <= 11)
    np.testing.assert_array_equal(target_folds(50, 100), np.arange(50))
    dev = deviations()
    expected = []
    for i in (0, 2, 5):  # 3 folds of 6 targets: indices round(linspace(0, 5, 3)) = 0, 2 (2.5 → 2), 5
        others = np.delete(TARGET, i)
        for d in (1, -1):
            means = np.array([dev[(dev.target == o) & (dev.direction == d)].deviation.mean() for o in others])
            expected += list(dev[(dev.target == TARGET[i]) & (dev.direction == d)].deviation
                             - lerp(TARGET[i], others, means))
    got = leave_one_target_out(points(), model="linear", max_folds=3)
    assert (got.folds, got.of_folds) == (3, 6)
    assert (got.rms, got.max_abs) == pytest.approx(pooled(expected), abs=1e-12)


def reference_breakpoints(x: np.ndarray, e: np.ndarray, tau: float) -> list[int]:
    """Seed 004's greedy segmentation, literally: grow while numpy.polyfit's line through the
    window keeps every |residual| <= tau."""
    bps, start, n = [0], 0, len(x)
    while start < n - 1:
        end = start + 1
        while end + 1 < n:
            w = slice(start, end + 2)
            coef = np.polyfit(x[w], e[w], 1)
            if np.max(np.abs(e[w] - np.polyval(coef, x[w]))) > tau:
                break
            end += 1
        bps.append(end)
        start = end
    return bps


@pytest.mark.parametrize("seed", range(6))
def test_fast_segmentation_and_its_leave_one_out_shortcut_agree_with_the_definition(seed: int) -> None:
    rng = np.random.default_rng(seed)
    x = np.unique(rng.uniform(0, 1000, int(rng.integers(5, 70))))
    e = rng.uniform(1, 6) * np.sin(x / rng.uniform(40, 200)) + rng.normal(0, 0.2, len(x)) + 0.004 * x
    tau = float(np.max(np.abs(e)) / 20)
    assert list(segment_breakpoints(x, e, tau)) == reference_breakpoints(x, e, tau)
    full = fit_segments(x, e)
    for i in range(len(x)):  # refit without point i, with and without the full fit as a hint
        xr, er = np.delete(x, i), np.delete(e, i)
        plain, hinted = fit_segments(xr, er), fit_segments(xr, er, hint=full)
        assert list(hinted.breakpoints) == list(plain.breakpoints)
        np.testing.assert_array_equal(hinted.node_values, plain.node_values)


def reference_spline(x: np.ndarray, e: np.ndarray):  # noqa: ANN201 - a callable, the spline held at the ends
    """Seed 003's adaptive spline, literally, on scipy's CubicSpline: knots = both ends + every
    local curvature maximum (curvature over the point index), then every point whose residual
    exceeds max|e|/20 becomes a knot, until none does."""
    from scipy.interpolate import CubicSpline
    from scipy.signal import argrelextrema

    tol = float(np.max(np.abs(e))) / 20
    d1 = np.gradient(e, np.arange(len(e), dtype=float))
    kappa = np.abs(np.gradient(d1, np.arange(len(e), dtype=float))) / (1 + d1**2) ** 1.5
    knots = np.union1d([0, len(x) - 1], argrelextrema(kappa, np.greater)[0])
    while True:
        spline = CubicSpline(x[knots], e[knots], bc_type="natural" if len(knots) > 2 else "not-a-knot")
        over = np.flatnonzero(np.abs(e - spline(x)) > tol)
        if over.size == 0:
            return lambda q: spline(np.clip(q, x[0], x[-1]))
        knots = np.union1d(knots, over)


def reference_segments(x: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, values) of seed 004's segments: the literal greedy breakpoints, and the values of
    the least-squares polyline on them by scipy's QR least-squares spline of degree 1."""
    from scipy.interpolate import make_lsq_spline

    nodes = x[reference_breakpoints(x, e, float(np.max(np.abs(e))) / 20)]
    knots = np.concatenate(([nodes[0]], nodes, [nodes[-1]]))
    return nodes, make_lsq_spline(x, e, knots, k=1)(nodes)


@pytest.mark.parametrize("model", ["spline", "segments"])
def test_refits_give_the_residuals_of_the_reference_fits(model: str) -> None:
    # the cross-validation refits (fast splines, hinted segmentation) against the models fitted
    # the plain way in every fold: each fold's table is the model at the union of both
    # directions' nodes (targets, or breakpoints), interpolated linearly, ends held
    rng = np.random.default_rng(11)
    n, runs = 45, 3
    x = np.sort(rng.uniform(0, 1000, n))
    truth = {1: 5 * np.sin(x / 90) + 0.004 * x, -1: 5 * np.sin(x / 90) + 0.004 * x - 2}
    dev = pd.DataFrame([(t, d, j, m + rng.normal(0, 0.3)) for j in range(1, runs + 1) for d in (1, -1)
                        for t, m in zip(x, truth[d], strict=True)], columns=["target", "direction", "run", "deviation"])

    def fold(train: pd.DataFrame, test: pd.DataFrame) -> np.ndarray:
        means = train.groupby(["direction", "target"])["deviation"].mean()
        fits, nodes = {}, []
        for d in (1, -1):
            xs, es = means[d].index.to_numpy(), means[d].to_numpy()
            if model == "spline":
                fits[d] = reference_spline(xs, es)
                nodes.append(xs)
            else:
                bx, bv = reference_segments(xs, es)
                fits[d] = lambda q, bx=bx, bv=bv: np.interp(q, bx, bv)
                nodes.append(bx)
        pos = np.union1d(*nodes)
        table = {d: np.interp(test.target.to_numpy(), pos, fits[d](pos)) for d in (1, -1)}
        return test.deviation.to_numpy() - np.where(test.direction.to_numpy() > 0, table[1], table[-1])

    by_run = np.concatenate([fold(dev[dev.run != j], dev[dev.run == j]) for j in range(1, runs + 1)])
    by_target = np.concatenate([fold(dev[dev.target != t], dev[dev.target == t]) for t in x])
    pts = MeasuredPoints.from_deviations(dev)
    got_run = leave_one_run_out(pts, model=model)
    got_target = leave_one_target_out(pts, model=model)
    exact = 0.0 if model == "spline" else 1e-12  # segments: least squares solved another way (rounding)
    assert (got_run.rms, got_run.max_abs) == pytest.approx(pooled(list(by_run)), rel=0, abs=exact)
    assert (got_target.rms, got_target.max_abs) == pytest.approx(pooled(list(by_target)), rel=0, abs=exact)
    assert (got_run.points, got_target.points) == (len(by_run), len(by_target))
