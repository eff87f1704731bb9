"""Out-of-sample residuals of the compensation models (docs/compensation.md, "Cross-validation").

The in-sample residual (:func:`~processing.compensation.residuals.compare_models`) scores a
table on the data it was fitted to: a table through the per-target means (``linear``, or a
``spline`` that ends with every target a knot) leaves only the run-to-run scatter and
E = M = 0 by construction.  Cross-validation refits each model without part of the data and
scores the refitted table on the held-out part only:

* **leave-one-run-out**: for each run j, the per-target means of the other runs → fit → table
  (same grid) → residual r = e − e_table(x) at every point of run j (both directions).  Needs
  at least 2 runs.  Says how well the table corrects a repetition of the measurement.
* **leave-one-target-out**: for each target i, the means at the other targets → fit → table →
  residual at every point measured at target i (every run, both directions).  Says how well the
  table corrects positions it was not fitted to (between the targets).  A held-out end target
  lies outside the refitted model's range: the table holds its end value there, as a
  controller does.  Needs at least 3 targets.

Each refitted model is scored as its table is applied: tabulated on the same positions as the
export (the grid, or the model's own nodes - which then lack the held-out target), interpolated
linearly between them, the end values held.  The residuals of all folds are pooled:
``rms`` = √(mean r²), ``max_abs`` = max |r|.
Units: positions mm (deg), errors and residuals um (arcsec).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from .models import MODEL_NAMES
from .residuals import MeasuredPoints, point_residuals
from .tables import FittedCurves, fit_curves, tabulate

MAX_TARGET_FOLDS = 100  # above this many targets, leave-one-target-out holds out this many, evenly spread


@dataclass(frozen=True)
class Score:
    """Pooled residual of one cross-validation (or of the in-sample fit): ``rms`` and
    ``max_abs`` in the unit of the deviations; ``points`` residuals from ``folds`` refits
    (``of_folds`` = the folds there are; fewer are evaluated above :data:`MAX_TARGET_FOLDS`)."""

    rms: float
    max_abs: float
    points: int
    folds: int = 0
    of_folds: int = 0

    @classmethod
    def of(cls, r: np.ndarray, folds: int = 0, of_folds: int = 0) -> Score:
        r = np.asarray(r, dtype=float)
        return cls(float(np.sqrt(np.mean(r**2))), float(np.max(np.abs(r))), len(r), folds, of_folds or folds)


@dataclass(frozen=True)
class Unavailable:
    """Why a cross-validation could not be done (one line)."""

    reason: str


Outcome = Score | Unavailable


def directional_means(points: MeasuredPoints) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(targets, x̄↑, x̄↓): the mean deviation per target and direction, NaN where a direction
    has no point at that target."""
    targets, inverse = np.unique(points.x, return_inverse=True)
    means = []
    for sel in (points.direction > 0, points.direction < 0):
        total = np.bincount(inverse[sel], weights=points.e[sel], minlength=len(targets))
        count = np.bincount(inverse[sel], minlength=len(targets))
        with np.errstate(invalid="ignore", divide="ignore"):
            means.append(np.where(count > 0, total / np.maximum(count, 1), np.nan))
    return targets, means[0], means[1]


def _fold_residuals(train_target: np.ndarray, train_up: np.ndarray, train_down: np.ndarray,
                    test: MeasuredPoints, model: str, mode: str, positions: np.ndarray | None,
                    model_options: dict[str, object], hint: FittedCurves | None = None) -> np.ndarray:
    curves = fit_curves(train_target, train_up, train_down, model=model, mode=mode, hint=hint, **model_options)
    return point_residuals(test, tabulate(curves, positions))


def leave_one_run_out(points: MeasuredPoints, *, model: str, mode: str = "bidirectional",
                      positions: np.ndarray | None = None, **model_options: object) -> Outcome:
    """Refit ``model`` without each run in turn and score it on that run's points."""
    if points.run is None:
        return Unavailable("needs the measured points of each run (only per-target means given)")
    runs = np.unique(points.run)
    if len(runs) < 2:
        return Unavailable(f"{len(runs)} run per direction: no run to hold out")
    residuals = []
    for j in runs:
        held = points.run == j
        t, up, down = directional_means(points.subset(~held))
        try:
            residuals.append(_fold_residuals(t, up, down, points.subset(held), model, mode, positions,
                                             dict(model_options)))
        except ValueError as exc:
            return Unavailable(f"without run {int(j)}: {exc}")
    return Score.of(np.concatenate(residuals), len(runs))


def target_folds(n_targets: int, max_folds: int | None = MAX_TARGET_FOLDS) -> np.ndarray:
    """Indices of the targets held out in turn: all of them, or ``max_folds`` evenly spread
    over the axis (both end targets included) when there are more."""
    if max_folds is None or n_targets <= max_folds:
        return np.arange(n_targets)
    return np.unique(np.round(np.linspace(0, n_targets - 1, max_folds)).astype(int))


def leave_one_target_out(points: MeasuredPoints, *, model: str, mode: str = "bidirectional",
                         positions: np.ndarray | None = None, max_folds: int | None = MAX_TARGET_FOLDS,
                         **model_options: object) -> Outcome:
    """Refit ``model`` without each target in turn and score it on that target's points."""
    targets, up, down = directional_means(points)
    if len(targets) < 3:
        return Unavailable(f"{len(targets)} targets: at least 3 are needed to refit without one")
    _, inverse = np.unique(points.x, return_inverse=True)
    order = np.argsort(inverse, kind="stable")
    bounds = np.searchsorted(inverse[order], np.arange(len(targets) + 1))
    folds = target_folds(len(targets), max_folds)
    try:  # the fit to every target: only a hint that speeds up the refits (models.fit_model)
        hint = fit_curves(targets, up, down, model=model, mode=mode, **model_options)
    except ValueError:
        hint = None
    residuals = []
    keep = np.ones(len(targets), dtype=bool)
    for i in folds:
        keep[i] = False
        rows = order[bounds[i]:bounds[i + 1]]
        test = MeasuredPoints(points.x[rows], points.direction[rows], points.e[rows])
        try:
            residuals.append(_fold_residuals(targets[keep], up[keep], down[keep], test, model, mode, positions,
                                             dict(model_options), hint))
        except ValueError as exc:
            return Unavailable(f"without target {targets[i]:g}: {exc}")
        keep[i] = True
    return Score.of(np.concatenate(residuals), len(folds), len(targets))


CROSS_VALIDATIONS = ("leave_one_run_out", "leave_one_target_out")


def cross_validate(points: MeasuredPoints, *, models: Iterable[str] = MODEL_NAMES, mode: str = "bidirectional",
                   positions: np.ndarray | None = None, max_target_folds: int | None = MAX_TARGET_FOLDS,
                   **model_options: object) -> dict[str, dict[str, Outcome]]:
    """``{model: {"leave_one_run_out": Score | Unavailable, "leave_one_target_out": ...}}``."""
    out: dict[str, dict[str, Outcome]] = {}
    for name in models:
        out[name] = {
            "leave_one_run_out": leave_one_run_out(points, model=name, mode=mode, positions=positions,
                                                   **model_options),
            "leave_one_target_out": leave_one_target_out(points, model=name, mode=mode, positions=positions,
                                                         max_folds=max_target_folds, **model_options),
        }
    return out
