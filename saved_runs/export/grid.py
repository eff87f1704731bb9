"""The table grid of ``guideway export``: where the controller file puts its points.

Rules (docs/compensation.md, "Table grid"):

* no table point outside the measured range [first target, last target] (a modulo LEC table of
  a rotary axis spans one revolution from the first target, whose end is the first target
  again): outside it a model has nothing to say, and the controller holds the end values anyway;
* Fanuc and Siemens need an equidistant grid; without ``--step`` it has as many intervals as
  the targets and the step is the mean target spacing rounded *down* to what the file holds
  (Siemens: 6 decimals; Fanuc: whole detection units at 0.001 mm), so the grid stays inside;
* a given ``--step`` must be representable in the file; the grid then covers the part of the
  measured range it reaches, and the notes say where it stops short of an end target.

Positions in mm (rotary axes: deg).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from processing.compensation.tables import equidistant_grid, floor_to

from ..errors import UserError

if TYPE_CHECKING:
    from .axis import AxisData
    from .options import ExportOptions

EQUIDISTANT = ("fanuc", "siemens")
MAX_GRID_POINTS = 100_000  # no controller takes more; guards against a mistyped --step
SIEMENS_RESOLUTION = 1e-6  # $AA_ENC_COMP_STEP / _MIN / _MAX are written with 6 decimals
FREE_RESOLUTION = 1e-6  # LinuxCNC and CSV positions are written with 6 decimals
REVOLUTION_DEG = 360.0


def fanuc_resolution_mm(detection_unit_um: float) -> float:
    """The finest Fanuc interval (parameter 3624): a whole number of detection units that the
    listing can write at 0.001 mm (the smallest multiple of the unit that is a whole µm)."""
    for k in range(1, 1001):
        r = k * detection_unit_um
        if abs(r - round(r)) < 1e-9:
            return round(r) / 1000.0
    return detection_unit_um / 1000.0  # pragma: no cover - a unit no series uses


def resolution(o: ExportOptions) -> float:
    if o.fmt == "fanuc":
        return fanuc_resolution_mm(o.fanuc_detection_unit_um)
    return SIEMENS_RESOLUTION if o.fmt == "siemens" else FREE_RESOLUTION


def _modulo(o: ExportOptions) -> bool:
    return o.fmt == "siemens" and o.siemens_modulo


def _default_step(d: AxisData, o: ExportOptions, res: float) -> float:
    x0, x1 = float(np.min(d.target)), float(np.max(d.target))
    n = len(d.target)
    if _modulo(o):  # a whole number of steps per revolution, exact in the file
        intervals = n - 1 if x1 - x0 >= REVOLUTION_DEG - 1e-6 else n
        for k in range(intervals, intervals + 1000):
            step = REVOLUTION_DEG / k
            if abs(step / res - round(step / res)) < 1e-6:
                return round(step / res) * res
        raise UserError("no grid step divides 360 deg exactly at 6 decimals; give --step")  # pragma: no cover
    return max(floor_to((x1 - x0) / (n - 1), res), res)


def _check_step(step: float, o: ExportOptions, res: float) -> None:
    if not (math.isfinite(step) and step > 0):
        raise UserError(f"--step must be positive, got {step:g}")
    if o.fmt not in EQUIDISTANT or abs(step / res - round(step / res)) < 1e-6:
        return
    if o.fmt == "fanuc":
        raise UserError(f"--step {step:g} mm is not a whole number of detection units "
                        f"({o.fanuc_detection_unit_um:g} um) at 0.001 mm; use a multiple of {res:g} mm")
    raise UserError(f"--step {step!r} is not exact at 6 decimals (the LEC table writes STEP with 6); "
                    "choose a rounder step")


def table_grid(d: AxisData, o: ExportOptions) -> tuple[np.ndarray | None, list[str]]:
    """(grid, notes): the table positions (None: the model's own nodes, LinuxCNC and CSV
    without ``--step``) and what the user should know about them."""
    if o.step is None and o.fmt not in EQUIDISTANT:
        return None, []
    x0, x1 = float(np.min(d.target)), float(np.max(d.target))
    res = resolution(o)
    step = _default_step(d, o, res) if o.step is None else float(o.step)
    _check_step(step, o, res)
    hi = x0 + REVOLUTION_DEG if _modulo(o) and d.axis_type == "rotary" else x1
    anchor = x0
    if o.fmt == "fanuc" and o.reference_position is not None:
        anchor = float(o.reference_position)
        tol = 1e-9 * max(1.0, abs(x0), abs(x1))
        if not x0 - tol <= anchor <= x1 + tol:
            raise UserError(f"--reference-position {anchor:g} mm lies outside the measured range "
                            f"{x0:g} … {x1:g} mm, and no table may reach outside it; measure from the "
                            "reference position, or give one inside the range")
    if (hi - x0) / step > MAX_GRID_POINTS:
        raise UserError(f"--step {step:g} gives more than {MAX_GRID_POINTS} table points; use a larger step")
    grid = equidistant_grid(x0, hi, step, anchor=anchor, inside=True)
    if len(grid) < 2:
        raise UserError(f"--step {step:g} leaves fewer than 2 table points within the measured range "
                        f"{x0:g} … {x1:g} {d.position_unit}; use a smaller step")
    if _modulo(o) and abs(grid[-1] - grid[0] - REVOLUTION_DEG) > 1e-6:
        raise UserError(f"a modulo LEC table must span 360 deg; targets and --step give "
                        f"{grid[0]:g} … {grid[-1]:g} deg")
    return grid, _end_notes(grid, x0, hi, d.position_unit)


def _end_notes(grid: np.ndarray, lo: float, hi: float, unit: str) -> list[str]:
    notes = []
    tol = 1e-6 * max(1.0, abs(lo), abs(hi))
    if grid[0] > lo + tol:
        notes.append(f"the table starts at {grid[0]:g} {unit}, {grid[0] - lo:g} {unit} after the first target "
                     f"({lo:g} {unit}): before it the controller holds the first value")
    if grid[-1] < hi - tol:
        notes.append(f"the table ends at {grid[-1]:g} {unit}, {hi - grid[-1]:g} {unit} before the last target "
                     f"({hi:g} {unit}): beyond it the controller holds the last value")
    return notes
