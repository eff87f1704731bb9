"""LinuxCNC joint compensation file (``[JOINT_n] COMP_FILE``, standards.md §4.1).

One line per entry, three whitespace-separated numbers in machine units (mm or deg):

* type 0: ``nominal  actual_forward  actual_reverse`` = P, P + e↑, P + e↓ (the loader stores
  nominal − actual = −e as the trim);
* type 1: ``nominal  trim_forward  trim_reverse`` = P, −e↑, −e↓ (trims added to the command).

The loader (``usrmotLoadComp``) stops silently at the first line that does not start with three
numbers, so the file has **no header and no comment lines**; nominals must be strictly
increasing (no sorting), at most 256 entries.  Outside the table the end trims are held.
"""

from __future__ import annotations

import numpy as np

from .numbers import fixed
from .tables import ErrorTable

MAX_ENTRIES = 256  # EMCMOT_COMP_SIZE
FILE_TYPES = (0, 1)


def linuxcnc_columns(table: ErrorTable, *, file_type: int = 1, unit_scale: float = 1e-3,
                     decimals: int = 6) -> list[tuple[str, str, str]]:
    """The three numbers of every line of the COMP_FILE, as written (see :func:`linuxcnc_comp_text`)."""
    if file_type not in FILE_TYPES:
        raise ValueError(f"LinuxCNC COMP_FILE_TYPE must be 0 or 1, not {file_type!r}")
    p = np.asarray(table.position, dtype=float)
    if len(p) > MAX_ENTRIES:
        raise ValueError(f"{len(p)} table entries; LinuxCNC accepts at most {MAX_ENTRIES} per joint "
                         "(use a larger grid step or the segments model)")
    rounded = np.round(p, decimals)
    if np.any(np.diff(rounded) <= 0):
        raise ValueError(f"table positions are not strictly increasing at {decimals} decimals")
    e_up, e_dn = table.directional()
    up = np.asarray(e_up, dtype=float) * unit_scale
    dn = np.asarray(e_dn, dtype=float) * unit_scale
    if file_type == 0:
        cols = (rounded, rounded + up, rounded + dn)
    else:
        cols = (rounded, -up, -dn)
    return [(fixed(a, decimals), fixed(b, decimals), fixed(c, decimals)) for a, b, c in zip(*cols, strict=True)]


def linuxcnc_comp_text(table: ErrorTable, *, file_type: int = 1, unit_scale: float = 1e-3, decimals: int = 6) -> str:
    """The COMP_FILE text for ``table``.

    ``unit_scale`` converts the table's error unit to machine units (um → mm: 1e-3;
    arcsec → deg: 1/3600).  The backlash of a ``backlash``-mode table is folded into the
    directional values, because LinuxCNC ignores BACKLASH when COMP_FILE is set.
    """
    rows = linuxcnc_columns(table, file_type=file_type, unit_scale=unit_scale, decimals=decimals)
    return "".join(f"{a} {b} {c}\n" for a, b, c in rows)


def linuxcnc_applied(table: ErrorTable, *, file_type: int = 1, unit_scale: float = 1e-3,
                     decimals: int = 6) -> ErrorTable:
    """The error the controller removes with the file as written (its rounded numbers; the
    loader's trim is nominal − actual for type 0, the number itself for type 1; the trim is
    added to the command, so the error removed is −trim), per direction, in the error unit."""
    rows = linuxcnc_columns(table, file_type=file_type, unit_scale=unit_scale, decimals=decimals)
    # reshape: an empty table gives shape (0,) and must still unpack into three columns (numpy takes any
    # negative size as the unknown one, so the mutant -2 for -1 is equivalent; the line's others are killed)
    nominal, fwd, rev = np.array(rows, dtype=float).reshape(-1, 3).T  # pragma: no mutate (equivalent)
    if file_type == 0:
        fwd, rev = nominal - fwd, nominal - rev
    return ErrorTable(nominal, -fwd / unit_scale, -rev / unit_scale, "bidirectional", table.model)
