"""The positioning evaluation as the export reads it: per-target mean deviations of both directions,
checked and unpacked (:class:`AxisData`; positions mm or deg, errors um or arcsec)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from ..errors import UserError
from .options import UNITS


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
