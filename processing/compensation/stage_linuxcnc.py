"""LinuxCNC's screw compensation as its motion controller applies a ``COMP_FILE`` (standards.md §4.1,
shared/reference/linuxcnc.md "How the comp file is applied", read from LinuxCNC 2.9's source).

* Loader (``usrmotLoadComp``, usrmotintf.cc): ``fgets`` lines of at most 254 characters, each read
  with ``sscanf("%lf %lf %lf")``; **the first line that is not three numbers ends the file
  silently** (a header, a comment, a blank line); extra text after the third number is ignored.
  Type 0: the columns are the actual positions reached moving + and −, the trim is
  ``nominal − column``; type 1: the columns are the trims themselves.
* ``EMCMOT_SET_JOINT_COMP`` (command.c): at most 256 entries (``EMCMOT_COMP_SIZE``; more are
  refused with "too many compensation entries"); an entry whose nominal is not strictly greater
  than the previous one is refused ("compensation values must increase") and reading goes on;
  trims and slopes are C ``float`` (32 bit), nominals ``double``.
* ``compute_screw_comp`` (control.c, every servo cycle): the segment ``nominal[k] <= pos_cmd <
  nominal[k+1]``; ``trim[k] + slope[k]·(pos_cmd − nominal[k])`` of the forward column when the
  commanded velocity is > 0, the reverse column when < 0; at velocity 0 nothing changes, so at
  rest the value of the last motion direction is held (before any motion it is 0).  Below the first
  and above the last entry that entry's trim is held (sentinels at ±DBL_MAX with slope 0).
* ``motor_pos_cmd = pos_cmd + backlash_filt``: the trim is added to the command, so the axis moves
  by +trim (the filter only ramps to it; at rest it has arrived, except for a step from rest in
  (a·T²/2, a·T²], a = MAX_ACCELERATION/2, T the servo period, which LinuxCNC's ramp never starts:
  not modelled here).

Checked against LinuxCNC 2.9 itself, headless: tests/test_linuxcnc_real.py (docs/compensation.md).

Positions and trims in machine units (mm or deg).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

LINELEN = 255  # fgets(buffer, LINELEN, fp): at most 254 characters per read
EMCMOT_COMP_SIZE = 256
FILE_TYPES = (0, 1)
_C_SPACE = " \t\n\v\f\r"
# what strtod() accepts for %lf (decimal, exponent, inf/nan; hexadecimal floats are not handled)
_STRTOD = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan)", re.IGNORECASE)


def _fgets(text: str) -> list[str]:
    """The successive buffers ``fgets(buffer, 255, fp)`` returns (a line longer than 254 characters
    comes back in pieces)."""
    out, i = [], 0
    while i < len(text):
        j = text.find("\n", i, i + LINELEN - 1)
        end = j + 1 if j >= 0 else min(len(text), i + LINELEN - 1)
        out.append(text[i:end])
        i = end
    return out


def _scan3(buffer: str) -> tuple[float, float, float] | None:
    """``sscanf(buffer, "%lf %lf %lf")`` == 3: the three numbers, or None."""
    values: list[float] = []
    i = 0
    for _ in range(3):
        while i < len(buffer) and buffer[i] in _C_SPACE:
            i += 1
        m = _STRTOD.match(buffer, i)
        if m is None:
            return None
        values.append(float(m.group()))
        i = m.end()
    return values[0], values[1], values[2]


@dataclass(frozen=True)
class LinuxCncComp:
    """A joint's compensation table as the motion controller holds it (machine units)."""

    file_type: int
    nominal: np.ndarray  # float64
    forward: np.ndarray  # float32 trims, + travel
    reverse: np.ndarray  # float32 trims, − travel
    lines_read: int  # lines the loader accepted as three numbers (before the first that is not)
    refused: tuple[str, ...] = ()  # the motion controller's messages for refused entries

    def __len__(self) -> int:
        return len(self.nominal)

    def correction(self, commanded: float, direction: int) -> float:
        """The trim added to the command at ``commanded`` for the last motion direction
        ``direction`` (+1, −1; 0 = no motion yet: 0).  Machine units."""
        if direction == 0 or len(self.nominal) == 0:
            return 0.0
        trims = self.forward if direction > 0 else self.reverse
        nom = self.nominal
        if commanded < nom[0]:
            return float(trims[0])
        k = int(np.searchsorted(nom, commanded, side="right")) - 1  # nominal[k] <= pos < nominal[k+1]
        if k >= len(nom) - 1:
            return float(trims[-1])
        slope = np.float32((float(trims[k + 1]) - float(trims[k])) / (nom[k + 1] - nom[k]))
        return float(trims[k]) + float(slope) * (commanded - float(nom[k]))


def read_linuxcnc_comp(text: str, file_type: int) -> LinuxCncComp:
    """Load ``text`` as ``usrmotLoadComp`` + ``EMCMOT_SET_JOINT_COMP`` do for ``COMP_FILE_TYPE``
    ``file_type``.  Raises ValueError for a file type other than 0 or 1 (the INI reader's range)."""
    if file_type not in FILE_TYPES:
        raise ValueError(f"COMP_FILE_TYPE must be 0 or 1, not {file_type!r}")
    nominal: list[float] = []
    forward: list[float] = []
    reverse: list[float] = []
    refused: list[str] = []
    lines = 0
    for buffer in _fgets(text):
        v = _scan3(buffer)
        if v is None:
            break  # the loader's `break`: everything after this line is ignored, silently
        lines += 1
        nom, fwd, rev = v
        if file_type == 0:
            fwd, rev = nom - fwd, nom - rev  # "convert to diffs"
        if len(nominal) >= EMCMOT_COMP_SIZE:
            refused.append(f"line {lines}: too many compensation entries")
            continue
        if nominal and nom <= nominal[-1]:  # as command.c compares (a NaN passes, as there)
            refused.append(f"line {lines}: compensation values must increase")
            continue
        nominal.append(nom)
        forward.append(fwd)
        reverse.append(rev)
    return LinuxCncComp(file_type, np.array(nominal, dtype=float), np.array(forward, dtype=np.float32),
                        np.array(reverse, dtype=np.float32), lines, tuple(refused))
