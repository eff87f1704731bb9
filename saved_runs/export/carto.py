"""A table exported from a run measured with a compensation table active (run.json ``compensation``):
the old table plus the measured difference (CARTO's rule), so the new table replaces the old one
instead of undoing it (docs/compensation.md, "Exporting from an as-left run").

The run's errors were measured with the old correction c_old(x, direction) already in them:
e_measured = e_axis + c_old.  The export models e_axis = e_measured − c_old, the old file read and
applied as its controller does (processing/compensation/stage.py), at every point in its approach
direction; the new table corrects e_axis, i.e. it is the old table's correction plus the measured
difference, and its residuals are those of the new table in place of the old one.  Tables of
different formats, LinuxCNC file types, axes or detection units are not combined.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd

from processing.compensation.stage import ControllerTable, load_controller_table

from ..errors import UserError
from ..store.compensation import compensation_text, run_compensation
from .options import ExportOptions


@dataclass(frozen=True)
class ActiveTable:
    """The table active while the run was measured, as its controller applied it."""

    record: dict[str, Any]
    table: ControllerTable

    def correction(self, position: np.ndarray, direction: np.ndarray, error_scale: float) -> np.ndarray:
        """c_old at each position (mm or deg) approached in ``direction``, in the error unit
        (``error_scale``: um per mm, 1000, or arcsec per deg, 3600)."""
        return np.array([self.table.correction(float(x), int(d)) for x, d in zip(position, direction, strict=True)]
                        ) * error_scale


def active_table(meta: dict[str, Any], options: ExportOptions, axis: str) -> tuple[ActiveTable | None, str]:
    """The table active during the run (None when none was, or the run does not say) and the note the
    export prints about it.  One-line :class:`UserError` when it cannot be combined with ``options``."""
    rec = run_compensation(meta)
    if rec.get("active") is None:
        return None, ("the run does not record whether a compensation table was active (written before the tool "
                      "recorded it): if one was, this table is not combined with it and would undo it")
    if not rec["active"]:
        return None, ""
    fmt = rec.get("format")
    what = compensation_text(rec).removeprefix("controller compensation: ")
    if fmt == "live":  # an offset computed while the axis moved: there is no table file to add the difference to
        raise UserError(f"the run was measured with live compensation active ({what}); a table from it would undo "
                        f"the live offset: export from the as-found run {rec.get('as_found_run', '')} instead, or "
                        "measure again without live compensation")
    if options.fmt != fmt:
        raise UserError(f"the run was measured with a {fmt} table active ({what}); a {options.fmt} table cannot be "
                        f"combined with it: export --format {fmt} (old table + measured difference), or measure "
                        "again without the table")
    if fmt == "linuxcnc" and rec.get("comp_file_type") != options.linuxcnc_type:
        raise UserError(f"the active table is LinuxCNC COMP_FILE_TYPE {rec.get('comp_file_type')}; export with "
                        f"--linuxcnc-type {rec.get('comp_file_type')} (a file of the other type needs the INI changed "
                        "too)")
    table = load_recorded_table(rec, meta, "the table active during the run")
    _same_axis_and_units(table, options, axis, fmt)
    note = (f"the run was measured with {what} active: this table is that table plus the measured difference "
            "(CARTO's rule) and replaces it; the residuals are those of this table in its place")
    return ActiveTable(rec, table), note


def load_recorded_table(rec: dict[str, Any], meta: dict[str, Any], what: str, why: str = "the new table is the old one "
                        "plus the measured difference") -> ControllerTable:
    """The table file a run.json ``compensation`` record names (``rec`` active), read as its controller read it
    during the run (the record's COMP_FILE_TYPE, reference position, detection unit, backlash).  One-line
    :class:`UserError` when the file is missing, changed (its SHA-256 differs from the record) or unreadable;
    ``what`` names the table in those lines, ``why`` says what needs it."""
    fmt = rec.get("format")
    path = Path(str(rec.get("path", "")))
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise UserError(f"{what}, {path}, cannot be read ({exc.strerror or exc}); {why}: restore "
                        "the file") from None
    if hashlib.sha256(data).hexdigest() != rec.get("sha256"):
        raise UserError(f"{path} is not the table that was active during the run (its SHA-256 differs from run.json "
                        f"{str(rec.get('sha256'))[:12]}…); restore that file")
    unit = "deg" if meta.get("axis_type") == "rotary" else "mm"
    err = "arcsec" if unit == "deg" else "um"
    scale = 1.0 / 3600.0 if err == "arcsec" else 1e-3
    try:
        return load_controller_table(
            data.decode("utf-8"), str(fmt), comp_file_type=rec.get("comp_file_type"),
            reference_position=rec.get(f"reference_position_{unit}"), detection_unit_um=rec.get("detection_unit_um"),
            reference_direction=int(rec.get("reference_direction", 1)),
            backlash=None if rec.get(f"backlash_{err}") is None else float(rec[f"backlash_{err}"]) * scale)
    except (ValueError, UnicodeDecodeError) as exc:
        raise UserError(f"{what} {path} cannot be read as a {fmt} table: {exc}") from None


def _same_axis_and_units(table: ControllerTable, options: ExportOptions, axis: str, fmt: str) -> None:
    old_axis = table.axis
    if fmt == "siemens":
        new_axis = options.siemens_axis or f"{axis}1"
        if old_axis and old_axis != new_axis:
            raise UserError(f"the active table is for Siemens axis {old_axis}, this export for {new_axis}: tables of "
                            "different axes are not combined (--siemens-axis)")
    if fmt == "fanuc":
        if old_axis and old_axis != axis.upper():
            raise UserError(f"the active table is for axis {old_axis}, this export for {axis}: tables of different "
                            "axes are not combined (--axis)")
        if abs(table.detection_unit_um - options.fanuc_detection_unit_um) > 1e-12:
            raise UserError(f"the active table counts in {table.detection_unit_um:g} um detection units, this export "
                            f"in {options.fanuc_detection_unit_um:g} um: tables of different units are not combined "
                            "(--fanuc-detection-unit)")
        if table.reference_direction != options.fanuc_reference_direction:
            # one machine, one reference-return direction (1006#5 ZMI): it decides which table 3627 is on
            old, new = ("+" if d > 0 else "−" for d in (table.reference_direction, options.fanuc_reference_direction))
            raise UserError(f"the active table was applied with the reference return in {old} (run.json "
                            f"reference_direction = {table.reference_direction}), this export is for a return in "
                            f"{new}: export with --fanuc-reference-direction {table.reference_direction}")


def without_active_table(result: Any, deviations: pd.DataFrame | None, active: ActiveTable
                         ) -> tuple[Any, pd.DataFrame | None]:
    """The evaluation's means and points with the old correction taken out: e_axis = e_measured − c_old."""
    error_scale = 3600.0 if getattr(result, "axis_type", "linear") == "rotary" else 1000.0
    pt = result.per_target.copy()
    x = pt["target"].to_numpy(float)
    for column, direction in (("mean_up", 1), ("mean_down", -1)):
        pt[column] = pt[column].to_numpy(float) - active.correction(x, np.full(len(x), direction), error_scale)
    proxy = SimpleNamespace(per_target=pt, axis_type=result.axis_type, unit=result.unit)
    if deviations is None:
        return proxy, None
    dev = deviations.copy()
    dev["deviation"] = dev["deviation"].to_numpy(float) - active.correction(
        dev["target"].to_numpy(float), dev["direction"].to_numpy(int), error_scale)
    return proxy, dev
