"""``[compensation]`` of a positioning set-up (and ``acquire --compensation FILE``): the table the
controller applies while the run is measured (docs/compensation.md, "Applying a table").

NumPy-free: the command line builds its choices from this module.  The formats are those of
:mod:`processing.compensation.stage` (tests/acquisition/test_compensation_setup.py holds them equal).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from saved_runs.errors import SetupError
from saved_runs.toml_file import TomlTable

COMPENSATION_FORMATS = ("linuxcnc", "fanuc", "siemens")


@dataclass(frozen=True)
class CompensationSetup:
    """The compensation table active in the controller.

    ``file``: the table file (a path relative to the set-up file's directory is resolved there);
    ``fmt``: the controller format (None: from the file's content; a LinuxCNC file also needs
    ``comp_file_type``, the INI's ``COMP_FILE_TYPE``, since the file does not say);
    ``reference_position`` (Fanuc, mm or deg): where the reference position lies in the run's axis
    coordinates (None: the listing's comment); ``detection_unit_um`` (Fanuc; None: the listing's
    comment, else 1); ``reference_direction`` (Fanuc, Siemens): the reference-return direction, +1 or
    −1, the backlash state at power-on; ``backlash`` (µm or arcsec, lost motion): the backlash parameter
    entered with the table (Siemens MD32450; Fanuc 1851 in place of the listing's; not LinuxCNC)."""

    file: str
    fmt: str | None = None
    comp_file_type: int | None = None
    reference_position: float | None = None
    detection_unit_um: float | None = None
    reference_direction: int = 1
    backlash: float | None = None  # um (arcsec): backlash parameter entered with it (Siemens MD32450, Fanuc 1851)

    def __post_init__(self) -> None:
        if self.fmt is not None and self.fmt not in COMPENSATION_FORMATS:
            raise SetupError(f"[compensation] format must be one of {', '.join(COMPENSATION_FORMATS)}, "
                             f"got {self.fmt!r}")
        if self.comp_file_type not in (None, 0, 1):
            raise SetupError(f"[compensation] comp_file_type must be 0 or 1 (LinuxCNC COMP_FILE_TYPE), "
                             f"got {self.comp_file_type!r}")
        if self.reference_direction not in (1, -1):
            raise SetupError(f"[compensation] reference_direction must be 1 or -1, got {self.reference_direction!r}")
        if self.detection_unit_um is not None and not (math.isfinite(self.detection_unit_um)
                                                       and self.detection_unit_um > 0):
            raise SetupError(f"[compensation] detection_unit_um must be a positive number, got "
                             f"{self.detection_unit_um!r}")
        if self.backlash is not None and not (math.isfinite(self.backlash) and self.backlash >= 0):
            raise SetupError(f"[compensation] backlash must be a number >= 0 (the lost motion), got {self.backlash!r}")
        if self.reference_position is not None and not math.isfinite(self.reference_position):
            raise SetupError("[compensation] the reference position must be a finite number")


def compensation_setup(top: TomlTable, source: str, unit: str) -> CompensationSetup | None:
    """``[compensation]`` of a set-up (None when the table is absent); ``unit``: mm or deg (the
    backlash is in um or arcsec)."""
    present = "compensation" in top.data
    t = top.table("compensation")
    if not present:
        return None
    file = t.get("file", str, required=True)
    if not file:
        raise SetupError(f"{source}: [compensation] file is empty; give the table file or leave out [compensation]")
    if not Path(file).is_absolute() and Path(source).is_file():
        file = str((Path(source).parent / file).resolve())
    try:
        setup = CompensationSetup(
            file=file, fmt=t.get("format", str, None), comp_file_type=t.get("comp_file_type", int, None),
            reference_position=t.get(f"reference_position_{unit}", float, None),
            detection_unit_um=t.get("detection_unit_um", float, None),
            reference_direction=t.get("reference_direction", int, 1),
            backlash=t.get("backlash_arcsec" if unit == "deg" else "backlash_um", float, None))
    except SetupError as exc:
        raise SetupError(f"{source}: {exc}") from None
    t.check_unknown()
    return setup
