"""Siemens SINUMERIK 840D sl / 828D LEC table (``$AA_ENC_COMP``, standards.md §4.2).

``$AA_ENC_COMP[e,N,AX]`` = compensation value of interpolation point N (0 … k) for measuring
system e, in mm (deg for a rotary axis); the value is the **measured error +e** (a positive
value moves the machine axis in the negative direction).  Points are equidistant:
``$AA_ENC_COMP_STEP`` apart from ``$AA_ENC_COMP_MIN`` to ``$AA_ENC_COMP_MAX`` =
MIN + k·STEP; linear interpolation between points; the first and last values stay active
outside [MIN, MAX].  LEC is not direction dependent: write the mean curve and put the
reversal into the backlash machine data.  Modulo tables repeat; their values at MIN and MAX
must be equal.  The file is an NC INI archive ending in M17; MD38000 MM_ENC_COMP_MAX_POINTS
must be ≥ k + 1.
"""

from __future__ import annotations

import numpy as np

from .numbers import fixed


def siemens_lec_text(
    position: np.ndarray,
    error: np.ndarray,
    *,
    axis: str = "X1",
    encoder: int = 0,
    unit_scale: float = 1e-3,
    decimals: int = 6,
    modulo: bool = False,
    max_points: int | None = None,
    note: str = "",
) -> str:
    """The ``%_N_AX_EEC_INI`` text for the error curve ``error`` (um, or arcsec) at the
    equidistant ``position`` (mm, or deg).  ``unit_scale`` converts the error unit to the
    position unit (um → mm 1e-3, arcsec → deg 1/3600)."""
    p = np.asarray(position, dtype=float)
    v = np.asarray(error, dtype=float) * unit_scale
    if p.ndim != 1 or p.shape != v.shape or len(p) < 2:
        raise ValueError("a LEC table needs at least 2 positions with one value each")
    step = float(p[1] - p[0])
    if step <= 0 or np.any(np.abs(np.diff(p) - step) > 1e-9 * max(1.0, abs(step))):
        raise ValueError("a LEC table needs equidistant, increasing positions")
    if abs(round(step, 6) - step) > 1e-9 * max(1.0, abs(step)):
        raise ValueError(f"grid step {step!r} is not exact at 6 decimals; choose a rounder step")
    if encoder not in (0, 1):
        raise ValueError("measuring system (encoder) index must be 0 or 1")
    if max_points is not None and len(p) > max_points:
        raise ValueError(f"{len(p)} interpolation points; MD38000 MM_ENC_COMP_MAX_POINTS allows {max_points}")
    if not axis or any(c in axis for c in " ,[]=;"):
        raise ValueError(f"invalid axis name {axis!r}")
    vs = siemens_values(error, unit_scale=unit_scale, decimals=decimals)
    if modulo and float(vs[0]) != float(vs[-1]):
        raise ValueError("a modulo LEC table needs equal values at MIN and MAX")
    lines = ["%_N_AX_EEC_INI", "CHANDATA(1)"]
    for i, s in enumerate(vs):
        comment = f" ; {note}" if i == 0 and note else ""
        lines.append(f"$AA_ENC_COMP[{encoder},{i},{axis}]={s}{comment}")
    lo, hi = float(p[0]), float(p[0] + step * (len(p) - 1))
    lines += [
        f"$AA_ENC_COMP_STEP[{encoder},{axis}]={fixed(step, 6)}",
        f"$AA_ENC_COMP_MIN[{encoder},{axis}]={fixed(lo, 6)}",
        f"$AA_ENC_COMP_MAX[{encoder},{axis}]={fixed(hi, 6)}",
        f"$AA_ENC_COMP_IS_MODULO[{encoder},{axis}]={1 if modulo else 0}",
        "M17",
    ]
    return "\n".join(lines) + "\n"


def siemens_values(error: np.ndarray, *, unit_scale: float = 1e-3, decimals: int = 6) -> list[str]:
    """The compensation values as written: +e in the position unit, ``decimals`` decimals."""
    return [fixed(x, decimals) for x in np.asarray(error, dtype=float) * unit_scale]


def siemens_applied_error(error: np.ndarray, *, unit_scale: float = 1e-3, decimals: int = 6) -> np.ndarray:
    """The error the controller removes at each interpolation point with the values as
    written (rounded to ``decimals``), back in the error unit (um or arcsec)."""
    return np.array([float(s) for s in siemens_values(error, unit_scale=unit_scale, decimals=decimals)]) / unit_scale
