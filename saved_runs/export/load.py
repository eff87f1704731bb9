"""What to do with a written table on the controller (``guideway export`` prints it; docs/compensation.md,
"Loading a table").  The tool never writes into a controller: these are the steps for the person at the
machine, with the numbers of the file just written.  Sources: ../shared/reference/standards.md §4.1
(LinuxCNC INI keys, BACKLASH ignored with a comp file), §4.2 (Siemens MD38000 / MD32700, active after
referencing), §4.4 (Fanuc 3605 … 3627, power off after changing 3620–3627, reference return); the Fanuc
1851 and Siemens MD32450 backlash parameters are [KNOW] (check their convention on the series).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

FANUC_PARAM = re.compile(r"^PARAM (\S+)=(\S+)$")
FANUC_1851 = re.compile(r"1851 = (-?\d+)", re.IGNORECASE)
FANUC_RETURN = re.compile(r"REFERENCE RETURN IN ([+-]) DIRECTION")
SIEMENS_ENTRY = re.compile(r"^\$AA_ENC_COMP\[(\d+),(\d+),(\w+)\]")


def load_instructions(fmt: str, text: str, path: Path | None, *, axis: str, error_unit: str,
                      lost_motion: float | None = None, comp_file_type: int = 1) -> list[str]:
    """The steps that load the table ``text`` (written to ``path``; None: stdout) into a ``fmt`` controller,
    one line each; ``lost_motion`` (um or arcsec): the reversal a one-table export leaves to the backlash
    parameter (−B̄), None when the table holds it."""
    name = path.name if path is not None else "the table"
    measure = (f"measure again with the table active (guideway acquire positioning ... --compensation {name}"
               + (f" --comp-file-type {comp_file_type}" if fmt == "linuxcnc" else "")
               + "), then guideway verify AS_FOUND AS_LEFT")
    if fmt == "linuxcnc":
        return [
            f"copy {name} into the directory of the machine's INI file",
            f"in the INI, in the [JOINT_n] section of the joint that drives axis {axis} (n = its joint number), set",
            f"    COMP_FILE = {name}",
            f"    COMP_FILE_TYPE = {comp_file_type}",
            "BACKLASH of that joint is ignored while COMP_FILE is set: the reversal is in the table's two columns",
            "restart LinuxCNC (the file is read at start-up), then home the joint",
            measure,
        ]
    if fmt == "fanuc":
        return _fanuc(text, name, measure)
    if fmt == "siemens":
        return _siemens(text, name, measure, error_unit, lost_motion)
    return [f"{name} is a plain table (positions, errors and corrections) for other software: enter its "
            "correction columns as that controller's documentation says (the tool knows no controller's rules for it)",
            measure]


def _fanuc(text: str, name: str, measure: str) -> list[str]:
    params = [m.groups() for m in map(FANUC_PARAM.match, text.splitlines()) if m]
    pitch = [ln.split()[1] for ln in text.splitlines() if ln.startswith("PITCH ")]
    first = pitch[0].split("=")[0] if pitch else "?"
    last = pitch[-1].split("=")[0] if pitch else "?"
    lines = ["MDI mode, emergency stop pressed; enable parameter writing (PWE = 1 on the setting screen)"]
    written = FANUC_RETURN.search(text)
    if written:  # bidirectional: 3627 is for that reference return, the machine's own 1006#5 (not in the listing)
        sign = written.group(1)
        zmi = 1 if sign == "-" else 0
        lines.append(f"check parameter 1006#5 ZMI = {zmi} (reference return in {'−' if zmi else '+'}): 3627 is written "
                     "for that direction; do not change it (it sets how the axis homes): if it differs, export "
                     f"again with --fanuc-reference-direction {-1 if zmi == 0 else 1}")
        if zmi:  # the simulated or recorded controller takes the direction from the set-up (default +)
            measure = (f"measure again with the table active: the set-up's [compensation] with file = \"{name}\" and "
                       "reference_direction = -1 (--compensation alone means a return in +), guideway acquire "
                       "positioning ..., then guideway verify AS_FOUND AS_LEFT")
    lines.append("enter the parameters in this order: " + ", ".join(f"{n} = {v}" for n, v in params))
    backlash = FANUC_1851.search(text)
    if backlash:
        lines.append(f"and the backlash parameter 1851 = {backlash.group(1)} (detection units; 1852 for rapid "
                     "traverse with 1800#4 = 1)")
    lines += [f"enter the {len(pitch)} point values of {name} (PITCH lines, points {first} … {last}) on the pitch "
              "error compensation screen",
              "parameter writing off (PWE = 0); switch the control off and on again (3620–3627 take effect only "
              "after power off)",
              "return the axis to the reference position: pitch error compensation acts only after the reference "
              "return",
              measure]
    return lines


def _siemens(text: str, name: str, measure: str, error_unit: str, lost_motion: float | None) -> list[str]:
    entries = [m.groups() for m in map(SIEMENS_ENTRY.match, text.splitlines()) if m]
    encoder = entries[0][0] if entries else "0"
    axis = entries[0][2] if entries else "AX"
    lines = [f"MD38000 MM_ENC_COMP_MAX_POINTS[{encoder}] of axis {axis} >= {len(entries)} (a memory reconfiguration: "
             "power on after changing it)",
             f"MD32700 ENC_COMP_ENABLE[{encoder}] = 0 (the table can only be loaded with the compensation off)",
             f"load {name} into the control (as an INI archive, or run it as a part program: it ends in M17)",
             f"MD32700 ENC_COMP_ENABLE[{encoder}] = 1, then NewConfig or reset",
             "reference the axis: LEC is active only after referencing"]
    if lost_motion is not None:
        unit, scale = ("deg", 1.0 / 3600.0) if error_unit == "arcsec" else ("mm", 1e-3)
        lines.insert(4, f"MD32450 BACKLASH = {lost_motion * scale:.6f} {unit} ({lost_motion:.3f} {error_unit}: "
                        "the lost motion the export reports, as LEC is not direction dependent; check the "
                        "parameter's sign convention on the machine)")
    lines.append(measure)
    return lines


def export_load_instructions(export: Any, path: Path | None, options: Any, axis: str) -> list[str]:
    """:func:`load_instructions` for an :class:`~saved_runs.export.build.Export`."""
    lost = -float(export.table.backlash) if export.table.mode == "backlash" else None
    return load_instructions(options.fmt, export.text, path, axis=axis, error_unit=export.error_unit,
                             lost_motion=lost, comp_file_type=options.linuxcnc_type)


def numbered(steps: list[str]) -> list[str]:
    """The steps numbered 1, 2, …; a line indented by four spaces (an INI line) belongs to the step before."""
    out, n = [], 0
    for step in steps:
        if step.startswith("    "):
            out.append(f"   {step}")
        else:
            n += 1
            out.append(f"{n}. {step}")
    return out
