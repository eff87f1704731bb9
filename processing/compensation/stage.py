"""The compensation stage of a controller: a written table file read as that controller reads it,
and the correction it adds between the commanded position and the axis (docs/compensation.md,
"Applying a table").

``ControllerTable.correction(commanded, direction)`` is the pure rule of each controller;
:class:`Compensator` is the little state a controller keeps while the axis moves: the direction
of the last motion (taken from the sign of the commanded motion and **held while the axis is at
rest**), whether the axis is referenced, and the Fanuc backlash state after power-on.

Positions and corrections in machine units (mm or deg).  A correction is what the controller adds
to the command: the axis goes to ``commanded + correction`` and meets its error there.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .stage_fanuc import FanucComp, read_fanuc_listing
from .stage_linuxcnc import LinuxCncComp, read_linuxcnc_comp
from .stage_siemens import SiemensComp, read_siemens_comp

FORMATS = ("linuxcnc", "fanuc", "siemens")
_SIGN = {1: "+", -1: "−"}


def detect_format(text: str) -> str | None:
    """The format a file's text is plainly in: ``siemens`` (``$AA_ENC_COMP`` / ``$AN_CEC``), ``fanuc``
    (``PARAM 36..`` lines), ``linuxcnc`` (the first line three numbers); None otherwise."""
    if "$AA_ENC_COMP" in text or "$AN_CEC" in text:
        return "siemens"
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    if any(ln.startswith("PARAM 362") for ln in lines):
        return "fanuc"
    first = text.splitlines()[0] if text else ""
    parts = first.split()
    if len(parts) >= 3:
        try:
            [float(p) for p in parts[:3]]
        except ValueError:
            return None
        return "linuxcnc"
    return None


@dataclass(frozen=True)
class ControllerTable:
    """A compensation file as one controller holds it.

    ``reference_position`` (Fanuc): the axis coordinate of the reference position the table is
    relative to; ``detection_unit_um`` (Fanuc): one detection unit (µm, or 0.001 deg on a rotary
    axis); ``reference_direction`` (Fanuc): the reference-return direction (the control's
    parameter 1006#5 ZMI: 0 = +1, 1 = −1), the backlash state at power-on and, bidirectional, the
    side 3627 is on (the table approached against it); ``backlash`` (Siemens MD32450 BACKLASH, mm or
    deg): the lost motion the control makes up on a reversal (a Fanuc 1851 is part of :class:`FanucComp`)."""

    fmt: str
    table: LinuxCncComp | FanucComp | SiemensComp
    reference_position: float = 0.0
    detection_unit_um: float = 1.0
    reference_direction: int = 1
    backlash: float = 0.0

    @property
    def axis(self) -> str | None:
        """The axis the file names (Fanuc listing, Siemens machine axis), or None (LinuxCNC)."""
        t = self.table
        return t.axis if isinstance(t, FanucComp | SiemensComp) else None

    @property
    def entries(self) -> int:
        t = self.table
        if isinstance(t, LinuxCncComp):
            return len(t)
        if isinstance(t, FanucComp):
            return len(t.values) + (0 if t.values_negative is None else len(t.values_negative))
        return (0 if t.lec is None else len(t.lec.values)) + sum(len(c.values) for c in t.cec)

    @property
    def modulo(self) -> bool:
        t = self.table
        if isinstance(t, SiemensComp):
            return any(x.modulo for x in ((t.lec,) if t.lec else ()) + t.cec)
        return isinstance(t, FanucComp) and t.rotary_travel > 0

    def description(self) -> str:
        """One line: what the controller holds."""
        t = self.table
        if isinstance(t, LinuxCncComp):
            return f"LinuxCNC COMP_FILE_TYPE {t.file_type}, {len(t)} entries"
        if isinstance(t, FanucComp):
            kind = "bidirectional" if t.bidirectional else "one table"
            return (f"Fanuc pitch error compensation ({kind}, points {t.negative_end}…{t.positive_end}, reference "
                    f"point {t.reference_number} at {self.reference_position:g}, interval {t.interval:g}, "
                    f"1851 = {t.backlash_cutting})")
        parts = []
        if t.lec is not None:
            parts.append(f"LEC {len(t.lec.values)} points" + (" modulo" if t.lec.modulo else ""))
        parts += [f"CEC {'both' if c.direction == 0 else '+' if c.direction > 0 else '-'}" for c in t.cec]
        if self.backlash:
            parts.append(f"MD32450 backlash {self.backlash:g}")
        return f"Siemens {t.axis}: " + ", ".join(parts)

    def correction(self, commanded: float, direction: int, *, referenced: bool = True, rapid: bool = False
                   ) -> float:
        """The correction (mm or deg) the controller adds at ``commanded`` with ``direction`` the
        direction of the last motion (+1, −1; 0: not moved since power-on).  ``referenced``: Fanuc pitch
        and Siemens LEC/CEC act only after referencing; LinuxCNC's comp acts once the joint moves."""
        t = self.table
        if isinstance(t, LinuxCncComp):
            return t.correction(commanded, direction)
        if isinstance(t, SiemensComp):
            if not referenced:
                return 0.0
            # MD32450: after a reversal away from the referencing direction the lost motion is made up
            # in the new direction (as Fanuc's 1851; the sign convention is to be checked on the machine)
            reversed_ = direction not in (0, self.reference_direction)
            return t.correction(commanded, direction) + (direction * self.backlash if reversed_ else 0.0)
        d = direction or self.reference_direction  # at power-on the control takes the reference direction
        counts = t.pitch_counts(commanded, d, self.reference_position, self.reference_direction) if referenced else 0.0
        pitch = counts * self.detection_unit_um * t.magnification
        backlash = t.backlash_counts(d, self.reference_direction, rapid) * self.detection_unit_um
        return (pitch + backlash) * 1e-3  # µm -> mm (0.001 deg -> deg)


def load_controller_table(text: str, fmt: str, *, comp_file_type: int | None = None,
                          reference_position: float | None = None, detection_unit_um: float | None = None,
                          reference_direction: int = 1, backlash: float | None = None) -> ControllerTable:
    """Read ``text`` as controller ``fmt`` reads it.  LinuxCNC needs ``comp_file_type`` (the INI's
    ``COMP_FILE_TYPE``: the file does not say); Fanuc takes the reference position and detection unit
    from the arguments or else from the listing's comment lines.  ``backlash`` (mm or deg, lost
    motion): the backlash parameter entered with the table (Siemens MD32450; Fanuc 1851, rounded to
    whole detection units, in place of the listing's; LinuxCNC has none with a comp file).
    ValueError for anything wrong."""
    if backlash is not None and not (backlash >= 0 and backlash < float("inf")):
        raise ValueError("the backlash (lost motion) must be a number >= 0")
    if fmt == "linuxcnc":
        if backlash:
            raise ValueError("LinuxCNC ignores BACKLASH when a COMP_FILE is set: put the reversal into the table")
        if comp_file_type is None:
            raise ValueError("a LinuxCNC comp file needs its COMP_FILE_TYPE (0 or 1): the file does not say")
        table = read_linuxcnc_comp(text, comp_file_type)
        if len(table) == 0:
            raise ValueError("LinuxCNC reads no entry from this file (its first line is not three numbers)")
        return ControllerTable(fmt, table)
    if fmt == "fanuc":
        f = read_fanuc_listing(text)
        ref = reference_position if reference_position is not None else f.reference_position
        if ref is None:
            raise ValueError("the Fanuc listing does not give the reference position's coordinate; "
                             "give it (reference_position)")
        unit = detection_unit_um if detection_unit_um is not None else (f.detection_unit or 1.0)
        if not unit > 0:
            raise ValueError("the detection unit must be positive")
        if reference_direction not in (1, -1):
            raise ValueError("the reference-return direction must be +1 or -1")
        written = f.written_reference_direction
        if f.bidirectional and written is not None and written != reference_direction:
            # 3627 belongs to the table approached against the reference return: read for the other
            # direction it would sit on the other table and shift both tables' corrections by it
            raise ValueError(f"the listing's 3627 is for a reference return in {_SIGN[written]} "
                             f"(1006#5 ZMI = {int(written < 0)}), the controller returns in "
                             f"{_SIGN[reference_direction]} (reference_direction = {reference_direction}): set "
                             f"reference_direction = {written} in [compensation] if the machine returns in "
                             f"{_SIGN[written]}, else export the table again with --fanuc-reference-direction "
                             f"{reference_direction}")
        if backlash is not None:
            f = replace(f, backlash_cutting=int(np.floor(backlash * 1000.0 / unit + 0.5)))
        return ControllerTable(fmt, f, float(ref), float(unit), reference_direction)
    if fmt == "siemens":
        return ControllerTable(fmt, read_siemens_comp(text), reference_direction=reference_direction,
                               backlash=backlash or 0.0)
    raise ValueError(f"unknown controller format {fmt!r}; choose one of {', '.join(FORMATS)}")


class Compensator:
    """A controller's compensation while the axis moves: ``move_to(commanded)`` returns the
    correction at the new commanded position, the direction taken from the sign of the commanded
    motion and held when the command does not change (the axis at rest)."""

    def __init__(self, table: ControllerTable, *, start: float, referenced: bool = True) -> None:
        self.table = table
        self.commanded = start
        self.direction = 0  # no motion since power-on
        self.referenced = referenced

    def move_to(self, commanded: float) -> float:
        """The axis is commanded to ``commanded``; the correction there (mm or deg)."""
        if commanded > self.commanded:
            self.direction = 1
        elif commanded < self.commanded:
            self.direction = -1
        self.commanded = commanded
        return self.table.correction(commanded, self.direction, referenced=self.referenced)
