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

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from processing.compensation.residuals import compare_models, format_comparison, measured_points
from processing.compensation.tables import ErrorTable, fit_curves, tabulate

from .. import nc_text
from ..errors import UserError
from .axis import axis_data
from .carto import active_table, without_active_table
from .grid import table_grid
from .options import FORMATS, MODEL_NAMES, SUFFIX, ExportOptions
from .residuals import (
    TableScores,
    cost_lines,
    figures_json,
    format_model_residuals,
    format_table_scores,
    model_residuals,
    residuals_json,
    score_tables,
)
from .writers import write_table


@dataclass(frozen=True)
class Export:
    """A controller file and what it leaves: ``comparison`` (every model on the same table
    positions, compare_models), ``scores`` (the chosen model on its own nodes, on the grid and as
    written), ``residuals`` (in-sample and cross-validated residual of every model,
    export_residuals.model_residuals)."""

    text: str
    table: ErrorTable
    comparison: pd.DataFrame
    position_unit: str
    error_unit: str
    suffix: str
    notes: list[str] = field(default_factory=list)
    fmt: str = ""
    model: str = ""
    grid_step: float | None = None
    scores: TableScores | None = None
    residuals: dict[str, Any] = field(default_factory=dict)
    cost: list[str] = field(default_factory=list)
    combined_with: dict[str, Any] | None = None  # run.json compensation of the table active in the run (CARTO)

    @property
    def grid_text(self) -> str:
        return grid_text(self.grid_step, self.position_unit)

    def residual_text(self) -> str:
        """Everything ``guideway export`` prints after the file's name and notes."""
        u = self.error_unit
        parts = [f"residual after compensation ({u}):", format_comparison(self.comparison, u)]
        if self.scores is not None:
            parts.append(format_table_scores(self.scores, u, self.grid_text, self.model))
        parts += self.cost
        if self.residuals:
            parts.append(format_model_residuals(self.residuals, u))
        return "\n".join(parts)

    def to_dict(self) -> dict[str, Any]:
        """The object ``guideway export --json`` prints (docs/compensation.md)."""
        u = self.error_unit
        rows = []
        for r in self.comparison.itertuples(index=False):
            row = {"model": r.model, "table_points": int(r.table_points), "note": r.note, "detail": r.detail}
            row.update(figures_json({k: float(getattr(r, k)) for k in ("max_abs", "range", "rms", "E", "M")}, u))
            row["reduction_pct"] = None if not np.isfinite(r.reduction_pct) else float(r.reduction_pct)
            rows.append(row)
        out: dict[str, Any] = {
            "format": self.fmt, "model": self.model, "mode": self.table.mode, "unit": u,
            "position_unit": self.position_unit,
            "table": {"points": len(self.table), f"first_{self.position_unit}": float(self.table.position[0]),
                      f"last_{self.position_unit}": float(self.table.position[-1]),
                      f"step_{self.position_unit}": self.grid_step},
            "basis": self.comparison.attrs.get("basis"), "points": self.comparison.attrs.get("n_points"),
            "comparison": rows,
            "residuals": residuals_json(self.residuals, u),
            "notes": list(self.notes),
            "combined_with": None if self.combined_with is None else {
                k: self.combined_with.get(k) for k in ("file", "format", "sha256")},
        }
        if self.scores is not None:
            out["table_as_written"] = figures_json(self.scores.written, u)
            out["model_on_its_nodes"] = figures_json(self.scores.nodes, u)
            out["on_the_grid"] = None if self.scores.grid is None else figures_json(self.scores.grid, u)
            out["costs"] = list(self.cost)
        return out


def _mode(o: ExportOptions) -> str:
    if o.fmt == "siemens":
        if o.mode not in (None, "backlash"):
            raise UserError("Siemens LEC is not direction dependent: use --mode backlash (mean curve + "
                            "reversal into the backlash machine data)")
        return "backlash"
    return o.mode or "bidirectional"


def _checked_axis(o: ExportOptions, run_axis: str) -> str:
    """The axis name the file gets, checked against what the controller accepts (saved_runs.nc_text):
    ``--axis`` always, the run's own name where the format writes it (Fanuc, Siemens without
    ``--siemens-axis``); ``--siemens-axis`` as a Sinumerik machine-axis identifier."""
    if o.axis is not None:
        nc_text.axis_letter(o.axis, "--axis")
    axis = o.axis or run_axis
    if o.fmt == "siemens" and o.siemens_axis is not None:
        nc_text.siemens_axis(o.siemens_axis, "--siemens-axis")
    elif o.fmt in ("fanuc", "siemens"):
        axis = nc_text.axis_letter(axis, "--axis" if o.axis else "the run's axis name (run.json setup.axis_name; "
                                   "give --axis LETTER)")
    return axis


def build_export(result: Any, options: ExportOptions, *, axis: str = "X",
                 deviations: pd.DataFrame | None = None) -> Export:
    """Build the controller file for ``options`` from an evaluation ``result``.  ``deviations``
    (the evaluation's columns ``target``, ``direction``, ``run``, ``deviation``) are the measured
    points the residuals are evaluated on; None: the per-target means only."""
    o = options
    if o.fmt not in FORMATS:
        raise UserError(f"unknown format {o.fmt!r}; choose one of {', '.join(FORMATS)}")
    if o.model not in MODEL_NAMES:
        raise UserError(f"unknown model {o.model!r}; choose one of {', '.join(MODEL_NAMES)}")
    d = axis_data(result)
    axis = _checked_axis(o, axis)
    mode = _mode(o)
    model_options = {"tolerance": o.tolerance, "initial_maxima": o.initial_maxima, "degree": o.degree}
    grid, grid_notes = table_grid(d, o)
    try:
        curves = fit_curves(d.target, d.mean_up, d.mean_down, model=o.model, mode=mode, **model_options)
        table = tabulate(curves, grid)
        comparison = compare_models(d.target, d.mean_up, d.mean_down, mode=mode, positions=grid,
                                    deviations=deviations, **model_options)
        written = write_table(d, o, table, axis)
        points = measured_points(d.target, d.mean_up, d.mean_down, deviations)
        assert written.applied is not None
        scores = score_tables(points, tabulate(curves, None), None if grid is None else table, written.applied)
        residuals = model_residuals(points, comparison, models=MODEL_NAMES, mode=mode, positions=grid,
                                    **model_options)
    except ValueError as exc:
        raise UserError(f"cannot build the {o.fmt} table: {exc}") from exc
    notes = grid_notes + written.notes
    if o.model == "polynomial":
        notes.append(_degree_note(curves, o.degree))
    if written.offset_note:
        notes.append(written.offset_note)
    step = None if grid is None else float(grid[1] - grid[0])
    cost = cost_lines(scores, d.error_unit, grid_text(step, d.position_unit))
    return Export(written.text, table, comparison, d.position_unit, d.error_unit, SUFFIX[o.fmt], notes, o.fmt,
                  o.model, step, scores, residuals, cost)


def grid_text(step: float | None, position_unit: str) -> str:
    return "model's nodes" if step is None else f"{round(step, 9):.12g} {position_unit} grid"


def _degree_note(curves: Any, requested: int) -> str:
    used = sorted({int(m.degree) for m in (curves.up, curves.down)})
    text = "/".join(map(str, used))
    if used == [requested]:
        return f"polynomial degree {text}"
    return f"polynomial degree {text} (of {requested} requested: min(requested, targets - 2), at least 1)"


def export_run(run_dir: Path | str, options: ExportOptions, *, accept_out_of_range: bool = False
               ) -> tuple[Any, Export]:
    """Load and evaluate a positioning run and build its export (values outside the set-up's
    validation limits refused unless ``accept_out_of_range``)."""
    from ..evaluation.evaluate import evaluate_run
    from ..store.reader import load_run

    run = load_run(run_dir)
    if run.kind != "positioning":
        raise UserError(f"{run.path} is a {run.kind} run; compensation tables come from positioning runs "
                        "(ISO 230-2); pass a positioning run directory")
    evaluation = evaluate_run(run, accept_out_of_range=accept_out_of_range)
    setup = run.meta.get("setup") or {}
    axis = str(setup.get("axis_name") or run.meta.get("axis") or "X")
    # a run measured with a table active: the old table plus the measured difference (CARTO's rule)
    active, note = active_table(run.meta, options, options.axis or axis)
    result, deviations = evaluation.result, evaluation.deviations
    if active is not None:
        result, deviations = without_active_table(result, deviations, active)
    export = build_export(result, options, axis=axis, deviations=deviations)
    if note:
        export.notes.insert(0, note)
    return run, replace(export, combined_with=active.record if active is not None else None)


def export_path(run_path: Path, export: Export, fmt: str) -> Path:
    """Where an export is written by default: ``RUN_DIR/results/compensation-FORMAT.<suffix>``."""
    return run_path / "results" / f"compensation-{fmt}{export.suffix}"


def write_export(run_dir: Path | str, options: ExportOptions, out: Path | None = None, *,
                 accept_out_of_range: bool = False) -> tuple[Any, Export, Path]:
    """Build the export of a positioning run (:func:`export_run`) and write it (atomically) to ``out``
    or :func:`export_path`."""
    from ..errors import FileWriteError, what_to_do
    from ..store.files import write_text_atomic
    from ..store.stale_temps import remove_own_stale_temps

    run, export = export_run(run_dir, options, accept_out_of_range=accept_out_of_range)
    path = out or export_path(run.path, export, options.fmt)
    if path.is_dir() and not path.is_symlink():
        raise UserError(f"--out {path} is a directory; give a file name, "
                        f"e.g. {path / f'compensation-{options.fmt}{export.suffix}'}")
    try:
        # inside a run (RUN/results/compensation-*) no link is followed, in the file's place or its folder's
        remove_own_stale_temps(path.parent, [path.name])  # what a killed export of this table left
        write_text_atomic(path, export.text, make_parents=True)
    except FileWriteError as exc:
        raise UserError(f"cannot write the table to {path}: {exc.reason}{what_to_do(exc.errno)}") from None
    # the source run remembers the table (a LinuxCNC file cannot carry a comment): guideway verify reads it
    from .provenance import export_record, record_export

    note = record_export(run.path, export_record(run.meta, path, export, options))
    if note:
        export.notes.append(note)
    return run, export, path
