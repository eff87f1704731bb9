"""The compensation table active in the controller during a positioning run: read the file, check it
fits the run's axis, and record it in run.json ``compensation`` (docs/compensation.md, "Applying a
table"; docs/run-format.md).  With ``--simulate`` the simulated controller applies it the way that
controller does (processing/compensation/stage.py); with real devices the tool only records what
the technician says is loaded (it never writes into a controller).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from processing.compensation.stage import ControllerTable, detect_format, load_controller_table
from processing.compensation.stage_fanuc import FanucComp
from processing.compensation.stage_linuxcnc import LinuxCncComp
from saved_runs.errors import SetupError

from .setup.compensation import CompensationSetup
from .setup.positioning import PositioningSetup

_AXIS_LIKE = re.compile(r"[XYZABCUVW]\d*")


@dataclass(frozen=True)
class ActiveCompensation:
    """A compensation file as its controller reads it, and the record run.json keeps of it."""

    setup: CompensationSetup
    fmt: str
    table: ControllerTable
    sha256: str
    size_bytes: int
    notes: tuple[str, ...] = ()

    def record(self, unit: str, applied_by: str) -> dict[str, Any]:
        """run.json ``compensation`` (docs/run-format.md)."""
        t = self.table
        out: dict[str, Any] = {
            "active": True, "file": Path(self.setup.file).name, "path": self.setup.file, "format": self.fmt,
            "sha256": self.sha256, "bytes": self.size_bytes, "entries": t.entries, "table": t.description(),
            "applied_by": applied_by,
        }
        if self.fmt == "linuxcnc":
            out["comp_file_type"] = self.setup.comp_file_type
        if self.setup.backlash is not None:
            out["backlash_" + ("arcsec" if unit == "deg" else "um")] = self.setup.backlash
        if self.fmt == "fanuc":
            out[f"reference_position_{unit}"] = t.reference_position
            out["detection_unit_um"] = t.detection_unit_um
            out["reference_direction"] = t.reference_direction
        if self.notes:
            out["notes"] = list(self.notes)
        return out


NO_COMPENSATION: dict[str, Any] = {"active": False}


def load_compensation(c: CompensationSetup, setup: PositioningSetup) -> ActiveCompensation:
    """Read ``c.file`` as its controller reads it and check that it can belong to the run's axis:
    the axis the file names, modulo tables only on rotary axes, Fanuc listings only on linear axes
    unless they give 3625, and a table that reaches the targets.  One-line :class:`SetupError`s."""
    path = Path(c.file)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SetupError(f"[compensation] file {c.file}: cannot read it ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise SetupError(f"[compensation] file {c.file} is not a text file (UTF-8)") from None
    found = detect_format(text)
    fmt = c.fmt or ("linuxcnc" if c.comp_file_type is not None else found)  # a COMP_FILE_TYPE names LinuxCNC
    if fmt is None:
        raise SetupError(f"[compensation] file {c.file}: cannot tell its controller format; give format = "
                         "\"linuxcnc\", \"fanuc\" or \"siemens\" (--compensation-format)")
    if found is not None and found != fmt:
        raise SetupError(f"[compensation] file {c.file} reads as a {found} table, not {fmt}: a controller of one "
                         "kind cannot apply another's table; give the right format or file")
    try:
        table = load_controller_table(text, fmt, comp_file_type=c.comp_file_type,
                                      reference_position=c.reference_position,
                                      detection_unit_um=c.detection_unit_um,
                                      reference_direction=c.reference_direction,
                                      backlash=None if c.backlash is None else c.backlash * setup_scale(setup))
    except ValueError as exc:
        hint = " (comp_file_type, or --comp-file-type)" if "COMP_FILE_TYPE" in str(exc) else ""
        raise SetupError(f"[compensation] file {c.file} ({fmt}): {exc}{hint}") from None
    _check_fits(table, setup, c.file)
    notes: tuple[str, ...] = ()
    if isinstance(table.table, LinuxCncComp):  # what LinuxCNC would print (or silently skip) loading it
        t = table.table
        notes = tuple(f"LinuxCNC refuses {m}" for m in t.refused)
        unread = len(text.splitlines()) - t.lines_read
        if unread > 0:
            notes += (f"LinuxCNC stops reading at line {t.lines_read + 1} (not three numbers): the "
                      f"{unread} line(s) from there on are ignored",)
    return ActiveCompensation(c, fmt, table, hashlib.sha256(data).hexdigest(), len(data), notes)


def setup_scale(setup: PositioningSetup) -> float:
    """um -> mm, or arcsec -> deg."""
    return 1.0 / 3600.0 if setup.axis_type == "rotary" else 1e-3


def _check_fits(table: ControllerTable, setup: PositioningSetup, file: str) -> None:
    axis, u = setup.axis_name, setup.unit
    named = table.axis
    if named and _AXIS_LIKE.fullmatch(named) and named[0] != axis.upper()[:1]:
        raise SetupError(f"[compensation] file {file} is a table of axis {named}; this run measures axis {axis}: "
                         "tables of different axes are not combined")
    if table.modulo and setup.axis_type != "rotary":
        raise SetupError(f"[compensation] file {file} is a modulo (rotary) table; this run's axis {axis} is linear")
    lo, hi = _table_range(table)
    t_lo, t_hi = min(setup.targets), max(setup.targets)
    if lo is not None and hi is not None and not table.modulo and (hi < t_lo or lo > t_hi):
        raise SetupError(f"[compensation] file {file} covers {lo:g} … {hi:g} {u}, the targets {t_lo:g} … {t_hi:g} "
                         f"{u}: not a table of this axis (or in other units)")


def _table_range(table: ControllerTable) -> tuple[float | None, float | None]:
    t = table.table
    if isinstance(t, LinuxCncComp):
        return float(t.nominal[0]), float(t.nominal[-1])
    if isinstance(t, FanucComp):
        at = t.point_positions(table.reference_position)
        return float(at[0]), float(at[-1])
    tables = ((t.lec,) if t.lec is not None else ()) + t.cec
    return min(x.minimum for x in tables), max(x.maximum for x in tables)
