"""What ``guideway export`` writes: the controller formats, the models and modes they offer, and
:class:`ExportOptions` (the command's options, checked where they are given).

NumPy-free on purpose: the command line builds its choices from this module, so ``guideway --help``
loads no numerical library.  The model names, modes and the default polynomial degree are those of
:mod:`processing.compensation` (tests/saved_runs/test_front_end_choices.py holds them equal).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import UserError

FORMATS = ("linuxcnc", "fanuc", "siemens", "csv")
MODEL_NAMES = ("linear", "spline", "segments", "polynomial")  # processing.compensation.models
MODES = ("bidirectional", "backlash")  # processing.compensation.tables
DEFAULT_POLYNOMIAL_DEGREE = 6  # processing.compensation.models
SUFFIX = {"linuxcnc": ".comp", "fanuc": ".txt", "siemens": ".ini", "csv": ".csv"}
UNITS = {"linear": ("mm", "um", 1e-3), "rotary": ("deg", "arcsec", 1.0 / 3600.0)}


@dataclass(frozen=True)
class ExportOptions:
    """What to export.  Lengths in the axis unit (mm or deg) unless the name says otherwise."""

    fmt: str
    model: str = "linear"
    mode: str | None = None  # None: "backlash" for siemens (LEC is not directional), else "bidirectional"
    step: float | None = None  # grid step; None: model nodes (linuxcnc, csv) or mean target spacing
    tolerance: float | None = None  # spline tolerance / segment threshold (um or arcsec); None: max|e|/20
    initial_maxima: int | None = None  # spline: curvature maxima used as initial knots (None: all)
    degree: int = DEFAULT_POLYNOMIAL_DEGREE
    axis: str | None = None  # axis name; None: run.json setup.axis_name
    reference_position: float | None = None  # Fanuc reference position / Siemens zero point
    linuxcnc_type: int = 1
    fanuc_magnification: int = 1
    fanuc_detection_unit_um: float = 1.0
    fanuc_first_point: int = 0
    fanuc_reference_point: int | None = None
    fanuc_negative_table: int | None = None
    fanuc_reference_direction: int = 1
    siemens_axis: str | None = None  # machine axis identifier; None: axis + "1" (e.g. X1)
    siemens_encoder: int = 0
    siemens_modulo: bool = False
    siemens_max_points: int | None = None

    def __post_init__(self) -> None:
        # checked here, not where a model is fitted: there a bad value only drops that model from
        # the comparison ("not fitted"), and the command went on with exit 0
        if self.tolerance is not None and not (math.isfinite(self.tolerance) and self.tolerance >= 0):
            raise UserError(f"--tolerance must be a number >= 0 (um or arcsec), got {self.tolerance:g}")
        if self.initial_maxima is not None and self.initial_maxima < 0:
            raise UserError(f"--initial-knots must be >= 0, got {self.initial_maxima}")
        if self.degree < 0:
            raise UserError(f"--degree must be >= 0, got {self.degree}")
