"""Error curves of a machine axis from the tool's own run directories (docs/volumetric.md, "Runs").

A run measures in its own frame (docs/conventions.md): X_r = direction of travel, Y_r = the
set-up's "up", Z_r = X_r × Y_r.  Its channels, relative to the datum, are

==============  =========================================  ===========================  ======
channel         what                                       from                         unit
==============  =========================================  ===========================  ======
linear          positioning deviation x̄_i (ISO 230-2,       positioning run              µm
                after environmental compensation)          (rotary: angle, arcsec)
straightness    guideway profile height (+Y_r)             straightness run             µm
stry, strz      displacement of P along Y_r, Z_r           either (mean per target /    µm
                                                           station)
roll, yaw,      rotation about X_r, Y_r, Z_r               either                       µrad
pitch
==============  =========================================  ===========================  ======

:func:`run_curve` returns a channel as (axis positions, values) in the run's own sign; the
machine-file reader maps it onto a machine-frame component with :func:`channel_vector`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from processing.decoupling import relative_to_first
from processing.passes import station_groups
from processing.reference_lines import endpoint_line, least_squares_line
from processing.volumetric.axis_tables import URAD_PER_ARCSEC

from ..errors import RunFormatError, SetupError
from ..evaluation.evaluate import evaluate_run
from ..store.reader import LoadedRun, load_run

CHANNELS = ("linear", "straightness", "stry", "strz", "roll", "yaw", "pitch")
# channel -> (rotation?, run axis 0 = X_r travel, 1 = Y_r up, 2 = Z_r)
CHANNEL_AXES = {"linear": (False, 0), "straightness": (False, 1), "stry": (False, 1), "strz": (False, 2),
                "roll": (True, 0), "yaw": (True, 1), "pitch": (True, 2)}
COLUMNS = {"stry": "stry_um", "strz": "strz_um", "roll": "roll_urad", "yaw": "yaw_urad", "pitch": "pitch_urad"}
LINES = ("least_squares", "endpoint", "none")
STRAIGHTNESS_CHANNELS = ("straightness", "stry", "strz")
DIRECTIONS = {"mean": None, "up": 1, "down": -1}


@dataclass(frozen=True)
class RunCurve:
    """A run channel along the axis: positions (axis coordinates, mm or deg, increasing) and values
    (µm or µrad, in the run's own sign); ``text`` says where it came from."""

    positions: np.ndarray
    values: np.ndarray
    text: str


def channel_vector(channel: str, travel: np.ndarray, up: np.ndarray) -> tuple[bool, np.ndarray]:
    """(rotation?, machine-frame unit vector) of a channel for a run frame given by its travel and up."""
    rotation, k = CHANNEL_AXES[channel]
    return rotation, (travel, up, np.cross(travel, up))[k]


class RunCache:
    """Loads and evaluates each run directory once per machine file."""

    def __init__(self) -> None:
        self._runs: dict[tuple[Path, str], tuple[LoadedRun, object]] = {}

    def evaluated(self, path: Path, method: str) -> tuple[LoadedRun, object]:
        key = (path.resolve(), method)
        if key not in self._runs:
            run = load_run(path)
            options = {"method": method, "mc_trials": 0} if run.kind == "straightness" else {}
            self._runs[key] = (run, evaluate_run(run, **options))
        return self._runs[key]


def run_curve(cache: RunCache, path: Path, channel: str, *, axis_kind: str, where: str, direction: str = "mean",
              line: str = "least_squares", method: str = "exact", start: float = 0.0,
              travel_sign: float = 1.0) -> RunCurve:
    """The ``channel`` of the run at ``path`` as a curve of the axis position.

    Positioning runs: the targets are axis positions already.  Straightness runs: the axis
    position of a station is ``start + travel_sign · x`` (x from the first station).  ``line``
    removes a reference line from the straightness channels (their slope is a squareness or
    parallelism term, given on its own).  ``where`` prefixes every error message.
    """
    if channel not in CHANNELS:
        raise SetupError(f"{where}: unknown channel {channel!r}; use one of {', '.join(CHANNELS)}")
    if line not in LINES:
        raise SetupError(f"{where}: line must be one of {', '.join(LINES)}, got {line!r}")
    run, evaluation = cache.evaluated(path, method)
    if run.kind == "positioning" and travel_sign < 0:
        raise SetupError(f"{where}: {path} is a positioning run: its deviations are along the axis's own direction "
                         "(the targets are axis positions); leave travel out")
    if run.kind == "positioning" and start != 0.0:
        raise SetupError(f"{where}: {path} is a positioning run: its targets are axis positions already; start is "
                         "for straightness runs")
    if run.kind == "positioning":
        x, v, what = _positioning(run, evaluation, channel, direction, axis_kind, where)
    else:
        if axis_kind == "rotary":
            raise SetupError(f"{where}: {path} is a straightness run; a rotary axis takes a rotary positioning run")
        x, v, what = _straightness(run, evaluation, channel, where)
        x = start + travel_sign * x
    if len(x) < 2:
        raise SetupError(f"{where}: {path} gives {len(x)} point(s) of {channel}; an error curve needs at least 2")
    order = np.argsort(x, kind="stable")
    x, v = x[order], v[order]
    if np.any(np.diff(x) <= 0):
        raise SetupError(f"{where}: {path} has two points at the same axis position; cannot make a curve")
    if channel in STRAIGHTNESS_CHANNELS and line != "none":
        v = (least_squares_line if line == "least_squares" else endpoint_line)(x, v).deviations_um
        what += f", {line.replace('_', ' ')} line removed"
    return RunCurve(x, v, f"run {path} {channel} ({what})")


def _positioning(run: LoadedRun, evaluation: object, channel: str, direction: str, axis_kind: str, where: str
                 ) -> tuple[np.ndarray, np.ndarray, str]:
    if direction not in DIRECTIONS:
        raise SetupError(f"{where}: direction must be one of {', '.join(DIRECTIONS)}, got {direction!r}")
    axis_type = run.meta.get("axis_type", "linear")
    if (axis_type == "rotary") != (axis_kind == "rotary"):
        raise SetupError(f"{where}: {run.path} is a {axis_type} positioning run but the axis is {axis_kind}")
    if channel == "straightness":
        raise SetupError(f"{where}: {run.path} is a positioning run; the straightness channel comes from a "
                         "straightness run (use stry or strz for the interferometer's straightness channels)")
    per_target = evaluation.result.per_target  # type: ignore[attr-defined]
    if channel == "linear":
        col = {"mean": "mean_bi", "up": "mean_up", "down": "mean_down"}[direction]
        x, v = per_target["target"].to_numpy(float), per_target[col].to_numpy(float)
        if axis_kind == "rotary":
            v = v * URAD_PER_ARCSEC
        what = f"ISO 230-2 {direction} deviation per target"
    else:
        if axis_kind == "rotary":
            raise SetupError(f"{where}: a rotary positioning run gives only the linear (angular positioning) channel")
        pts = run.points
        d = DIRECTIONS[direction]
        if d is not None:
            pts = pts[pts["direction"] == d]
        means = pts.groupby("target_index")[COLUMNS[channel]].mean()
        targets = pts.groupby("target_index")["target_mm"].first()
        x, v = targets.to_numpy(float), means.reindex(targets.index).to_numpy(float)
        what = f"{direction} of every approach per target"
    keep = np.isfinite(v)
    if not keep.any():
        raise SetupError(f"{where}: {run.path} recorded no {channel} values; choose another source")
    return x[keep], v[keep], what


def _straightness(run: LoadedRun, evaluation: object, channel: str, where: str
                  ) -> tuple[np.ndarray, np.ndarray, str]:
    if channel == "linear":
        raise SetupError(f"{where}: {run.path} is a straightness run; the linear (positioning) error comes from "
                         "a positioning run")
    if channel == "straightness":
        result = evaluation.result  # type: ignore[attr-defined]
        profile: pd.DataFrame = result.profile
        return (profile["x_mm"].to_numpy(float), profile["height_um"].to_numpy(float),
                f"{result.method} decoupling, profile per station")
    pts = run.points
    try:
        groups = station_groups(pts)
    except ValueError as exc:
        raise RunFormatError(f"{run.path}: {exc}") from None
    x = groups.average(pts["x_mm"].to_numpy(float))
    v = groups.average(relative_to_first(pts[COLUMNS[channel]].to_numpy(float)))
    keep = np.isfinite(v)
    if not keep.any():
        raise SetupError(f"{where}: {run.path} recorded no {channel} values; choose another source")
    return x[keep], v[keep], "mean per station, relative to the datum"
