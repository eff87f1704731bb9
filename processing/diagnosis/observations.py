"""What a run offers the diagnosis: one :class:`Observations` per observed channel.

Each holds the observed values ``y_um`` (µm), the per-point quantities the effects are
functions of (``values``), the nuisance columns that are always fitted (the interferometer
zero; for straightness the profile itself or the reference line), the replicate groups
whose scatter is the noise (repeat approaches, forward and return passes) and the
cross-validation folds (grouped by run and direction, or by pass and station block:
errors within one approach series are correlated, so they are held out together).

Channels:

* ``deviation`` (positioning): x = reading − target after environmental compensation.
* ``height`` (straightness): the decoupled surface height of every point.  With a reference
  profile in the model the nuisance is an offset and a slope (the laser's alignment is
  arbitrary); without one the profile is unknown and every station has its own free height,
  so only stations visited twice carry evidence (the forward-return redundancy).
* ``lin`` (straightness): the interferometer's X channel, P's displacement minus k·L; the
  nuisance is an offset and the pitch change (P sits above the block's pivot).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

MAX_FOLDS = 10
STATION_BLOCKS = 5


@dataclass(frozen=True)
class Observations:
    """One observed channel of a run (arrays of equal length n, units in the key names)."""

    kind: str
    channel: str
    y_um: np.ndarray
    values: dict[str, np.ndarray]
    nuisance: np.ndarray
    nuisance_names: tuple[str, ...]
    replicate: np.ndarray  # group id per point: the noise is the scatter within groups
    folds: np.ndarray  # cross-validation fold per point
    fold_basis: str
    replicate_basis: str
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def n(self) -> int:
        return len(self.y_um)

    def has(self, key: str) -> bool:
        """``values[key]`` is recorded for every point (finite)."""
        v = self.values.get(key)
        return v is not None and bool(np.all(np.isfinite(v)))


def group_ids(*keys: np.ndarray) -> np.ndarray:
    """Dense integer ids of the distinct tuples of ``keys`` (in order of first appearance)."""
    frame = pd.DataFrame({f"k{i}": np.asarray(k) for i, k in enumerate(keys)})
    return frame.groupby(list(frame.columns), sort=False).ngroup().to_numpy()


def fold_ids(groups: np.ndarray, max_folds: int = MAX_FOLDS) -> np.ndarray:
    """At most ``max_folds`` folds, each holding whole groups (group g goes to fold g mod K)."""
    g = np.asarray(groups)
    return g % max_folds if g.max(initial=0) + 1 > max_folds else g.copy()


def time_minutes(time_s: np.ndarray) -> np.ndarray:
    """Minutes since the first point in time (NaN everywhere when any time is missing)."""
    t = np.asarray(time_s, dtype=float)
    if t.size == 0 or not np.all(np.isfinite(t)):
        return np.full(t.shape, np.nan)
    return (t - t.min()) / 60.0


def positioning_observations(points: pd.DataFrame, deviation_um: np.ndarray,
                             index: np.ndarray | None) -> Observations:
    """The deviation channel of a linear positioning run.

    ``deviation_um``: x_ij per row of ``points`` (after environmental compensation);
    ``index``: the air index of every row (None or NaN where the air was not recorded).
    """
    n = len(points)
    direction = points["direction"].to_numpy(dtype=int)
    run = points["run"].to_numpy(dtype=int)
    time_s = points["time_s"].to_numpy(dtype=float) if "time_s" in points else np.full(n, np.nan)
    values = {
        "position_mm": points["target_mm"].to_numpy(dtype=float),
        "direction": direction.astype(float),
        "run": run.astype(float),
        "target_index": points["target_index"].to_numpy(dtype=float),
        "time_min": time_minutes(time_s),
        "pitch_urad": _column(points, "pitch_urad"),
        "yaw_urad": _column(points, "yaw_urad"),
        "index_change": _index_change(index, time_s, n),
    }
    series = group_ids(run, direction)
    return Observations(
        kind="positioning", channel="deviation", y_um=np.asarray(deviation_um, dtype=float), values=values,
        nuisance=np.ones((n, 1)), nuisance_names=("offset_um",),
        replicate=group_ids(values["target_index"], direction), folds=fold_ids(series),
        fold_basis="run and direction", replicate_basis="repeat approaches (same target and direction)")


def _column(points: pd.DataFrame, name: str) -> np.ndarray:
    return points[name].to_numpy(dtype=float) if name in points else np.full(len(points), np.nan)


def _index_change(index: np.ndarray | None, time_s: np.ndarray, n: int) -> np.ndarray:
    """n − n₀ with n₀ the index of the first point in time (row order without times)."""
    if index is None:
        return np.full(n, np.nan)
    idx = np.asarray(index, dtype=float)
    first = int(np.argmin(time_s)) if np.all(np.isfinite(time_s)) and n else 0
    return idx - idx[first]


def straightness_observations(points: pd.DataFrame, per_point: pd.DataFrame, sensor_um: np.ndarray,
                              *, reference: bool, lever_x_mm: float = 100.0) -> tuple[Observations, Observations]:
    """The height and lin channels of a straightness run.

    ``per_point``: the decoupled profile of every point (x_mm, height_um), row for row;
    ``sensor_um``: the sensor reading change since the first point, height sense (µm);
    ``reference``: the model holds a reference profile (profile_table); ``lever_x_mm``: xQ − xP, the recorded
    distance along X from the interferometer's point P to the sensor's point Q (+ ahead of P, − behind).
    """
    n = len(points)
    station = points["station"].to_numpy(dtype=int)
    pass_ = points["pass"].to_numpy(dtype=int) if "pass" in points else np.zeros(n, dtype=int)
    pitch = points["pitch_urad"].to_numpy(dtype=float)
    values = {
        "x_mm": per_point["x_mm"].to_numpy(dtype=float),
        "station": station.astype(float),
        "pass": pass_.astype(float),
        "time_min": time_minutes(_column(points, "time_s")),
        "sensor_um": np.asarray(sensor_um, dtype=float),
        "dpitch_urad": pitch - pitch[0],
        "q_side": np.full(n, 1.0 if lever_x_mm >= 0 else -1.0),
        "lever_x_mm": np.full(n, float(lever_x_mm)),
    }
    ranks = np.argsort(np.argsort(station, kind="stable"), kind="stable")
    block = (ranks * STATION_BLOCKS // max(n, 1)).astype(int)
    folds = group_ids(pass_, block)
    height = per_point["height_um"].to_numpy(dtype=float)
    notes: list[str] = []
    if reference:
        x = values["x_mm"]
        h_obs = Observations("straightness", "height", height, values, np.column_stack([np.ones(n), x / 1000.0]),
                             ("offset_um", "slope_um_per_m"), group_ids(station), folds,
                             "pass and station block", "forward and return pass of a station")
    else:
        counts = np.bincount(station - station.min())[station - station.min()]
        keep = counts >= 2
        if not keep.any():
            notes.append("no station was measured twice and the model gives no reference profile: the "
                         "height channel holds no redundancy to diagnose (add a return pass or a profile_table)")
        kept = {k: v[keep] for k, v in values.items()}
        ids = group_ids(station[keep])
        nuis = np.zeros((int(keep.sum()), int(ids.max(initial=-1)) + 1))
        nuis[np.arange(len(ids)), ids] = 1.0
        h_obs = Observations("straightness", "height", height[keep], kept, nuis,
                             tuple(f"height_station_{k}_um" for k in pd.unique(station[keep])), ids,
                             folds[keep], "pass and station block",
                             "forward and return pass of a station (the profile itself is unknown)", tuple(notes))
    lin = Observations("straightness", "lin", points["lin_um"].to_numpy(dtype=float), values,
                       np.column_stack([np.ones(n), values["dpitch_urad"] * 1e-3]),
                       ("offset_um", "pivot_lever_mm"), group_ids(station), folds,
                       "pass and station block", "forward and return pass of a station")
    return h_obs, lin
