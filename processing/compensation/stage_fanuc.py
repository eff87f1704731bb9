"""Fanuc pitch error and backlash compensation as the control applies them (standards.md §4.4 for the
pitch table; the backlash rules are stated below with their level of evidence).

Pitch error compensation (standards.md §4.4, 0i-PB parameter manual B-63980EN p.100):

* point N sits at x_ref + (N − 3620)·3624; its value is an **incremental** number of counts, output
  while the axis crosses from point N−1 to point N; the absolute correction at point N is the sum
  of the increments from the reference point (0 there), so the table is relative to the reference
  position and cumulative;
* one count = detection unit × magnification (3623); values are whole counts;
* beyond the points 3621 − 1 … 3622 nothing more is output: the end values hold;
* between points the increment's pulses are output as the axis crosses the interval: modelled as
  linear between the points (the pulses are whole, so a real control is within one count of it);
* bidirectional (3605#0 BDP = 1): the − travel table starts at 3626 with the same length; 3627 is
  the absolute value at the reference position approached from the direction opposite to the
  reference-return direction [KNOW in standards.md], i.e. the − table's with a reference return in +
  (1006#5 ZMI = 0), the + table's with a reference return in − (ZMI = 1); the table of the
  reference-return direction is 0 there.  The reference-return direction is a machine parameter of
  the control, not part of the listing: the caller gives it (the set-up's ``reference_direction``);
  the listing's comment states the one it was written for, and a listing written for the other one
  is refused (its 3627 would sit on the wrong table);
* rotary axis (3625 = travel per revolution > 0): the position is taken modulo 3625 from the
  reference position (the standards.md rotary example: points 3620 … 3622 cover one revolution);
* active only after a reference return (standards.md §4.4: "reference return required").

Backlash compensation (1851 cutting feed, 1852 rapid traverse with 1800#4 RBK = 1, detection units,
not multiplied by 3623) — not in standards.md, from Fanuc's parameter manuals [KNOW, check on the
series]: on a reversal the control outputs the backlash value in the new direction.  After power-on
the control takes the reference-return direction as the last direction, so the first move that way
outputs nothing and the **first reversal** away from it outputs B in the new direction (−B moving −,
with a + reference return).  The correction is therefore 0 in the reference-return direction and
direction·B after a reversal; it is independent of the reference return (active from power-on).

Units: positions mm (deg), the detection unit in µm (linear) or 0.001 deg (rotary), corrections in
the position unit.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

_PARAM = re.compile(r"^PARAM\s+(\d{4}(?:#\d)?)\s*=\s*([+-]?\d+(?:\.\d+)?)$")
_PITCH = re.compile(r"^PITCH\s+(\d+)\s*=\s*([+-]?\d+)$")
_REFERENCE = re.compile(r"REFERENCE POSITION ([+-]?\d+(?:\.\d*)?(?:E[+-]?\d+)?) (?:MM|DEG) = POINT (\d+)")
_COUNT = re.compile(r"ONE COUNT = ([+-]?\d+(?:\.\d*)?(?:E[+-]?\d+)?) UM")
_AXIS = re.compile(r"COMPENSATION AXIS ([A-Z])\b")
_RETURN = re.compile(r"REFERENCE RETURN IN ([+-]) DIRECTION")


@dataclass(frozen=True)
class FanucComp:
    """The pitch-error and backlash parameters of one axis as the control holds them."""

    reference_number: int  # 3620
    negative_end: int  # 3621
    positive_end: int  # 3622
    magnification: int  # 3623
    interval: float  # 3624, mm (deg)
    values: np.ndarray  # increments of points 3621 … 3622 (counts), + travel (or both)
    values_negative: np.ndarray | None = None  # 3626 …, − travel (3605#0 = 1)
    reference_offset: int = 0  # 3627: counts at the reference of the table against the reference return
    rotary_travel: float = 0.0  # 3625 (0: linear axis)
    backlash_cutting: int = 0  # 1851, detection units
    backlash_rapid: int | None = None  # 1852 when 1800#4 RBK = 1
    reference_position: float | None = None  # axis coordinate of the reference position (listing comment)
    detection_unit: float | None = None  # µm (listing comment); None: not stated in the file
    axis: str | None = None  # the listing's axis letter
    written_reference_direction: int | None = None  # the reference return the listing says it is for (comment)

    @property
    def bidirectional(self) -> bool:
        return self.values_negative is not None

    def point_positions(self, reference_position: float) -> np.ndarray:
        """Positions of points 3621 − 1 … 3622 (the first is where the first increment starts)."""
        n = np.arange(self.negative_end - 1, self.positive_end + 1)
        return reference_position + (n - self.reference_number) * self.interval

    def absolute_counts(self, direction: int, reference_direction: int) -> np.ndarray:
        """Absolute correction (counts) at :meth:`point_positions` for travel in ``direction`` with the
        reference return in ``reference_direction`` (+1 or −1): the running sum of the increments, 0 at
        the reference point, or 3627 there for the bidirectional table of the direction opposite to the
        reference return."""
        neg = self.values_negative is not None and direction < 0
        v = self.values_negative if neg and self.values_negative is not None else self.values
        cum = np.concatenate(([0], np.cumsum(np.asarray(v, dtype=np.int64))))
        k = self.reference_number - (self.negative_end - 1)
        against = self.bidirectional and (direction < 0) != (reference_direction < 0)
        return cum - cum[k] + (self.reference_offset if against else 0)

    def pitch_counts(self, commanded: float, direction: int, reference_position: float,
                     reference_direction: int) -> float:
        """The pitch-error correction (counts, fractional between points) at ``commanded``."""
        x = commanded
        if self.rotary_travel > 0:
            x = reference_position + float(np.mod(commanded - reference_position, self.rotary_travel))
        at = self.point_positions(reference_position)
        return float(np.interp(x, at, self.absolute_counts(direction, reference_direction)))

    def backlash_counts(self, direction: int, reference_direction: int, rapid: bool = False) -> int:
        """The backlash correction (detection units) for the last motion ``direction``: 0 in the
        reference-return direction (the power-on state), direction·B after a reversal away from it."""
        b = self.backlash_rapid if rapid and self.backlash_rapid is not None else self.backlash_cutting
        return 0 if direction in (0, reference_direction) else direction * b


def read_fanuc_listing(text: str) -> FanucComp:
    """Read the parameter listing ``guideway export --format fanuc`` writes (docs/compensation.md:
    ``(...)`` comments, ``PARAM <no>=<value>``, ``PITCH <point>=<increment>``).  ValueError names
    the first line or parameter that is wrong."""
    params: dict[str, float] = {}
    points: dict[int, int] = {}
    reference_position = unit = None
    axis = None
    written_direction = None
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("(") and line.endswith(")"):
            if m := _REFERENCE.search(line.upper()):
                reference_position = float(m.group(1))
            if m := _COUNT.search(line.upper()):
                unit = float(m.group(1))
            if m := _AXIS.search(line.upper()):
                axis = m.group(1)
            if m := _RETURN.search(line.upper()):
                written_direction = 1 if m.group(1) == "+" else -1
            continue
        if m := _PARAM.match(line):
            params[m.group(1)] = float(m.group(2))
        elif m := _PITCH.match(line):
            if int(m.group(1)) in points:
                raise ValueError(f"line {number}: pitch point {m.group(1)} given twice")
            points[int(m.group(1))] = int(m.group(2))
        else:
            raise ValueError(f"line {number}: not a Fanuc listing line (PARAM n=v, PITCH n=v or (comment)): "
                             f"{line[:40]!r}")
    for key in ("3620", "3621", "3622", "3623", "3624"):
        if key not in params:
            raise ValueError(f"parameter {key} is missing")
    ref, n_neg, n_pos = int(params["3620"]), int(params["3621"]), int(params["3622"])
    mag, interval = int(params["3623"]), params["3624"]
    if not n_neg - 1 <= ref <= n_pos:
        raise ValueError(f"reference point 3620 = {ref} lies outside points 3621 - 1 = {n_neg - 1} … 3622 = {n_pos}")
    if mag < 1 or not interval > 0:
        raise ValueError("3623 (magnification) must be >= 1 and 3624 (interval) positive")

    def table(first: int) -> np.ndarray:
        missing = [n for n in range(first, first + n_pos - n_neg + 1) if n not in points]
        if missing:
            raise ValueError(f"pitch point {missing[0]} is missing")
        return np.array([points[n] for n in range(first, first + n_pos - n_neg + 1)], dtype=np.int64)

    values = table(n_neg)
    negative = None
    if params.get("3605#0", 0) == 1:
        if "3626" not in params:
            raise ValueError("3605#0 = 1 (bidirectional) needs parameter 3626")
        negative = table(int(params["3626"]))
    rbk = params.get("1800#4", 0) == 1
    return FanucComp(ref, n_neg, n_pos, mag, interval, values, negative, int(params.get("3627", 0)),
                     float(params.get("3625", 0.0)), int(params.get("1851", 0)),
                     int(params["1852"]) if rbk and "1852" in params else None,
                     reference_position, unit, axis, written_direction)
