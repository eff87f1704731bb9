"""Residual figures of ``guideway export`` beyond the model comparison: the table as written
(read back as the controller applies it) against the same model on its own nodes, and the
cross-validated (leave-one-run-out, leave-one-target-out) residual of every model.

Units: the deviation unit of the run (um, or arcsec for a rotary axis).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from processing.compensation.crossval import CROSS_VALIDATIONS, Outcome, Score, Unavailable, cross_validate
from processing.compensation.residuals import MeasuredPoints, point_residuals, residual_figures
from processing.compensation.tables import ErrorTable

FIGURES = ("max_abs", "range", "rms", "E", "M")
COST_TOLERANCE = 0.01  # um (arcsec): a change below this is rounding noise, not a cost
CV_LABELS = {"in_sample": "in-sample", "leave_one_run_out": "leave-one-run-out",
             "leave_one_target_out": "leave-one-target-out"}


@dataclass(frozen=True)
class TableScores:
    """Residual figures (:data:`FIGURES`) of the chosen model's table: ``nodes`` on the model's
    own nodes, unrounded (what the model itself can do); ``grid`` on the file's grid with
    unrounded values (None without a grid); ``written`` the file as written, applied as the
    controller applies it."""

    nodes: dict[str, float]
    grid: dict[str, float] | None
    written: dict[str, float]
    points: int


def score_tables(points: MeasuredPoints, nodes: ErrorTable, grid: ErrorTable | None,
                 applied: ErrorTable) -> TableScores:
    def fig(table: ErrorTable) -> dict[str, float]:
        return residual_figures(points, point_residuals(points, table))

    return TableScores(fig(nodes), None if grid is None else fig(grid), fig(applied), len(points.e))


def _changes(before: dict[str, float], after: dict[str, float]) -> list[str]:
    return [f"{k} {before[k]:.3f} -> {after[k]:.3f}" for k in ("E", "M", "range", "rms")
            if after[k] - before[k] > COST_TOLERANCE]


def cost_lines(s: TableScores, unit: str, grid_text: str) -> list[str]:
    """What regridding and writing the file cost, in words ([] when nothing)."""
    lines = []
    if s.grid is not None:
        changed = _changes(s.nodes, s.grid)
        if changed:
            lines.append(f"regridding costs accuracy: on the {grid_text} the model's residual grows "
                         f"({', '.join(changed)} {unit}); the grid does not pass through the targets - "
                         "a finer --step, or linuxcnc/csv (free positions), keeps more of it")
    base = s.grid if s.grid is not None else s.nodes
    changed = _changes(base, s.written)
    if changed:
        lines.append(f"writing the file costs: {', '.join(changed)} {unit} (rounding to the file's resolution, "
                     "backlash parameter, reference offset)")
    return lines


def format_table_scores(s: TableScores, unit: str, grid_text: str, model: str) -> str:
    head = (f"{'table':<32} {'max|r| ' + unit:>14} {'range ' + unit:>12} {'RMS ' + unit:>10} "
            f"{'E ' + unit:>10} {'M ' + unit:>10}")
    rows = [("model on its own nodes", s.nodes)]
    if s.grid is not None:
        rows.append((f"on the {grid_text}", s.grid))
    rows.append(("as written, applied", s.written))
    lines = [f"# the {model} table as the controller applies it, at every measured point ({s.points})", head]
    for label, f in rows:
        lines.append(f"{label:<32} {f['max_abs']:>14.3f} {f['range']:>12.3f} {f['rms']:>10.3f} "
                     f"{f['E']:>10.3f} {f['M']:>10.3f}")
    return "\n".join(lines)


def model_residuals(points: MeasuredPoints, comparison: pd.DataFrame, *, models: Iterable[str], mode: str,
                    positions: np.ndarray | None, **model_options: object) -> dict[str, dict[str, Outcome]]:
    """``{model: {"in_sample": ..., "leave_one_run_out": ..., "leave_one_target_out": ...}}``: the
    comparison's residual of every model next to its cross-validated residuals, on the same
    table positions."""
    rows = comparison.set_index("model")
    cv = cross_validate(points, models=models, mode=mode, positions=positions, **model_options)
    out: dict[str, dict[str, Outcome]] = {}
    for name, folds in cv.items():
        row = rows.loc[name]
        in_sample: Outcome = (Unavailable(f"not fitted: {row.note}") if row.note
                              else Score(float(row.rms), float(row.max_abs), int(comparison.attrs["n_points"])))
        out[name] = {"in_sample": in_sample, **folds}
    return out


def _cell(o: Outcome) -> str:
    return "-" if isinstance(o, Unavailable) else f"{o.rms:.3f} / {o.max_abs:.3f}"


def format_model_residuals(residuals: dict[str, dict[str, Outcome]], unit: str) -> str:
    kinds = ("in_sample", *CROSS_VALIDATIONS)
    lines = ["# residual out of sample: each model refitted without one run (or one target) and scored on the "
             "held-out points only",
             f"{'model':<11} " + " ".join(f"{CV_LABELS[k] + ' RMS / max ' + unit:>34}" for k in kinds)]
    notes: dict[str, str] = {}
    for name, res in residuals.items():
        lines.append(f"{name:<11} " + " ".join(f"{_cell(res[k]):>34}" for k in kinds))
        for k in CROSS_VALIDATIONS:
            o = res[k]
            if isinstance(o, Unavailable):
                notes.setdefault(f"{CV_LABELS[k]}: {o.reason}", name)
            elif o.folds < o.of_folds:
                notes.setdefault(f"{CV_LABELS[k]}: {o.folds} of {o.of_folds} targets held out in turn "
                                 "(evenly spread, both ends)", name)
    lines += [f"# {text}" for text in notes]
    lines.append("# in-sample = the table scored on the data it was fitted to (see the comparison above)")
    return "\n".join(lines)


def _number(v: float) -> float | None:
    return v if math.isfinite(v) else None


def outcome_json(o: Outcome, unit: str) -> dict[str, Any]:
    if isinstance(o, Unavailable):
        return {f"rms_{unit}": None, f"max_{unit}": None, "unavailable": o.reason}
    out: dict[str, Any] = {f"rms_{unit}": _number(o.rms), f"max_{unit}": _number(o.max_abs), "points": o.points}
    if o.of_folds:
        out.update(folds=o.folds, of_folds=o.of_folds)
    return out


def residuals_json(residuals: dict[str, dict[str, Outcome]], unit: str) -> dict[str, Any]:
    return {name: {k: outcome_json(o, unit) for k, o in res.items()} for name, res in residuals.items()}


def figures_json(f: dict[str, float], unit: str) -> dict[str, float | None]:
    return {f"{'max' if k == 'max_abs' else k}_{unit}": _number(v) for k, v in f.items()}
