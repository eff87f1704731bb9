"""Fanuc pitch error compensation (Series 0i / 16i / 18i / 30i, standards.md §4.4).

Rules used (manual text and the 0i-PB example of standards.md §4.4):

* compensation point N sits at x_N = x_ref + (N − n_ref)·d (d = interval, parameter 3624,
  n_ref = parameter 3620); the value of point N is **incremental** and is output while the axis
  crosses the interval from point N−1 to point N;
* 3621 = n_ref − (negative stroke / d) + 1, 3622 = n_ref + (positive stroke / d);
* one count = detection unit × magnification (3623);
* values are corrections (counts the control adds), so the absolute correction is
  c_k = round(−(e(x_k) − e_ref)/(unit·mag)) with c_ref = 0 at the reference position, and the
  incremental value is v_N = c_N − c_{N−1}: the cumulative value is rounded, never the
  increments, so rounding errors do not accumulate;
* bidirectional pitch error compensation (3605#0 BDP = 1): a second table of the same length
  for travel in the negative direction starts at point 3626; 3627 is the absolute correction at
  the reference position when it is approached from the direction opposite to the
  reference-return direction.  Both tables are relative to the reference-return direction's
  curve at the reference position (assumption, standards.md §4.4 tags the bidirectional
  details [KNOW]).

Linear axes only: the rotary rules (3625, closure of a revolution) are not implemented.
Units: positions mm; errors and the detection unit um.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def round_half_away(v: np.ndarray | float) -> np.ndarray:
    """Round to the nearest integer, halves away from zero (int64)."""
    # float64 or the input's own float/int type give the same result (m − floor(m) is exact in both)
    a = np.asarray(v, dtype=float)  # pragma: no mutate (equivalent)
    m = np.abs(a)
    f = np.floor(m)
    # m − f is exact in binary floating point; floor(m + 0.5) is not: (0.5 − 2⁻⁵⁴) + 0.5 rounds to 1.0
    return (np.sign(a) * (f + (m - f >= 0.5))).astype(np.int64)


def incremental_from_absolute(c: np.ndarray) -> np.ndarray:
    """v_N = c_N − c_{N−1} for the points after the first absolute value ``c[0]``."""
    return np.diff(np.asarray(c, dtype=np.int64))


def absolute_from_incremental(v: np.ndarray, first_number: int, ref_number: int, ref_value: int = 0) -> np.ndarray:
    """Absolute profile at the positions of points first_number − 1 … last (one more value than
    ``v``), anchored so that the value at point ``ref_number`` is ``ref_value``."""
    cum = np.concatenate(([0], np.cumsum(np.asarray(v, dtype=np.int64))))
    k = ref_number - (first_number - 1)
    if not 0 <= k < len(cum):
        raise ValueError("the reference point lies outside the table")
    return cum - cum[k] + ref_value


@dataclass(frozen=True)
class FanucPitchTable:
    """A Fanuc pitch-error table: parameters and incremental point values (counts)."""

    reference_number: int  # 3620
    negative_end: int  # 3621
    positive_end: int  # 3622
    magnification: int  # 3623
    interval_mm: float  # 3624
    detection_unit_um: float
    reference_position_mm: float
    values: np.ndarray  # points negative_end … positive_end, + travel (or both directions)
    negative_table_start: int | None = None  # 3626 (bidirectional only)
    reference_offset: int | None = None  # 3627 (bidirectional only)
    values_negative: np.ndarray | None = None
    reference_direction: int = 1  # reference-return direction (+1 or −1): which table 3627 belongs to

    @property
    def bidirectional(self) -> bool:
        return self.values_negative is not None

    def positions_mm(self) -> np.ndarray:
        """Positions of points negative_end − 1 … positive_end (the table's stroke)."""
        n = np.arange(self.negative_end - 1, self.positive_end + 1)
        return self.reference_position_mm + (n - self.reference_number) * self.interval_mm

    def absolute_counts(self) -> tuple[np.ndarray, np.ndarray | None]:
        """Absolute correction (counts) at :meth:`positions_mm`: the + travel table and,
        bidirectional, the − travel table; the sums of the incremental values as the control adds
        them up.  The table of the reference-return direction is 0 at the reference, the other one
        3627 (the reference approached against the reference-return direction)."""
        up = absolute_from_incremental(self.values, self.negative_end, self.reference_number)
        if self.values_negative is None:
            return up, None
        down = absolute_from_incremental(self.values_negative, self.negative_end, self.reference_number)
        offset = int(self.reference_offset or 0)
        if self.reference_direction == -1:  # reference return in −: the + table is approached against it
            return up + offset, down
        return up, down + offset


def fanuc_pitch_table(
    error_up_um: np.ndarray,
    error_down_um: np.ndarray | None,
    *,
    grid_mm: np.ndarray,
    reference_position_mm: float,
    detection_unit_um: float = 1.0,
    magnification: int = 1,
    first_number: int = 0,
    reference_number: int | None = None,
    negative_table_start: int | None = None,
    reference_direction: int = 1,
) -> FanucPitchTable:
    """Build the table from the modelled errors on ``grid_mm`` (increasing, equidistant within
    1e-9 × max(1 mm, interval), containing the reference position within 1e-6 intervals).
    ``error_down_um`` None → one table for both directions.

    ``first_number`` is the number of the first point (3621) when ``reference_number`` (3620)
    is not given (with the reference at the negative end 3620 = 3621 − 1, so a first number 0
    becomes 1); ``negative_table_start`` (3626) defaults to the point after 3622.
    ``reference_direction`` is the reference-return direction (+1 or −1).
    """
    g = np.asarray(grid_mm, dtype=float)
    if len(g) < 2:
        raise ValueError("a pitch table needs at least 2 grid positions")
    d = float(g[1] - g[0])
    if not d > 0:  # a decreasing grid gave a negative 3624; a repeated position a NaN reference index
        raise ValueError(f"the grid positions must increase (3624 > 0); the first two are {g[0]:g} and {g[1]:g} mm")
    if np.any(np.abs(np.diff(g) - d) > 1e-9 * max(1.0, abs(d))):
        raise ValueError("Fanuc pitch compensation needs an equidistant grid")
    k_ref = (reference_position_mm - g[0]) / d
    if abs(k_ref - round(k_ref)) > 1e-6 or not 0 <= round(k_ref) < len(g):
        raise ValueError("the reference position must be one of the grid positions")
    k_ref = int(round(k_ref))
    if magnification < 1:
        raise ValueError("magnification must be a positive integer")
    if not detection_unit_um > 0:
        raise ValueError("detection unit must be positive")
    if reference_direction not in (1, -1):
        raise ValueError("reference direction must be +1 or -1")
    neg_intervals = k_ref
    if reference_number is None:  # 3621 = first_number (3620 = 0, 3621 = 1 if that is impossible)
        reference_number = max(first_number + neg_intervals - 1, 0)
    n_neg = reference_number - neg_intervals + 1  # 3621
    n_pos = reference_number + (len(g) - 1 - k_ref)  # 3622
    if n_neg < 0:
        raise ValueError(f"reference point number {reference_number} leaves point numbers below 0 "
                         f"({neg_intervals} intervals on the negative side)")
    q = detection_unit_um * magnification
    e_up = np.asarray(error_up_um, dtype=float)
    e_dn = None if error_down_um is None else np.asarray(error_down_um, dtype=float)
    e_ref = (e_up if reference_direction == 1 or e_dn is None else e_dn)[k_ref]
    c_up = round_half_away(-(e_up - e_ref) / q)
    if e_dn is None:
        return FanucPitchTable(reference_number, n_neg, n_pos, magnification, d, detection_unit_um,
                               float(reference_position_mm), incremental_from_absolute(c_up),
                               reference_direction=reference_direction)
    c_dn = round_half_away(-(e_dn - e_ref) / q)
    start = n_pos + 1 if negative_table_start is None else negative_table_start
    if start < 0:
        raise ValueError(f"the negative-direction table start (3626) {start} is below 0: point numbers start at 0")
    if start <= n_pos and start + (n_pos - n_neg) >= n_neg:
        raise ValueError("the negative-direction table overlaps the positive-direction table")
    offset = int(c_dn[k_ref] if reference_direction == 1 else c_up[k_ref])
    return FanucPitchTable(reference_number, n_neg, n_pos, magnification, d, detection_unit_um,
                           float(reference_position_mm), incremental_from_absolute(c_up), start, offset,
                           incremental_from_absolute(c_dn), reference_direction)


def _fmt_interval(v: float) -> str:
    return f"{v:.3f}"


def fanuc_text(
    t: FanucPitchTable,
    *,
    axis: str = "X",  # pragma: no mutate (equivalent: upper-cased below, "x" is the same axis)
    note: str = "",
) -> str:
    """A parameter listing for entry on the control (parameter and pitch error screens).

    Format (ours; the punch-file layout could not be verified, standards.md §4.4):
    ``(...)`` comment lines, ``PARAM <number>=<value>`` and ``PITCH <point>=<increment>``.
    """
    unit = t.detection_unit_um
    lines = [
        f"(GUIDEWAY PITCH ERROR COMPENSATION AXIS {axis.upper()})",
        f"(ONE COUNT = {unit:g} UM X MAGNIFICATION {t.magnification}; VALUES ARE INCREMENTAL CORRECTIONS)",
    ]
    if note:
        lines.append(f"({note.upper().replace('(', '[').replace(')', ']')})")  # comments do not nest
    lines.append(f"(REFERENCE POSITION {t.reference_position_mm:g} MM = POINT {t.reference_number})")
    lines.append(f"PARAM 3605#0={1 if t.bidirectional else 0}")
    lines.append(f"PARAM 3620={t.reference_number}")
    lines.append(f"PARAM 3621={t.negative_end}")
    lines.append(f"PARAM 3622={t.positive_end}")
    lines.append(f"PARAM 3623={t.magnification}")
    steps = t.interval_mm * 1000.0 / unit
    lines.append(f"(3624 IN MM; SERIES THAT TAKE DETECTION UNITS: {steps:.0f})")
    lines.append(f"PARAM 3624={_fmt_interval(t.interval_mm)}")
    if t.bidirectional:
        lines.append(f"PARAM 3626={t.negative_table_start}")
        # 3627 belongs to the table approached against the reference return, which is the control's own
        # parameter 1006#5 ZMI (not written: entering it would change how the machine homes): say which
        sign, zmi, table = ("-", 1, "+") if t.reference_direction == -1 else ("+", 0, "-")
        lines.append(f"(REFERENCE RETURN IN {sign} DIRECTION, 1006#5 ZMI = {zmi}: 3627 IS THE {table}"
                     " TABLE AT THE REFERENCE)")
        lines.append(f"PARAM 3627={t.reference_offset}")
    lines.append("(POSITIVE DIRECTION)" if t.bidirectional else "(BOTH DIRECTIONS)")
    lines += [f"PITCH {n}={int(v)}" for n, v in zip(range(t.negative_end, t.positive_end + 1), t.values, strict=True)]
    if t.values_negative is not None:
        if t.negative_table_start is None:
            raise ValueError("a bidirectional table needs parameter 3626 (the first point of its negative-direction "
                             "table)")
        lines.append("(NEGATIVE DIRECTION)")
        lines += [f"PITCH {t.negative_table_start + i}={int(v)}" for i, v in enumerate(t.values_negative)]
    return "\n".join(lines) + "\n"
