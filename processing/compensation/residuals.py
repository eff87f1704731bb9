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
from .tables import DirectionalData, ErrorTable, FittedCurves, fit_curves, split_directions, tabulate


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


@dataclass(frozen=True)
class MeasuredPoints:
    """Every measured deviation of a run: commanded position (mm or deg), direction of travel
    (+1 ↑ / −1 ↓) and deviation e = actual − commanded (um or arcsec), one entry per run,
    target and direction."""

    x: np.ndarray
    direction: np.ndarray
    e: np.ndarray
    run: np.ndarray | None = None  # run number j of each point (None: not known, e.g. the means)

    def subset(self, keep: np.ndarray) -> MeasuredPoints:
        """The points where the boolean mask ``keep`` is true."""
        return MeasuredPoints(self.x[keep], self.direction[keep], self.e[keep],
                              None if self.run is None else self.run[keep])

    @classmethod
    def from_deviations(cls, deviations: pd.DataFrame) -> MeasuredPoints:
        """From the evaluation's ``deviations`` (columns ``target``, ``direction``, ``deviation``,
        optionally ``run``); non-finite deviations are dropped."""
        missing = [c for c in ("target", "direction", "deviation") if c not in deviations.columns]
        if missing:
            raise ValueError(f"deviations lack column(s) {', '.join(missing)}")
        x = deviations["target"].to_numpy(dtype=float)
        sign = np.sign(deviations["direction"].to_numpy(dtype=float))
        e = deviations["deviation"].to_numpy(dtype=float)
        if np.any(sign == 0):
            raise ValueError("every deviation needs a direction of +1 or -1")
        keep = np.isfinite(x) & np.isfinite(e)
        if not keep.any():
            raise ValueError("no finite measured deviation")
        run = deviations["run"].to_numpy(dtype=float)[keep] if "run" in deviations.columns else None
        run = run.astype(np.int64) if run is not None and np.all(np.isfinite(run)) else None
        return cls(x[keep], sign[keep].astype(np.int64), e[keep], run)

    @classmethod
    def from_means(cls, d: DirectionalData) -> MeasuredPoints:
        """The per-target means as the only 'points' (one per target and direction)."""
        return cls(np.concatenate((d.x_up, d.x_down)),
                   np.concatenate((np.ones(len(d.x_up), np.int64), -np.ones(len(d.x_down), np.int64))),
                   np.concatenate((d.e_up, d.e_down)))


def point_residuals(points: MeasuredPoints, table: ErrorTable) -> np.ndarray:
    """Residual e − e_table(x) at every point, the ↑ curve for ↑ travel and the ↓ curve for ↓
    travel (backlash folded in), interpolated linearly as the controller does.  A direction the
    run never travelled in takes the table's curve for that direction all the same."""
    e_up, e_dn = table.directional()
    up = points.direction > 0
    model = np.where(up, interpolate_table(points.x, table.position, e_up),
                     interpolate_table(points.x, table.position, e_dn))
    return points.e - model


def iso_figures(points: MeasuredPoints, r: np.ndarray) -> tuple[float, float]:
    """(E, M) of the residuals ``r`` in the ISO 230-2 sense: x̄_i↑ / x̄_i↓ = mean residual per
    target and direction; E = max − min over all x̄_i↑ and x̄_i↓ (bidirectional systematic
    positional deviation); M = max − min of x̄_i = (x̄_i↑ + x̄_i↓)/2 (mean bidirectional
    positional deviation; a target measured in one direction only uses that mean)."""
    df = pd.DataFrame({"x": points.x, "up": points.direction > 0, "r": r})
    means = df.groupby(["x", "up"])["r"].mean().unstack("up")
    e_fig = float(np.nanmax(means.to_numpy()) - np.nanmin(means.to_numpy()))
    bi = means.mean(axis=1, skipna=True).to_numpy()
    return e_fig, float(np.max(bi) - np.min(bi))


def residual_figures(points: MeasuredPoints, r: np.ndarray) -> dict[str, float]:
    """``max_abs``, ``range``, ``rms`` (:class:`ResidualStats`) and ISO 230-2 ``E``, ``M``
    (:func:`iso_figures`) of the residuals ``r`` at ``points``."""
    e_fig, m_fig = iso_figures(points, r)
    return {**ResidualStats.of(r).__dict__, "E": e_fig, "M": m_fig}


def measured_points(target: np.ndarray, mean_up: np.ndarray, mean_down: np.ndarray,
                    deviations: pd.DataFrame | None) -> MeasuredPoints:
    """The points a residual is evaluated at: every measured deviation, or (``deviations``
    None) the per-target means."""
    d = split_directions(target, mean_up, mean_down)  # validates the means in both cases
    return MeasuredPoints.from_means(d) if deviations is None else MeasuredPoints.from_deviations(deviations)


def _polynomial_detail(curves: FittedCurves, requested: object) -> str:
    degrees = sorted({int(getattr(m, "degree", -1)) for m in (curves.up, curves.down)})
    used = "/".join(str(g) for g in degrees)
    if isinstance(requested, int) and degrees != [requested]:
        return f"degree {used} (of {requested} requested: too few targets, degree <= n - 2)"
    return f"degree {used}"


COLUMNS = ["model", "table_points", "max_abs", "range", "rms", "reduction_pct", "E", "M", "detail", "note"]
BASIS_POINTS = "points"
BASIS_MEANS = "means"


def compare_models(
    target: np.ndarray,
    mean_up: np.ndarray,
    mean_down: np.ndarray,
    *,
    models: Iterable[str] = MODEL_NAMES,
    mode: str = "bidirectional",
    positions: np.ndarray | None = None,
    deviations: pd.DataFrame | None = None,
    **model_options: object,
) -> pd.DataFrame:
    """One row per model (plus ``none`` = uncompensated).  The tables are fitted to the
    per-target means; the residual is evaluated at every measured point of ``deviations``
    (columns ``target``, ``direction`` ±1, ``deviation``: each run, each direction), or at the
    means alone when ``deviations`` is None (then the run-to-run scatter is not in the figures).

    Columns (unit of the deviations): ``model``, ``table_points``, ``max_abs`` = max|r|,
    ``range`` = max r − min r, ``rms`` = sqrt(mean r²), ``reduction_pct`` = 100·(1 − range /
    range of ``none``), ``E`` and ``M`` (:func:`iso_figures` of the residuals), ``detail``
    (e.g. the polynomial degree used) and ``note`` (why a model could not be fitted; its numbers
    are then NaN).  ``df.attrs["basis"]`` is ``"points"`` or ``"means"`` and
    ``df.attrs["n_points"]`` the number of residuals per model.

    ``positions`` is the controller's table grid (None: each model's own nodes)."""
    points = measured_points(target, mean_up, mean_down, deviations)
    nan = float("nan")

    def row(model: str, n: int, r: np.ndarray, before_range: float, detail: str = "") -> dict[str, object]:
        fig = residual_figures(points, r)
        red = 100.0 * (1.0 - fig["range"] / before_range) if before_range > 0 else 0.0
        return {"model": model, "table_points": n, **fig, "reduction_pct": red, "detail": detail, "note": ""}

    before = ResidualStats.of(points.e).range
    rows = [row("none", 0, points.e, before)]
    for name in models:
        try:
            curves = fit_curves(target, mean_up, mean_down, model=name, mode=mode, **model_options)
            table = tabulate(curves, positions)
        except ValueError as exc:  # e.g. too few targets: report, go on
            rows.append({"model": name, "table_points": 0, "max_abs": nan, "range": nan, "rms": nan,
                         "reduction_pct": nan, "E": nan, "M": nan, "detail": "", "note": str(exc)})
            continue
        detail = _polynomial_detail(curves, model_options.get("degree")) if name == "polynomial" else ""
        rows.append(row(name, len(table), point_residuals(points, table), before, detail))
    df = pd.DataFrame(rows, columns=COLUMNS)
    df.attrs["basis"] = BASIS_MEANS if deviations is None else BASIS_POINTS
    df.attrs["n_points"] = len(points.e)
    return df


def basis_text(df: pd.DataFrame) -> str:
    """One line saying what the residuals were evaluated on."""
    n = df.attrs.get("n_points", "?")
    if df.attrs.get("basis") == BASIS_POINTS:
        return (f"residual at every measured point ({n}: each run, each direction), "
                "table fitted to the per-target means")
    return (f"residual at the per-target MEAN deviations only ({n} means): the run-to-run scatter "
            "is not included, the real residual is larger")


def format_comparison(df: pd.DataFrame, unit: str) -> str:
    """The comparison as a fixed-width text table, preceded by :func:`basis_text`."""
    lines = [f"# {basis_text(df)}",
             f"{'model':<11} {'points':>6} {'max|r| ' + unit:>14} {'range ' + unit:>14} {'RMS ' + unit:>12} "
             f"{'reduction':>9} {'E ' + unit:>10} {'M ' + unit:>10}"]
    for row in df.itertuples(index=False):
        if row.note:
            lines.append(f"{row.model:<11} {'-':>6}  not fitted: {row.note}")
            continue
        pts = "-" if row.model == "none" else str(row.table_points)
        line = (f"{row.model:<11} {pts:>6} {row.max_abs:>14.3f} {row.range:>14.3f} {row.rms:>12.3f} "
                f"{row.reduction_pct:>8.1f}% {row.E:>10.3f} {row.M:>10.3f}")
        lines.append(f"{line}  {row.detail}" if row.detail else line)
    lines.append("# reduction = of the range vs. none; E, M = ISO 230-2 E and M of the compensated means")
    return "\n".join(lines)
