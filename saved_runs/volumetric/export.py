"""``guideway volumetric MACHINE.toml --export linuxcnc|csv --out DIR``: per-axis compensation
tables from the model, and the part a per-axis table cannot hold (docs/volumetric.md, "Export").

Files in DIR: ``<AXIS>.comp`` (LinuxCNC ``COMP_FILE``, type 1: trims −e) or ``<AXIS>.csv`` (the
generic CSV of docs/compensation.md) per moving axis; ``cross-terms.csv``: every element's cross
terms over the grid, largest first (columns ``element, group, body, target, max_abs, unit``, the
pose of the maximum, ``source``).  The model is direction independent: both travel directions
get the same values (a reversal error belongs in ``guideway export`` of the positioning run).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from processing.compensation.generic_csv import csv_text
from processing.compensation.linuxcnc import linuxcnc_comp_text
from processing.compensation.tables import ErrorTable
from processing.volumetric.axis_tables import (
    URAD_PER_ARCSEC,
    AxisTable,
    CrossTerm,
    axis_table,
    cross_terms,
    machine_direction,
)
from processing.volumetric.evaluate import evaluate, nominal

from ..errors import UserError
from ..store.files import write_text_atomic
from ..store.stale_temps import remove_own_stale_temps
from .field import column_name, flat_positions, grid_positions
from .machine_file import MachineFile

EXPORT_FORMATS = ("linuxcnc", "csv")
SUFFIX = {"linuxcnc": ".comp", "csv": ".csv"}


@dataclass(frozen=True)
class AxisResidual:
    """Largest error left along an axis (µm; rotary: µrad about it) over the grid after its table."""

    axis: str
    before: float
    after: float
    unit: str


@dataclass(frozen=True)
class VolumetricExport:
    tables: list[AxisTable]
    files: list[Path]
    cross: list[CrossTerm]
    residuals: list[AxisResidual]
    unheld_position_um: float      # max |error along no compensated direction + cross terms| after all tables
    notes: list[str]


def _error_table(t: AxisTable) -> ErrorTable:
    return ErrorTable(position=t.position, error_up=t.error, error_down=t.error, mode="bidirectional",
                      model="volumetric")


def export_model(machine: MachineFile, fmt: str, out_dir: Path | str, *, count: int,
                 fixed: dict[str, float], method: str = "first-order") -> VolumetricExport:
    """Write the per-axis tables and cross-terms.csv into ``out_dir``."""
    if fmt not in EXPORT_FORMATS:
        raise UserError(f"--export {fmt!r}: choose one of {', '.join(EXPORT_FORMATS)}")
    model = machine.model
    reference = {a.name: fixed.get(a.name, a.reference) for a in model.axes}
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} exists and is not a directory; choose another --out")
    tables = [axis_table(model, a.name, count, reference, machine.conditions, method) for a in model.axes]
    texts: dict[str, str] = {}
    try:
        for t in tables:
            table = _error_table(t)
            scale = 1.0 / 3600.0 if t.kind == "rotary" else 1e-3
            texts[t.axis] = (linuxcnc_comp_text(table, file_type=1, unit_scale=scale) if fmt == "linuxcnc"
                             else csv_text(table, position_unit=t.position_unit, error_unit=t.error_unit))
    except ValueError as exc:
        raise UserError(f"cannot build the {fmt} tables: {exc}") from None
    _, grid = grid_positions(model, count, fixed)
    cross = cross_terms(model, grid, reference, machine.conditions)
    residuals, unheld = _residuals(machine, tables, grid, method)
    files = []
    try:
        out.mkdir(parents=True, exist_ok=True)
        # what a killed export of these tables left
        remove_own_stale_temps(out, [*(f"{t.axis}{SUFFIX[fmt]}" for t in tables), "cross-terms.csv"])
        for t in tables:
            path = out / f"{t.axis}{SUFFIX[fmt]}"
            write_text_atomic(path, texts[t.axis], inside=out)  # a link planted in the folder is refused
            files.append(path)
        path = out / "cross-terms.csv"
        write_text_atomic(path, cross_table(machine, cross, grid).to_csv(index=False, float_format="%.6f"),
                          inside=out)
        files.append(path)
    except OSError as exc:
        raise UserError(f"cannot write the tables to {out}: {exc.strerror or exc}") from None
    notes = ["the model is direction independent: both directions of every table hold the same values; "
             "for the reversal use `guideway export RUN_DIR` on the axis's positioning run"]
    for t in tables:
        lo, hi = model.body(t.axis).range  # type: ignore[misc]
        if t.position[0] > lo or t.position[-1] < hi:
            notes.append(f"the {t.axis} table spans the measured {t.position[0]:g} … {t.position[-1]:g} "
                         f"{t.position_unit} of its range {lo:g} … {hi:g}; beyond, the controller holds the end "
                         "values")
    if fmt == "linuxcnc":
        notes.append("LinuxCNC: [JOINT_n] COMP_FILE = <AXIS>.comp, COMP_FILE_TYPE = 1 (trims −e); table "
                     "positions are axis positions, make sure they are the joint's machine coordinates")
    return VolumetricExport(tables, files, cross, residuals, unheld, notes)


def cross_table(machine: MachineFile, cross: list[CrossTerm], grid: dict[str, np.ndarray]) -> pd.DataFrame:
    model = machine.model
    elements = {e.id: e for e in model.elements}
    grid = flat_positions(grid)
    rows = []
    for c in cross:
        e = elements[c.element]
        rows.append({"element": c.element, "group": e.group, "body": e.body, "target": c.target,
                     "max_abs": c.max_abs, "unit": c.unit,
                     **{column_name(a): float(grid[a.name][c.index]) for a in model.axes}, "source": e.source})
    cols = ["element", "group", "body", "target", "max_abs", "unit", *(column_name(a) for a in model.axes),
            "source"]
    return pd.DataFrame(rows, columns=cols)


def _residuals(machine: MachineFile, tables: list[AxisTable], grid: dict[str, np.ndarray], method: str
               ) -> tuple[list[AxisResidual], float]:
    """The error along each axis over the grid before and after applying its table as a controller
    does (linear interpolation, ends held), and the largest position error the tables leave."""
    model = machine.model
    err = evaluate(model, grid, machine.conditions, method=method, frame="machine")
    nom = nominal(model, grid)
    left = err.position_um.copy()
    out = []
    for t in tables:
        body = model.body(t.axis)
        u = machine_direction(nom, body)
        sign = -1.0 if body.chain == "workpiece" else 1.0
        if body.kind == "prismatic":
            along = np.einsum("...i,...i->...", err.position_um, u)
            held = sign * np.interp(grid[t.axis], t.position, t.error)
            left -= held[..., None] * u
            unit = "um"
        else:
            along = np.einsum("...i,...i->...", err.orientation_urad, u)
            held = sign * np.interp(grid[t.axis], t.position, t.error) * URAD_PER_ARCSEC
            unit = "urad"
        out.append(AxisResidual(t.axis, float(np.max(np.abs(along))), float(np.max(np.abs(along - held))), unit))
    return out, float(np.max(np.linalg.norm(left, axis=-1)))
