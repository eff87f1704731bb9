"""Export CNC compensation tables from an evaluated positioning run (``guideway export``).

Input: the positioning evaluation's ``result`` with ``per_target`` (DataFrame with columns
``target_index``, ``target`` (mm or deg), ``mean_up``, ``mean_down`` (x̄_i↑ / x̄_i↓ =
actual − target in um or arcsec, NaN where a direction was not measured)), ``axis_type``
("linear" / "rotary") and ``unit`` ("um" / "arcsec").  Output: the controller file's text, the
table it was built from and the residual-after-compensation comparison of all models.  With the
evaluation's ``deviations`` (every run and direction) the comparison applies each table to every
measured point; without them it can only use the means and says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from processing.compensation.fanuc import fanuc_pitch_table, fanuc_text, round_half_away
from processing.compensation.generic_csv import csv_text
from processing.compensation.linuxcnc import linuxcnc_comp_text
from processing.compensation.models import DEFAULT_POLYNOMIAL_DEGREE, MODEL_NAMES
from processing.compensation.residuals import basis_text, compare_models, format_comparison
from processing.compensation.siemens import siemens_lec_text
from processing.compensation.tables import MODES, ErrorTable, equidistant_grid, fit_curves, tabulate

from .errors import UserError

# What the command line needs of the compensation package (tui imports acquisition only).
__all__ = ["DEFAULT_POLYNOMIAL_DEGREE", "FORMATS", "MODEL_NAMES", "MODES", "Export", "ExportOptions", "basis_text",
           "build_export", "export_path", "export_run", "format_comparison", "write_export"]

FORMATS = ("linuxcnc", "fanuc", "siemens", "csv")
SUFFIX = {"linuxcnc": ".comp", "fanuc": ".txt", "siemens": ".ini", "csv": ".csv"}
EQUIDISTANT = ("fanuc", "siemens")
MAX_GRID_POINTS = 100_000  # no controller takes more; guards against a mistyped --step
UNITS = {"linear": ("mm", "um", 1e-3), "rotary": ("deg", "arcsec", 1.0 / 3600.0)}


@dataclass(frozen=True)
class ExportOptions:
    """What to export.  Lengths in the axis unit (mm or deg) unless the name says otherwise."""

    fmt: str
    model: str = "linear"
    mode: str | None = None  # None: "backlash" for siemens (LEC is not directional), else "bidirectional"
    step: float | None = None  # grid step; None: model nodes (linuxcnc, csv) or mean target spacing
    tolerance: float | None = None  # spline tolerance / segment threshold (um or arcsec); None: max|e|/20
    initial_maxima: int | None = None  # spline: curvature maxima used as initial knots (None: all)
    degree: int = DEFAULT_POLYNOMIAL_DEGREE
    axis: str | None = None  # axis name; None: run.json setup.axis_name
    reference_position: float | None = None  # Fanuc reference position / Siemens zero point
    linuxcnc_type: int = 1
    fanuc_magnification: int = 1
    fanuc_detection_unit_um: float = 1.0
    fanuc_first_point: int = 0
    fanuc_reference_point: int | None = None
    fanuc_negative_table: int | None = None
    fanuc_reference_direction: int = 1
    siemens_axis: str | None = None  # machine axis identifier; None: axis + "1" (e.g. X1)
    siemens_encoder: int = 0
    siemens_modulo: bool = False
    siemens_max_points: int | None = None


@dataclass(frozen=True)
class Export:
    text: str
    table: ErrorTable
    comparison: pd.DataFrame
    position_unit: str
    error_unit: str
    suffix: str
    notes: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class AxisData:
    target: np.ndarray
    mean_up: np.ndarray
    mean_down: np.ndarray
    axis_type: str
    position_unit: str
    error_unit: str
    unit_scale: float


def axis_data(result: Any) -> AxisData:
    """Validate and unpack an evaluation result (see the module docstring)."""
    per_target = getattr(result, "per_target", None)
    if not isinstance(per_target, pd.DataFrame):
        raise UserError("the evaluation has no per-target mean deviations; export needs a positioning run")
    missing = [c for c in ("target", "mean_up", "mean_down") if c not in per_target.columns]
    if missing:
        raise UserError(f"per-target results lack column(s) {', '.join(missing)}; re-run `guideway process`")
    axis_type = getattr(result, "axis_type", None)
    if axis_type not in UNITS:
        raise UserError(f"axis type {axis_type!r} is not 'linear' or 'rotary'; fix axis_type in run.json")
    pos_unit, err_unit, scale = UNITS[axis_type]
    unit = getattr(result, "unit", err_unit)
    if unit != err_unit:
        raise UserError(f"a {axis_type} axis must report deviations in {err_unit}, not {unit!r}")
    try:
        df = per_target.sort_values("target")
        cols = [df[c].to_numpy(float) for c in ("target", "mean_up", "mean_down")]
    except (TypeError, ValueError) as exc:
        raise UserError(f"per-target results are not numeric ({exc}); re-run `guideway process`") from exc
    if len(cols[0]) < 2:
        raise UserError(f"{len(cols[0])} target(s) evaluated; a compensation table needs at least 2")
    return AxisData(*cols, axis_type, pos_unit, err_unit, scale)


def _grid(d: AxisData, o: ExportOptions) -> np.ndarray | None:
    x0, x1 = float(np.min(d.target)), float(np.max(d.target))
    if o.step is None and o.fmt not in EQUIDISTANT:
        return None
    step = o.step
    if step is None:  # mean spacing, rounded to 1 um (0.001 deg) so the controller can hold it exactly
        step = max(round((x1 - x0) / (len(d.target) - 1), 3), 0.001)
    if not step > 0:
        raise UserError(f"--step must be positive, got {step:g}")
    ref = x0 if o.reference_position is None else o.reference_position
    if (max(x1, ref) - min(x0, ref)) / step > MAX_GRID_POINTS:
        raise UserError(f"--step {step:g} gives more than {MAX_GRID_POINTS} table points; use a larger step")
    if o.fmt == "fanuc":
        return equidistant_grid(min(x0, ref), max(x1, ref), step, anchor=ref)
    grid = equidistant_grid(x0, x1, step)
    if o.fmt == "siemens" and o.siemens_modulo and abs(grid[-1] - grid[0] - 360.0) > 1e-6:
        raise UserError(f"a modulo LEC table must span 360 deg; targets and --step give "
                        f"{grid[0]:g} … {grid[-1]:g} deg")
    return grid


def _mode(o: ExportOptions) -> str:
    if o.fmt == "siemens":
        if o.mode not in (None, "backlash"):
            raise UserError("Siemens LEC is not direction dependent: use --mode backlash (mean curve + "
                            "reversal into the backlash machine data)")
        return "backlash"
    return o.mode or "bidirectional"


def build_export(result: Any, options: ExportOptions, *, axis: str = "X",
                 deviations: pd.DataFrame | None = None) -> Export:
    """Build the controller file for ``options`` from an evaluation ``result``.  ``deviations``
    (the evaluation's columns ``target``, ``direction``, ``run``, ``deviation``) are the measured
    points the residual comparison is evaluated on; None: the per-target means only."""
    o = options
    if o.fmt not in FORMATS:
        raise UserError(f"unknown format {o.fmt!r}; choose one of {', '.join(FORMATS)}")
    if o.model not in MODEL_NAMES:
        raise UserError(f"unknown model {o.model!r}; choose one of {', '.join(MODEL_NAMES)}")
    d = axis_data(result)
    axis = o.axis or axis
    mode = _mode(o)
    model_options = {"tolerance": o.tolerance, "initial_maxima": o.initial_maxima, "degree": o.degree}
    try:
        grid = _grid(d, o)
        curves = fit_curves(d.target, d.mean_up, d.mean_down, model=o.model, mode=mode, **model_options)
        table = tabulate(curves, grid)
        comparison = compare_models(d.target, d.mean_up, d.mean_down, mode=mode, positions=grid,
                                    deviations=deviations, **model_options)
        text, notes = _write(d, o, table, axis)
        if o.model == "polynomial":
            notes.append(_degree_note(curves, o.degree))
    except ValueError as exc:
        raise UserError(f"cannot build the {o.fmt} table: {exc}") from exc
    return Export(text, table, comparison, d.position_unit, d.error_unit, SUFFIX[o.fmt], notes)


def _degree_note(curves: Any, requested: int) -> str:
    used = sorted({int(m.degree) for m in (curves.up, curves.down)})
    text = "/".join(map(str, used))
    if used == [requested]:
        return f"polynomial degree {text}"
    return f"polynomial degree {text} (of {requested} requested: min(requested, targets - 2), at least 1)"


def _backlash_note(table: ErrorTable, d: AxisData) -> str:
    return (f"mean reversal B = mean(up - down) = {table.backlash:.3f} {d.error_unit}; "
            f"lost motion for the backlash parameter = {-table.backlash:.3f} {d.error_unit}")


def _write(d: AxisData, o: ExportOptions, table: ErrorTable, axis: str) -> tuple[str, list[str]]:
    notes: list[str] = []
    if o.fmt == "linuxcnc":
        notes.append(f"LinuxCNC: [JOINT_n] COMP_FILE = <this file>, COMP_FILE_TYPE = {o.linuxcnc_type}; "
                     "BACKLASH is ignored when COMP_FILE is set (reversal is in the table)")
        return linuxcnc_comp_text(table, file_type=o.linuxcnc_type, unit_scale=d.unit_scale), notes
    if o.fmt == "csv":
        return csv_text(table, position_unit=d.position_unit, error_unit=d.error_unit), notes
    if o.fmt == "siemens":
        values = table.error_up
        if o.reference_position is not None:
            values = values - np.interp(o.reference_position, table.position, values)
        if o.siemens_modulo:
            if d.axis_type != "rotary":
                raise ValueError("modulo tables are for rotary axes")
            values = values.copy()
            values[0] = values[-1] = (values[0] + values[-1]) / 2.0
        notes.append(_backlash_note(table, d) + " (Siemens MD32450 BACKLASH; check its sign on the machine)")
        text = siemens_lec_text(
            table.position, values, axis=o.siemens_axis or f"{axis}1", encoder=o.siemens_encoder,
            unit_scale=d.unit_scale, decimals=6 if d.axis_type == "linear" else 8, modulo=o.siemens_modulo,
            max_points=o.siemens_max_points, note=f"guideway LEC {o.model} model, mean of both directions",
        )
        return text, notes
    # fanuc
    if d.axis_type != "linear":
        raise ValueError("rotary-axis pitch tables (parameter 3625) are not supported; use linuxcnc, siemens or csv")
    ref = float(table.position[0]) if o.reference_position is None else o.reference_position
    bidirectional = table.mode == "bidirectional"
    pitch = fanuc_pitch_table(
        table.error_up, table.error_down if bidirectional else None,
        grid_mm=table.position, reference_position_mm=ref, detection_unit_um=o.fanuc_detection_unit_um,
        magnification=o.fanuc_magnification, first_number=o.fanuc_first_point,
        reference_number=o.fanuc_reference_point, negative_table_start=o.fanuc_negative_table,
        reference_direction=o.fanuc_reference_direction,
    )
    note = ""
    if not bidirectional:
        lost = int(round_half_away(-table.backlash / o.fanuc_detection_unit_um))
        note = f"backlash parameter 1851 = {lost} detection units of lost motion"
        notes.append(_backlash_note(table, d) + f" (Fanuc parameter 1851 = {lost} detection units)")
    return fanuc_text(pitch, axis=axis, note=note), notes


def export_run(run_dir: Path | str, options: ExportOptions) -> tuple[Any, Export]:
    """Load and evaluate a positioning run and build its export."""
    from .evaluate import evaluate_run
    from .runstore import load_run

    run = load_run(run_dir)
    if run.kind != "positioning":
        raise UserError(f"{run.path} is a {run.kind} run; compensation tables come from positioning runs "
                        "(ISO 230-2); pass a positioning run directory")
    evaluation = evaluate_run(run)
    setup = run.meta.get("setup") or {}
    axis = str(setup.get("axis_name") or run.meta.get("axis") or "X")
    return run, build_export(evaluation.result, options, axis=axis, deviations=evaluation.deviations)


def export_path(run_path: Path, export: Export, fmt: str) -> Path:
    """Where an export is written by default: ``RUN_DIR/results/compensation-FORMAT.<suffix>``."""
    return run_path / "results" / f"compensation-{fmt}{export.suffix}"


def write_export(run_dir: Path | str, options: ExportOptions, out: Path | None = None) -> tuple[Any, Export, Path]:
    """Build the export of a positioning run and write it (atomically) to ``out`` or :func:`export_path`."""
    from .runstore import write_text_atomic

    run, export = export_run(run_dir, options)
    path = out or export_path(run.path, export, options.fmt)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, export.text)
    return run, export, path
