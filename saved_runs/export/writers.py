"""The controller file of ``guideway export`` and the table the controller applies from it.

Each writer returns the file's text together with :class:`Written.applied`: the error the
controller removes with the file **as written** (its rounded numbers: Fanuc counts, 6-decimal
values, the backlash parameter as reported), so the residual after compensation is scored on
what the machine will get, not on the model in memory.  Positions mm (deg), errors um (arcsec).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from processing.compensation.fanuc import fanuc_pitch_table, fanuc_text, round_half_away
from processing.compensation.generic_csv import csv_text
from processing.compensation.linuxcnc import linuxcnc_applied, linuxcnc_comp_text
from processing.compensation.numbers import fixed
from processing.compensation.siemens import siemens_applied_error, siemens_lec_text
from processing.compensation.tables import ErrorTable

from .. import nc_text

if TYPE_CHECKING:
    from .axis import AxisData
    from .options import ExportOptions

CSV_DECIMALS = 6


@dataclass(frozen=True)
class Written:
    """A controller file: ``text``, ``notes`` for the user, ``applied`` (the error the controller
    removes, per direction, at the file's positions; backlash folded in as the controller's
    backlash parameter applies it) and ``offset_note`` (the error the file leaves at every position
    by design: a table relative to a reference position keeps the error there)."""

    text: str
    notes: list[str] = field(default_factory=list)
    applied: ErrorTable | None = None
    offset_note: str = ""


def _backlash_note(table: ErrorTable, d: AxisData) -> str:
    return (f"mean reversal B = mean(up - down) = {table.backlash:.3f} {d.error_unit}; "
            f"lost motion for the backlash parameter = {-table.backlash:.3f} {d.error_unit}")


def write_table(d: AxisData, o: ExportOptions, table: ErrorTable, axis: str) -> Written:
    """The file for ``o.fmt`` from ``table`` (the model at the grid positions)."""
    if o.fmt == "linuxcnc":
        notes = [f"LinuxCNC: [JOINT_n] COMP_FILE = <this file>, COMP_FILE_TYPE = {o.linuxcnc_type}; "
                 "BACKLASH is ignored when COMP_FILE is set (reversal is in the table)"]
        text = linuxcnc_comp_text(table, file_type=o.linuxcnc_type, unit_scale=d.unit_scale)
        applied = linuxcnc_applied(table, file_type=o.linuxcnc_type, unit_scale=d.unit_scale)
        return Written(text, notes, applied)
    if o.fmt == "csv":
        e_up, e_dn = (np.array([float(fixed(v, CSV_DECIMALS)) for v in e]) for e in table.directional())
        applied = ErrorTable(table.position, e_up, e_dn, "bidirectional", table.model)
        return Written(csv_text(table, position_unit=d.position_unit, error_unit=d.error_unit,
                                decimals=CSV_DECIMALS), [], applied)
    if o.fmt == "siemens":
        return _siemens(d, o, table, axis)
    return _fanuc(d, o, table, axis)


def _siemens(d: AxisData, o: ExportOptions, table: ErrorTable, axis: str) -> Written:
    values, offset_note = table.error_up, ""
    if o.reference_position is not None:
        offset = float(np.interp(o.reference_position, table.position, values))
        values = values - offset
        offset_note = (f"the table is zero at the reference position {o.reference_position:g} {d.position_unit}: "
                       f"the error there ({offset:+.3f} {d.error_unit}) stays in every residual")
    if o.siemens_modulo:
        if d.axis_type != "rotary":
            raise ValueError("modulo tables are for rotary axes")
        values = values.copy()
        values[0] = values[-1] = (values[0] + values[-1]) / 2.0
    decimals = 6 if d.axis_type == "linear" else 8
    notes = [_backlash_note(table, d) + " (Siemens MD32450 BACKLASH; check its sign on the machine)"]
    text = siemens_lec_text(
        table.position, values, encoder=o.siemens_encoder,
        axis=nc_text.siemens_axis(o.siemens_axis or f"{axis}1", "the Siemens axis name"),
        unit_scale=d.unit_scale, decimals=decimals, modulo=o.siemens_modulo,
        max_points=o.siemens_max_points,
        note=nc_text.comment(f"guideway LEC {o.model} model, mean of both directions", "the table's note"),
    )
    removed = siemens_applied_error(values, unit_scale=d.unit_scale, decimals=decimals)
    applied = ErrorTable(table.position, removed, removed, "backlash", table.model, table.backlash)
    return Written(text, notes, applied, offset_note)


def _fanuc(d: AxisData, o: ExportOptions, table: ErrorTable, axis: str) -> Written:
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
    notes: list[str] = []
    note, backlash = "", 0.0
    if not bidirectional:
        lost = int(round_half_away(-table.backlash / o.fanuc_detection_unit_um))
        backlash = -lost * o.fanuc_detection_unit_um
        note = f"backlash parameter 1851 = {lost} detection units of lost motion"
        notes.append(_backlash_note(table, d) + f" (Fanuc parameter 1851 = {lost} detection units)")
    count_um = o.fanuc_detection_unit_um * o.fanuc_magnification
    c_up, c_dn = pitch.absolute_counts()
    removed_up = -c_up * count_um
    removed_dn = removed_up if c_dn is None else -c_dn * count_um
    applied = ErrorTable(pitch.positions_mm(), removed_up, removed_dn, table.mode, table.model, backlash)
    reference_curve = table.error_down if bidirectional and o.fanuc_reference_direction == -1 else table.error_up
    offset = float(np.interp(ref, table.position, reference_curve))
    offset_note = (f"Fanuc corrections are relative to the reference position {ref:g} mm: the error there "
                   f"({offset:+.3f} um) stays in every residual (in max|r| and RMS, not in range, E or M)")
    text = fanuc_text(pitch, axis=nc_text.axis_letter(axis, "the axis name"),
                      note=nc_text.comment(note, "the table's note"))
    return Written(text, notes, applied, offset_note)
