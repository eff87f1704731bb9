"""Forward and return passes of a straightness run (run format v2 ``pass`` column).

Every point is decoupled against the one datum (the first forward point); the
reported profile is, per station, the mean of the points of that station
(forward and, when present, return), in the order of the forward pass.
Averaging a forward and a return pass cancels a drift that is linear in time
up to a constant (the two visits of station k straddle the run's middle
instant), and a constant is removed by every reference line.

Closure error: return-pass height minus forward-pass height at the first
station (the datum), i.e. how far the round trip fails to come back (um).
Drift estimate: the forward-return differences d_k = h_ret(k) - h_fwd(k) over
the time between the two visits dt_k, fitted by d = r dt (least squares
through the origin: no time elapsed, no drift); reported as r in um/h.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from scipy import sparse


@dataclass(frozen=True)
class StationGroups:
    """Which points make up each output station.

    ``stations``: output station numbers (forward order); ``group``: for each
    point, the index of its output station; ``matrix``: the (n_out x n_points)
    averaging matrix (each row averages its station's points).
    """

    stations: np.ndarray
    group: np.ndarray
    counts: np.ndarray  # points per output station
    matrix: sparse.csr_matrix | None  # None: one point per station, in order (identity)

    def average(self, values: np.ndarray) -> np.ndarray:
        """Per-station means of per-point ``values`` (last axis = points)."""
        if self.matrix is None:
            return values
        return np.asarray((self.matrix @ np.asarray(values).T).T)


def pass_of(points: pd.DataFrame) -> np.ndarray:
    """The ``pass`` column (0 forward, 1 return); all 0 when absent."""
    if "pass" not in points:
        return np.zeros(len(points), dtype=int)
    p = points["pass"].to_numpy(dtype=int)
    if not np.all((p == 0) | (p == 1)):
        raise ValueError("column pass must be 0 (forward) or 1 (return)")
    return p


def check_order(points: pd.DataFrame) -> None:
    """The first point must be the forward-pass datum; forward stations must be distinct."""
    p = pass_of(points)
    if len(p) and p[0] != 0:
        raise ValueError("the first point must belong to the forward pass (pass 0): it is the datum")
    fwd = points["station"].to_numpy(dtype=int)[p == 0]
    if np.all(np.diff(fwd) > 0):
        return
    fwd = np.sort(fwd)
    if np.any(fwd[1:] == fwd[:-1]):
        raise ValueError("a station appears twice in the forward pass")


def station_groups(points: pd.DataFrame) -> StationGroups:
    """Group the points by station, stations in forward-pass order (return-only ones at the end)."""
    st = points["station"].to_numpy(dtype=int)
    p = pass_of(points)
    if not np.any(p) and np.all(np.diff(st) > 0):  # forward pass only, in order: identity
        return StationGroups(st, np.arange(len(st)), np.ones(len(st), dtype=np.intp), None)
    order = pd.unique(np.concatenate([st[p == 0], st[p == 1]]))
    group = pd.Index(order).get_indexer(st).astype(np.intp)
    counts = np.bincount(group, minlength=len(order))
    m = sparse.csr_matrix((1.0 / counts[group], (group, np.arange(len(st)))), shape=(len(order), len(st)))
    return StationGroups(np.asarray(order, dtype=int), group, counts, m)


@dataclass(frozen=True)
class ReturnPassSummary:
    """Forward and return profiles and what their difference says (um, h)."""

    forward: pd.DataFrame
    backward: pd.DataFrame
    closure_um: float | None
    drift_um_per_h: float | None

    def to_dict(self) -> dict[str, Any]:
        def rows(df: pd.DataFrame) -> list[dict[str, Any]]:
            return [{"station": int(r.station), "x_mm": float(r.x_mm), "height_um": float(r.height_um)}
                    for r in df.itertuples(index=False)]

        return {"forward": rows(self.forward), "return": rows(self.backward),
                "closure_um": self.closure_um, "drift_um_per_h": self.drift_um_per_h}


def return_pass_summary(points: pd.DataFrame, per_point: pd.DataFrame) -> ReturnPassSummary | None:
    """Compare the passes of a decoupled run; None without return-pass points.

    ``per_point``: the decoupled profile of every point (station, x_mm, height_um),
    row for row with ``points`` (which must carry ``time_s``).
    """
    p = pass_of(points)
    if not np.any(p == 1):
        return None
    prof = per_point.assign(time_s=points["time_s"].to_numpy(dtype=float))
    fwd = prof[p == 0].reset_index(drop=True)
    ret = prof[p == 1].groupby("station", sort=False).mean(numeric_only=True).reset_index()
    both = fwd.merge(ret, on="station", suffixes=("_f", "_r"))
    d = (both["height_um_r"] - both["height_um_f"]).to_numpy()
    dt_h = (both["time_s_r"] - both["time_s_f"]).to_numpy() / 3600.0
    datum = int(fwd["station"].iloc[0])
    at_datum = both["station"] == datum
    closure = float(d[at_datum.to_numpy()][0]) if at_datum.any() else None
    drift = float(np.sum(d * dt_h) / np.sum(dt_h**2)) if np.sum(dt_h**2) > 0 else None
    cols = ["station", "x_mm", "height_um"]
    return ReturnPassSummary(fwd[cols], ret[cols], closure, drift)
