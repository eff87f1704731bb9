"""The set-up's validation limits applied to a saved run before it is evaluated.

A value outside them (a sensor reading of 1e9 mm, an axis reading 5 mm from its target) would
turn into a meaningless result (a straightness of 1e12 µm), so ``process``, ``report`` and
``export`` refuse the run with one line naming the point and the column, unless the user
accepts them (``--accept-out-of-range``); accepted values are listed in the results and marked
in the report.

Limits (docs/setup-*.toml, the same as the checks on every capture):

* straightness: ``[validation]`` sensor_range_mm (sensor_mm), max_straightness_um (|stry_um|,
  |strz_um|), max_angle_urad (|pitch|, |yaw|, |roll|), max_lin_um (|lin_um|);
* positioning: ``max_deviation_mm`` / ``max_deviation_deg`` (|reading − target|); on a linear
  axis whose readings are environment-compensated also the values the compensation uses, within
  the range of the air-index equations (:data:`saved_runs.evaluation.air.RANGES`, as ``guideway air-index``
  checks them): air temperature, pressure, humidity, and the material temperature when
  ``expansion_ppm_per_k`` is set (within the same temperature range).  A humidity of 1e9 %RH
  would otherwise move every deviation by metres.

The straightness limits are :class:`ValidationSetup` (a set-up's ``[validation]``, kept in run.json
``setup.validation``).  Run files without the keys take the set-up defaults.  NaN and inf are not
"outside" (the evaluators report a value that is not finite on their own, where the method needs it).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from processing.environment import EnvironmentSettings, angular_deviation_deg

from ..errors import RunFormatError, SetupError
from ..store.reader import LoadedRun
from .air import RANGES as AIR_INDEX_RANGES

if TYPE_CHECKING:  # the set-up loaders import this module: pandas only where points are checked
    import pandas as pd

ARROW = {1: "up (+)", -1: "down (-)"}
POSITIONING_DEFAULT_LIMIT = {"linear": 1.0, "rotary": 0.1}  # mm, deg (the positioning set-up's defaults)


@dataclass(frozen=True)
class ValidationSetup:
    """``[validation]`` of a straightness set-up (run.json ``setup.validation``): the checks on every
    capture (sensor stability, plausible ranges, jumps between neighbours), whose ranges are the
    limits a saved run is evaluated within."""

    max_sensor_std_um: float = 2.0
    sensor_range_mm: tuple[float, float] = (-50.0, 50.0)
    max_straightness_um: float = 1000.0
    max_angle_urad: float = 5000.0
    max_lin_um: float = 2000.0
    jump_ifm_um: float = 50.0
    jump_sensor_um: float = 50.0
    capture_attempts: int = 3

    def __post_init__(self) -> None:
        lo, hi = self.sensor_range_mm
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise SetupError(f"[validation] sensor_range_mm must be [low, high] with low < high, got {[lo, hi]}")
        if self.capture_attempts < 1:
            raise SetupError(f"[validation] capture_attempts must be >= 1, got {self.capture_attempts}")
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, float) and not (math.isfinite(v) and v > 0):
                raise SetupError(f"[validation] {f.name} must be a positive number, got {v}")


@dataclass(frozen=True)
class OutOfRange:
    """One value outside its limit: where (station / target, run, direction), which column, the
    value and the limit in words."""

    where: str
    column: str
    value: float
    limit: str
    of_setup: bool = True  # a limit of the set-up (else one of the equations, named in ``limit``)

    def text(self) -> str:
        return f"{self.where}: {self.column} = {self.value:.6g} outside {self.limit}"

    def to_dict(self) -> dict[str, Any]:
        d = {**asdict(self), "value": self.value if math.isfinite(self.value) else None}
        del d["of_setup"]
        return d


def straightness_bounds(v: ValidationSetup) -> dict[str, tuple[float, float, str]]:
    """Column → (low, high, unit) of a straightness run's points.csv."""
    lo, hi = v.sensor_range_mm
    out = {"sensor_mm": (lo, hi, "mm"), "lin_um": (-v.max_lin_um, v.max_lin_um, "um")}
    out |= dict.fromkeys(("stry_um", "strz_um"), (-v.max_straightness_um, v.max_straightness_um, "um"))
    out |= dict.fromkeys(("pitch_urad", "yaw_urad", "roll_urad"), (-v.max_angle_urad, v.max_angle_urad, "urad"))
    return out


def _validation(run: LoadedRun) -> ValidationSetup:
    val = dict((run.meta.get("setup") or {}).get("validation") or {})
    if "sensor_range_mm" in val:
        val["sensor_range_mm"] = tuple(val["sensor_range_mm"])
    try:
        return ValidationSetup(**val)
    except (TypeError, ValueError, SetupError) as exc:
        raise RunFormatError(f"{run.path}/run.json: setup.validation cannot be read ({exc})") from None


def _outside(values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return np.flatnonzero(np.isfinite(values) & ((values < lo) | (values > hi)))


def straightness_out_of_range(run: LoadedRun) -> list[OutOfRange]:
    pts = run.columns
    found = []
    for col, (lo, hi, unit) in straightness_bounds(_validation(run)).items():
        if col not in pts:
            continue
        values = np.asarray(pts[col], dtype=float)
        for i in _outside(values, lo, hi):
            where = f"station {int(pts['station'][i])}" + (" (return pass)" if "pass" in pts and int(pts["pass"][i])
                                                          else "")
            found.append(OutOfRange(where, col, float(values[i]), f"[{lo:g}, {hi:g}] {unit}"))
    return found


def environment_bounds(setup: dict[str, Any]) -> dict[str, tuple[float, float, str, str]]:
    """Column → (low, high, unit, whose range) of the environment values a linear positioning
    run's compensation uses (nothing when its readings are used as recorded)."""
    try:
        settings = EnvironmentSettings.from_dict(setup.get("environment"))
    except ValueError:
        return {}  # the evaluation refuses the set-up itself, with its own message
    if settings.readings_compensated:
        return {}
    ranges = {flag: (lo, hi) for flag, lo, hi in AIR_INDEX_RANGES}
    (t_lo, t_hi), (p_lo, p_hi), (rh_lo, rh_hi) = ranges["--t-c"], ranges["--p-pa"], ranges["--rh"]
    equations = "the range of the air-index equations"
    out = {"air_temp_c": (t_lo, t_hi, "C", equations), "air_pressure_hpa": (p_lo / 100, p_hi / 100, "hPa", equations),
           "humidity_pct": (rh_lo, rh_hi, "%RH", equations)}
    if settings.expansion_ppm_per_k is not None:
        out["material_temp_c"] = (t_lo, t_hi, "C", "the temperature range the tool evaluates")
    return out


def positioning_out_of_range(run: LoadedRun) -> list[OutOfRange]:
    axis_type = run.meta.get("axis_type", "linear")
    u = "deg" if axis_type == "rotary" else "mm"
    setup = run.meta.get("setup") or {}
    limit = setup.get(f"max_deviation_{u}", POSITIONING_DEFAULT_LIMIT.get(axis_type, 1.0))
    if not (isinstance(limit, int | float) and not isinstance(limit, bool) and limit > 0):
        raise RunFormatError(f"{run.path}/run.json: setup.max_deviation_{u} must be a positive number, got {limit!r}")
    pts: pd.DataFrame = run.points
    target = pts[f"target_{u}"].to_numpy(dtype=float)
    reading = pts[f"reading_{u}"].to_numpy(dtype=float)
    diff = angular_deviation_deg(reading, target) if u == "deg" else reading - target
    found = []
    for i in _outside(diff, -float(limit), float(limit)):
        row = pts.iloc[int(i)]
        where = (f"target {int(row['target_index'])} ({target[i]:g} {u}), run {int(row['run'])} "
                 f"{ARROW.get(int(row['direction']), '?')}")
        found.append(OutOfRange(where, f"reading_{u}", float(reading[i]),
                                f"+/-{float(limit):g} {u} of its target (max_deviation_{u})"))
    if axis_type != "rotary":
        for col, (lo, hi, unit, whose) in environment_bounds(setup).items():
            if col not in pts:
                continue
            values = pts[col].to_numpy(dtype=float)
            for i in _outside(values, lo, hi):
                row = pts.iloc[int(i)]
                where = (f"target {int(row['target_index'])} ({target[i]:g} {u}), run {int(row['run'])} "
                         f"{ARROW.get(int(row['direction']), '?')}")
                found.append(OutOfRange(where, col, float(values[i]),
                                        f"[{lo:g}, {hi:g}] {unit}, {whose}", of_setup=False))
    return found


def out_of_range(run: LoadedRun, *, accept: bool = False) -> tuple[OutOfRange, ...]:
    """The run's values outside the set-up's validation limits.  Refused (one-line
    :class:`RunFormatError`) unless ``accept``; accepted, they are returned for the results."""
    found = straightness_out_of_range(run) if run.kind == "straightness" else positioning_out_of_range(run)
    if found and not accept:
        more = f" ({len(found)} values out of range)" if len(found) > 1 else ""
        whose = ", the set-up's validation limit" if found[0].of_setup else ""
        raise RunFormatError(f"{run.path}/points.csv: {found[0].text()}{more}{whose}; "
                             "redo that point or fix the value, or pass --accept-out-of-range to evaluate as it is")
    return tuple(found)


def out_of_range_dict(found: tuple[OutOfRange, ...]) -> dict[str, Any]:
    """``{"out_of_range_accepted": [...]}`` for the results (nothing when there is none)."""
    return {"out_of_range_accepted": [f.to_dict() for f in found]} if found else {}


def print_out_of_range(found: tuple[OutOfRange, ...], stream: Any) -> None:
    if found:
        print(f"warning: {len(found)} value(s) outside the set-up's validation limits accepted "
              f"(--accept-out-of-range): {'; '.join(f.text() for f in found[:3])}"
              + (" ..." if len(found) > 3 else ""), file=stream)

