"""Residual error after compensation: apply a table the way a controller does and compare
the models (seed 003, Table 1: errors before and after compensation per model).

Units: positions mm (deg), errors and corrections um (arcsec).  A *correction* here is the
change of the actual position the controller produces, so the compensated error is
e + correction; the ideal correction is −e_model.  Controllers interpolate linearly between
table points and hold the first/last value outside the table (LinuxCNC §4.1, Siemens §4.2).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .models import MODEL_NAMES
from .tables import DirectionalData, ErrorTable, fit_curves, split_directions, tabulate


def interpolate_table(x: np.ndarray, position: np.ndarray, value: np.ndarray) -> np.ndarray:
    """Linear interpolation of a table, first/last value held outside it."""
    return np.interp(np.asarray(x, dtype=float), np.asarray(position, dtype=float), np.asarray(value, dtype=float))


@dataclass(frozen=True)
class ResidualStats:
    """Remaining error over all measured points of both directions (um or arcsec)."""

    max_abs: float
    range: float
    rms: float

    @classmethod
    def of(cls, r: np.ndarray) -> ResidualStats:
        r = np.asarray(r, dtype=float)
        return cls(float(np.max(np.abs(r))), float(np.max(r) - np.min(r)), float(np.sqrt(np.mean(r**2))))


def compensated_errors(d: DirectionalData, table: ErrorTable) -> tuple[np.ndarray, np.ndarray]:
    """(residual↑, residual↓) at the measured points of ``d`` after applying ``table`` with the
    ideal correction −e_model (backlash folded in, as the controller's backlash compensation
    does)."""
    e_up, e_dn = table.directional()
    return (d.e_up - interpolate_table(d.x_up, table.position, e_up),
            d.e_down - interpolate_table(d.x_down, table.position, e_dn))


def _finite(*arrays: np.ndarray) -> np.ndarray:
    a = np.concatenate([np.asarray(v, dtype=float) for v in arrays])
    return a[np.isfinite(a)]


def compare_models(
    target: np.ndarray,
    mean_up: np.ndarray,
    mean_down: np.ndarray,
    *,
    models: Iterable[str] = MODEL_NAMES,
    mode: str = "bidirectional",
    positions: np.ndarray | None = None,
    **model_options: object,
) -> pd.DataFrame:
    """One row per model (plus ``none`` = uncompensated): columns ``model``, ``table_points``,
    ``max_abs``, ``range``, ``rms`` (unit of the means), ``reduction_pct`` (of the range) and
    ``note`` (why a model could not be fitted; its numbers are then NaN).

    ``positions`` is the controller's table grid (None: each model's own nodes)."""
    d = split_directions(target, mean_up, mean_down)
    before = ResidualStats.of(_finite(d.e_up, d.e_down))
    rows = [{"model": "none", "table_points": 0, **before.__dict__, "reduction_pct": 0.0, "note": ""}]
    for name in models:
        try:
            table = tabulate(fit_curves(target, mean_up, mean_down, model=name, mode=mode, **model_options),
                             positions)
        except ValueError as exc:  # e.g. too few targets for the polynomial degree: report, go on
            nan = float("nan")
            rows.append({"model": name, "table_points": 0, "max_abs": nan, "range": nan, "rms": nan,
                         "reduction_pct": nan, "note": str(exc)})
            continue
        after = ResidualStats.of(_finite(*compensated_errors(d, table)))
        red = 100.0 * (1.0 - after.range / before.range) if before.range > 0 else 0.0
        rows.append({"model": name, "table_points": len(table), **after.__dict__, "reduction_pct": red, "note": ""})
    return pd.DataFrame(rows, columns=["model", "table_points", "max_abs", "range", "rms", "reduction_pct", "note"])


def format_comparison(df: pd.DataFrame, unit: str) -> str:
    """The comparison as a fixed-width text table."""
    lines = [f"{'model':<11} {'points':>6} {'max|r| ' + unit:>14} {'range ' + unit:>14} {'RMS ' + unit:>12} "
             f"{'reduction':>9}"]
    for row in df.itertuples(index=False):
        if row.note:
            lines.append(f"{row.model:<11} {'-':>6}  not fitted: {row.note}")
            continue
        pts = "-" if row.model == "none" else str(row.table_points)
        lines.append(f"{row.model:<11} {pts:>6} {row.max_abs:>14.3f} {row.range:>14.3f} {row.rms:>12.3f} "
                     f"{row.reduction_pct:>8.1f}%")
    return "\n".join(lines)
