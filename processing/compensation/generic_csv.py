"""Generic CSV compensation table: one header line, one row per table position.

Columns: ``position_<pu>``, ``error_up_<eu>``, ``error_down_<eu>`` (e = actual − commanded,
backlash folded in), ``correction_up_<eu>``, ``correction_down_<eu>`` (= −error: what a
controller must add to the command).  ``pu`` is the position unit (mm or deg), ``eu`` the
error unit (um or arcsec).
"""

from __future__ import annotations

from .numbers import fixed
from .tables import ErrorTable


def csv_text(table: ErrorTable, *, position_unit: str = "mm", error_unit: str = "um", decimals: int = 6) -> str:
    e_up, e_dn = table.directional()
    head = (f"position_{position_unit},error_up_{error_unit},error_down_{error_unit},"
            f"correction_up_{error_unit},correction_down_{error_unit}\n")
    rows = (",".join(fixed(v, decimals) for v in (p, a, b, -a, -b)) + "\n"
            for p, a, b in zip(table.position, e_up, e_dn, strict=True))
    return head + "".join(rows)
