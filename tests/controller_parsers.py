"""Test-side readers of controller compensation files, written from the controllers' documented
rules (standards.md §4.1, §4.2, §4.4), independent of the writers in processing/compensation.

Each reader also applies the table the way the controller does, returning the change of the
actual position it produces (the *correction*, in um), so a test can check
compensated error = measured error + correction.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

# ---------------------------------------------------------------------------------------------
# LinuxCNC usrmotLoadComp() + EMCMOT_SET_JOINT_COMP + compute_screw_comp() (standards.md §4.1)

LINELEN = 255  # fgets(buffer, LINELEN, fp) reads at most LINELEN - 1 characters
EMCMOT_COMP_SIZE = 256
_C_SPACE = " \t\n\v\f\r"
# what strtod() accepts for %lf (decimal and inf/nan forms; hex floats are not produced here)
_STRTOD = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan)", re.IGNORECASE)


def fgets_lines(text: str) -> list[str]:
    """The successive buffers fgets() returns: up to and including a newline, at most 254 chars."""
    out, i = [], 0
    while i < len(text):
        j = text.find("\n", i, i + LINELEN - 1)
        end = j + 1 if j >= 0 else min(len(text), i + LINELEN - 1)
        out.append(text[i:end])
        i = end
    return out


def sscanf_lf3(buffer: str) -> list[float]:
    """sscanf(buffer, "%lf %lf %lf", ...): the converted values (fewer than 3 = failure).
    %lf skips leading white space; the blank in the format matches any white space, also none."""
    values, i = [], 0
    for _ in range(3):
        while i < len(buffer) and buffer[i] in _C_SPACE:
            i += 1
        m = _STRTOD.match(buffer, i)
        if not m:
            break
        values.append(float(m.group()))
        i = m.end()
    return values


@dataclass
class LinuxCncComp:
    nominal: list[float] = field(default_factory=list)
    forward: list[float] = field(default_factory=list)  # trims, float32 as in motion.h
    reverse: list[float] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    lines_read: int = 0

    def trim(self, pos: np.ndarray, direction: int) -> np.ndarray:
        """compute_screw_comp(): linear interpolation per direction, end trims held (mm)."""
        t = self.forward if direction > 0 else self.reverse
        return np.interp(np.asarray(pos, dtype=float), self.nominal, np.asarray(t, dtype=float))

    def correction_um(self, pos: np.ndarray, direction: int) -> np.ndarray:
        """motor_pos_cmd = pos_cmd + trim: the actual position moves by the trim."""
        return self.trim(pos, direction) * 1000.0


def read_linuxcnc_comp(text: str, file_type: int) -> LinuxCncComp:
    comp = LinuxCncComp()
    for buffer in fgets_lines(text):
        v = sscanf_lf3(buffer)
        if len(v) != 3:
            break
        comp.lines_read += 1
        nom, fwd, rev = v
        if file_type == 0:
            fwd, rev = nom - fwd, nom - rev  # "convert to diffs"
        if len(comp.nominal) >= EMCMOT_COMP_SIZE:
            comp.errors.append("too many compensation entries")
            continue
        if comp.nominal and nom <= comp.nominal[-1]:
            comp.errors.append("compensation values must increase")
            continue
        comp.nominal.append(nom)
        comp.forward.append(float(np.float32(fwd)))
        comp.reverse.append(float(np.float32(rev)))
    return comp


# ---------------------------------------------------------------------------------------------
# Siemens $AA_ENC_COMP INI (standards.md §4.2)

_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)"
_VALUE = re.compile(rf"^\$AA_ENC_COMP\[(\d+),(\d+),([A-Za-z0-9_]+)\]=({_NUM})$")
_META = re.compile(rf"^\$AA_ENC_COMP_(STEP|MIN|MAX|IS_MODULO)\[(\d+),([A-Za-z0-9_]+)\]=({_NUM})$")


@dataclass
class SiemensLec:
    axis: str
    encoder: int
    values_mm: np.ndarray
    step: float
    minimum: float
    maximum: float
    modulo: bool

    def value_mm(self, pos: np.ndarray) -> np.ndarray:
        """Linear interpolation between the points; first/last value active outside the table."""
        grid = self.minimum + self.step * np.arange(len(self.values_mm))
        return np.interp(np.asarray(pos, dtype=float), grid, self.values_mm)

    def correction_um(self, pos: np.ndarray) -> np.ndarray:
        """A positive compensation value moves the machine axis in the negative direction."""
        return -self.value_mm(pos) * 1000.0


def read_siemens_lec(text: str) -> SiemensLec:
    lines = [ln.split(";", 1)[0].strip() for ln in text.splitlines()]
    lines = [ln for ln in lines if ln]
    assert lines[0] == "%_N_AX_EEC_INI" and lines[1] == "CHANDATA(1)" and lines[-1] == "M17"
    values: dict[int, float] = {}
    meta: dict[str, float] = {}
    keys = set()
    for ln in lines[2:-1]:
        if m := _VALUE.match(ln):
            e, n, ax, v = m.groups()
            assert int(n) not in values, f"point {n} assigned twice"
            values[int(n)] = float(v)
        elif m := _META.match(ln):
            name, e, ax, v = m.groups()
            meta[name] = float(v)
        else:
            raise AssertionError(f"not a LEC assignment: {ln!r}")
        keys.add((int(e), ax))
    assert len(keys) == 1, "one measuring system and axis per table"
    (encoder, axis), = keys
    assert sorted(values) == list(range(len(values))), "points must be numbered 0 … k"
    assert set(meta) == {"STEP", "MIN", "MAX", "IS_MODULO"}
    n_max = (meta["MAX"] - meta["MIN"]) / meta["STEP"]
    assert abs(n_max - round(n_max)) < 1e-9 and round(n_max) == len(values) - 1, "N_max = (MAX − MIN)/STEP"
    vals = np.array([values[i] for i in range(len(values))])
    if meta["IS_MODULO"]:
        assert vals[0] == vals[-1], "modulo: values at MIN and MAX must be equal"
    return SiemensLec(axis, encoder, vals, meta["STEP"], meta["MIN"], meta["MAX"], bool(meta["IS_MODULO"]))


# ---------------------------------------------------------------------------------------------
# Fanuc pitch error compensation listing (standards.md §4.4 rules; listing layout as documented
# in docs/compensation.md: "(...)" comments, "PARAM n=v", "PITCH n=v")

_PARAM = re.compile(r"^PARAM (\d{4}(?:#\d)?)=([+-]?\d+(?:\.\d+)?)$")
_PITCH = re.compile(r"^PITCH (\d+)=([+-]?\d+)$")


@dataclass
class FanucPitch:
    params: dict[str, float]
    points: dict[int, int]
    written_for: str | None = None  # "+" / "-": the reference return the listing's comment says it is for

    def absolute_counts(self, pos_mm: np.ndarray, ref_mm: float, direction: int,
                        reference_direction: int = 1) -> np.ndarray:
        """Absolute correction (counts) at compensation-point positions, travelling in ``direction``
        on a control whose reference return is in ``reference_direction`` (1006#5 ZMI = 0: +1, 1: −1).

        Point N is at x_ref + (N − 3620)·3624; its incremental value is output while the axis
        crosses from point N−1 to N, so the absolute value at point N is the sum of the
        increments from the reference point to N (negated below the reference).  At the reference
        the value is zero, except (bidirectional, 3605#0 = 1) for the table travelled against the
        reference return: 3627 is "the compensation amount (absolute) at the reference position
        when approaching it from the direction opposite to the reference-return direction".
        The + travel table is points 3621 …, the − travel table points 3626 …."""
        p = self.params
        ref, n_neg, n_pos, d = int(p["3620"]), int(p["3621"]), int(p["3622"]), p["3624"]
        bidirectional = p.get("3605#0", 0) == 1
        if bidirectional and self.written_for is not None:
            assert self.written_for == ("+" if reference_direction > 0 else "-"), (
                f"the listing is for a reference return in {self.written_for}")
        base = int(p["3626"]) if bidirectional and direction < 0 else n_neg
        approached_against_return = (direction > 0) != (reference_direction > 0)
        offset = int(p["3627"]) if bidirectional and approached_against_return else 0
        out = []
        for x in np.atleast_1d(np.asarray(pos_mm, dtype=float)):
            k = (x - ref_mm) / d
            assert abs(k - round(k)) < 1e-9, "evaluate at compensation points only"
            n = ref + int(round(k))
            assert n_neg - 1 <= n <= n_pos, "position outside the table"
            inc = [self.points[base + (m - n_neg)] for m in range(min(n, ref) + 1, max(n, ref) + 1)]
            out.append(offset + (sum(inc) if n >= ref else -sum(inc)))
        return np.array(out)

    def correction_um(self, pos_mm: np.ndarray, ref_mm: float, direction: int, unit_um: float,
                      reference_direction: int = 1) -> np.ndarray:
        return self.absolute_counts(pos_mm, ref_mm, direction, reference_direction) * unit_um * self.params["3623"]

    def point_positions_mm(self, ref_mm: float) -> np.ndarray:
        """Positions of points 3621 − 1 … 3622 (the first one is where the first increment starts)."""
        p = self.params
        n = np.arange(int(p["3621"]) - 1, int(p["3622"]) + 1)
        return ref_mm + (n - int(p["3620"])) * p["3624"]

    def correction_um_anywhere(self, pos_mm: np.ndarray, ref_mm: float, direction: int,
                               unit_um: float, reference_direction: int = 1) -> np.ndarray:
        """The correction at any position: point N's increment is output while the axis crosses
        from point N−1 to N, i.e. spread over the interval (linear between the points); outside
        the compensated stroke nothing more is output (the end values hold)."""
        at = self.point_positions_mm(ref_mm)
        return np.interp(np.asarray(pos_mm, dtype=float), at,
                         self.correction_um(at, ref_mm, direction, unit_um, reference_direction))


def read_fanuc(text: str) -> FanucPitch:
    params: dict[str, float] = {}
    points: dict[int, int] = {}
    written_for = None
    for ln in text.splitlines():
        ln = ln.strip()
        if not ln or (ln.startswith("(") and ln.endswith(")")):
            if m := re.search(r"REFERENCE RETURN IN ([+-]) DIRECTION", ln):
                written_for = m.group(1)
            continue
        if m := _PARAM.match(ln):
            params[m.group(1)] = float(m.group(2))
        elif m := _PITCH.match(ln):
            assert int(m.group(1)) not in points
            points[int(m.group(1))] = int(m.group(2))
        else:
            raise AssertionError(f"not a Fanuc listing line: {ln!r}")
    n_neg, n_pos = int(params["3621"]), int(params["3622"])
    assert n_neg <= int(params["3620"]) + 1 and int(params["3620"]) <= n_pos
    expected = set(range(n_neg, n_pos + 1))
    if params.get("3605#0", 0) == 1:
        start = int(params["3626"])
        expected |= set(range(start, start + n_pos - n_neg + 1))
    assert set(points) == expected, "one value per compensation point"
    return FanucPitch(params, points, written_for)
