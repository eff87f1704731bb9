"""SINUMERIK leadscrew / encoder error compensation (LEC, ``$AA_ENC_COMP``) and direction-dependent
CEC tables (``$AN_CEC``) as the control applies them (standards.md §4.2, §4.3).

* LEC: equidistant points N = 0 … k at MIN + N·STEP, MAX = MIN + k·STEP; linear interpolation;
  "the first and last compensation values remain active over the entire traversing range"; the
  value is the measured error: "a positive compensation value causes the machine axis to move in
  the negative direction", so the correction is −value; **not direction dependent**.
* Modulo (``IS_MODULO`` = 1, rotary axes): the table repeats; the position is taken modulo
  MAX − MIN into [MIN, MAX).
* CEC (§4.3): ``$AN_CEC_DIRECTION[t]`` 0 = both directions, 1 = only positive, −1 = only negative
  traversing direction of the input axis: "position-dependent backlash compensation can be
  implemented using two tables"; the values of every table acting on an output axis are summed;
  below MIN / above MAX the first / last value is held.  Only tables whose input and output axis
  are both this axis are applied here.  The sign of a CEC value is taken as LEC's (the value is
  the error; the manual's examples describe both alike) [UNVERIFIED: check on the machine].
* Active only after the axis is referenced (MD32700 ENC_COMP_ENABLE = 1, then referencing).

Positions and values in mm (deg).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_LEC_VALUE = re.compile(rf"^\$AA_ENC_COMP\[\s*(\d+)\s*,\s*(\d+)\s*,\s*([A-Za-z_][A-Za-z0-9_]*)\s*\]\s*=\s*({_NUM})$")
_LEC_META = re.compile(rf"^\$AA_ENC_COMP_(STEP|MIN|MAX|IS_MODULO)\[\s*(\d+)\s*,\s*([A-Za-z_][A-Za-z0-9_]*)\s*\]"
                       rf"\s*=\s*({_NUM})$")
_CEC_VALUE = re.compile(rf"^\$AN_CEC\[\s*(\d+)\s*,\s*(\d+)\s*\]\s*=\s*({_NUM})$")
_CEC_META = re.compile(rf"^\$AN_CEC_(STEP|MIN|MAX|DIRECTION|IS_MODULO|MULT_BY_TABLE)\[\s*(\d+)\s*\]\s*=\s*({_NUM})$")
_CEC_AXIS = re.compile(r"^\$AN_CEC_(INPUT|OUTPUT)_AXIS\[\s*(\d+)\s*\]\s*=\s*\(\s*([A-Za-z_][A-Za-z0-9_]*)\s*\)$")
_FRAME = re.compile(r"^(%_N_\w+|CHANDATA\(\d+\)|M17|M30|M02|M2)$")


@dataclass(frozen=True)
class EquidistantTable:
    """One equidistant table: values at MIN + N·STEP (mm or deg)."""

    values: np.ndarray
    step: float
    minimum: float
    maximum: float
    modulo: bool = False
    direction: int = 0  # CEC only: 0 both, +1 positive, −1 negative traversing direction

    def value(self, position: float) -> float:
        """Linear interpolation; end values held; modulo tables repeat over [MIN, MAX)."""
        x = position
        if self.modulo:
            x = self.minimum + float(np.mod(position - self.minimum, self.maximum - self.minimum))
        grid = self.minimum + self.step * np.arange(len(self.values))
        return float(np.interp(x, grid, self.values))

    def acts(self, direction: int) -> bool:
        """Does this table act for the last traversing ``direction``? (0: not moved yet: only
        tables for both directions.)"""
        return self.direction == 0 or self.direction == direction


@dataclass(frozen=True)
class SiemensComp:
    """The LEC table of a measuring system and the CEC tables of one axis."""

    axis: str
    encoder: int | None
    lec: EquidistantTable | None
    cec: tuple[EquidistantTable, ...] = field(default_factory=tuple)

    @property
    def direction_dependent(self) -> bool:
        return any(t.direction != 0 for t in self.cec)

    def correction(self, commanded: float, direction: int) -> float:
        """−(LEC value + the CEC values acting in ``direction``) at ``commanded`` (mm or deg)."""
        total = self.lec.value(commanded) if self.lec is not None else 0.0
        total += sum(t.value(commanded) for t in self.cec if t.acts(direction))
        return -total


def _table(values: dict[int, float], meta: dict[str, float], what: str, direction: int = 0) -> EquidistantTable:
    for key in ("STEP", "MIN", "MAX"):
        if key not in meta:
            raise ValueError(f"{what}: {key} is missing")
    if sorted(values) != list(range(len(values))) or len(values) < 2:
        raise ValueError(f"{what}: the points must be numbered 0 … k (at least 2)")
    step, lo, hi = meta["STEP"], meta["MIN"], meta["MAX"]
    if not step > 0:
        raise ValueError(f"{what}: STEP must be positive")
    n_max = (hi - lo) / step
    if abs(n_max - round(n_max)) > 1e-6 or round(n_max) != len(values) - 1:
        raise ValueError(f"{what}: (MAX - MIN) / STEP = {n_max:g} but the points run 0 … {len(values) - 1}")
    v = np.array([values[i] for i in range(len(values))], dtype=float)
    return EquidistantTable(v, step, lo, hi, bool(meta.get("IS_MODULO", 0)), direction)


def read_siemens_comp(text: str, axis: str | None = None) -> SiemensComp:
    """Read an ``%_N_AX_EEC_INI`` (LEC) and/or ``%_N_NC_CEC_INI`` (CEC) text: ``;`` comments,
    ``CHANDATA``, ``M17``/``M30`` ignored.  One LEC axis and measuring system per file; CEC tables are
    kept where their input and output axis are the LEC axis (or ``axis``).  ValueError names the
    first line that is wrong."""
    lec_values: dict[int, float] = {}
    lec_meta: dict[str, float] = {}
    lec_keys: set[tuple[int, str]] = set()
    cec_values: dict[int, dict[int, float]] = {}
    cec_meta: dict[int, dict[str, float]] = {}
    cec_axes: dict[int, dict[str, str]] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split(";", 1)[0].strip()
        if not line or _FRAME.match(line):
            continue
        if m := _LEC_VALUE.match(line):
            e, n, ax, v = m.groups()
            if int(n) in lec_values:
                raise ValueError(f"line {number}: point {n} assigned twice")
            lec_values[int(n)] = float(v)
            lec_keys.add((int(e), ax))
        elif m := _LEC_META.match(line):
            name, e, ax, v = m.groups()
            lec_meta[name] = float(v)
            lec_keys.add((int(e), ax))
        elif m := _CEC_VALUE.match(line):
            t, n, v = m.groups()
            cec_values.setdefault(int(t), {})[int(n)] = float(v)
        elif m := _CEC_META.match(line):
            name, t, v = m.groups()
            cec_meta.setdefault(int(t), {})[name] = float(v)
        elif m := _CEC_AXIS.match(line):
            which, t, ax = m.groups()
            cec_axes.setdefault(int(t), {})[which] = ax
        else:
            raise ValueError(f"line {number}: not a $AA_ENC_COMP / $AN_CEC assignment: {line[:50]!r}")
    if len(lec_keys) > 1:
        raise ValueError("the LEC assignments name more than one axis or measuring system: "
                         + ", ".join(f"[{e},{a}]" for e, a in sorted(lec_keys)))
    encoder, lec_axis = next(iter(lec_keys)) if lec_keys else (None, None)
    lec = _table(lec_values, lec_meta, f"$AA_ENC_COMP[{encoder},{lec_axis}]") if lec_keys else None
    own = axis or lec_axis
    cec = []
    for t in sorted(set(cec_values) | set(cec_meta)):
        meta, axes = cec_meta.get(t, {}), cec_axes.get(t, {})
        if own is not None and (axes.get("INPUT", own) != own or axes.get("OUTPUT", own) != own):
            continue  # another axis's table (sag of one axis over another): not this axis's error
        direction = int(meta.get("DIRECTION", 0))
        if direction not in (-1, 0, 1):
            raise ValueError(f"$AN_CEC_DIRECTION[{t}] must be -1, 0 or 1")
        cec.append(_table(cec_values.get(t, {}), meta, f"$AN_CEC[{t}]", direction))
        own = own or axes.get("OUTPUT")
    if lec is None and not cec:
        raise ValueError("no $AA_ENC_COMP or $AN_CEC table in the file")
    return SiemensComp(own or "", encoder, lec, tuple(cec))
