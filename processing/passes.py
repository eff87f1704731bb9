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

from .point_columns import Points, as_columns, row_count


@dataclass(frozen=True)
class StationGroups:
    """Which points make up each output station.

    ``stations``: output station numbers (forward order); ``group``: for each
    point, the index of its output station; ``rank``: for each point, how many
    points of its station come before it (0 for the first); ``weight``: 1 / the
    point's station count.  ``identity``: one point per station, in order.
    """

    stations: np.ndarray
    group: np.ndarray
    counts: np.ndarray  # points per output station
    rank: np.ndarray
    identity: bool

    def average(self, values: np.ndarray) -> np.ndarray:
        """Per-station means of per-point ``values`` (last axis = points).

        Each mean is summed as sum_j (1 / n_k) v_j over the station's points in file order, starting from
        0.0 (the sum a sparse averaging matrix computes; the same bits)."""
        if self.identity:
            return values
        values = np.asarray(values, dtype=float)
        weighted = values * (1.0 / self.counts[self.group])
        out = np.zeros((*values.shape[:-1], len(self.stations)))
        for r in range(int(self.rank.max()) + 1 if len(self.rank) else 0):
            at = np.flatnonzero(self.rank == r)
            out[..., self.group[at]] += weighted[..., at]  # one point per station per rank: no repeated index
        return out


def pass_of(points: Points) -> np.ndarray:
    """The ``pass`` column (0 forward, 1 return); all 0 when absent."""
    cols = as_columns(points)
    if "pass" not in cols:
        return np.zeros(row_count(cols), dtype=int)
    p = np.asarray(cols["pass"], dtype=int)
    if not np.all((p == 0) | (p == 1)):
        raise ValueError("column pass must be 0 (forward) or 1 (return)")
    return p


def check_order(points: Points) -> None:
    """The first point must be the forward-pass datum; forward stations must be distinct."""
    p = pass_of(points)
    if len(p) and p[0] != 0:
        raise ValueError("the first point must belong to the forward pass (pass 0): it is the datum")
    fwd = np.asarray(as_columns(points)["station"], dtype=int)[p == 0]
    if np.all(np.diff(fwd) > 0):
        return
    fwd = np.sort(fwd)
    if np.any(fwd[1:] == fwd[:-1]):
        raise ValueError("a station appears twice in the forward pass")


def _first_seen(values: np.ndarray) -> np.ndarray:
    """The distinct values in order of first appearance."""
    _, first = np.unique(values, return_index=True)
    return values[np.sort(first)]


def _index_in(order: np.ndarray, values: np.ndarray) -> np.ndarray:
    """For each of ``values``, its index in ``order`` (distinct values holding every one of them)."""
    sorter = np.argsort(order)
    return sorter[np.searchsorted(order, values, sorter=sorter)].astype(np.intp)


def station_groups(points: Points) -> StationGroups:
    """Group the points by station, stations in forward-pass order (return-only ones at the end)."""
    st = np.asarray(as_columns(points)["station"], dtype=int)
    p = pass_of(points)
    n = len(st)
    if not np.any(p) and np.all(np.diff(st) > 0):  # forward pass only, in order: identity
        return StationGroups(st, np.arange(n), np.ones(n, dtype=np.intp), np.zeros(n, dtype=np.intp), True)
    order = _first_seen(np.concatenate([st[p == 0], st[p == 1]]))
    group = _index_in(order, st)
    counts = np.bincount(group, minlength=len(order))
    by_station = np.argsort(group, kind="stable")  # file order within each station
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    rank = np.empty(n, dtype=np.intp)
    rank[by_station] = np.arange(n) - starts[group[by_station]]
    return StationGroups(np.asarray(order, dtype=int), group, counts, rank, False)


@dataclass(frozen=True)
class ReturnPassSummary:
    """Forward and return profiles (columns station, x_mm, height_um) and what their difference says (um, h)."""

    forward: dict[str, np.ndarray]
    backward: dict[str, np.ndarray]
    closure_um: float | None
    drift_um_per_h: float | None

    def to_dict(self) -> dict[str, Any]:
        def rows(t: dict[str, np.ndarray]) -> list[dict[str, Any]]:
            return [{"station": int(k), "x_mm": float(x), "height_um": float(h)}
                    for k, x, h in zip(t["station"], t["x_mm"], t["height_um"], strict=True)]

        return {"forward": rows(self.forward), "return": rows(self.backward),
                "closure_um": self.closure_um, "drift_um_per_h": self.drift_um_per_h}


def return_pass_summary(points: Points, per_point: Points) -> ReturnPassSummary | None:
    """Compare the passes of a decoupled run; None without return-pass points.

    ``per_point``: the decoupled profile of every point (station, x_mm, height_um),
    row for row with ``points`` (which must carry ``time_s``).  A station measured more
    than once in the return pass counts with the mean of its return points.
    """
    p = pass_of(points)
    if not np.any(p == 1):
        return None
    prof = {c: np.asarray(v) for c, v in as_columns(per_point).items() if c in ("station", "x_mm", "height_um")}
    prof["time_s"] = np.asarray(as_columns(points)["time_s"], dtype=float)
    fwd = {c: v[p == 0] for c, v in prof.items()}
    back = {c: v[p == 1] for c, v in prof.items()}
    # the return pass per station (order of first appearance), means of its points
    st = back["station"]
    order = _first_seen(st)
    idx = _index_in(order, st)
    counts = np.bincount(idx, minlength=len(order))
    ret = {"station": order}
    for c in ("x_mm", "height_um", "time_s"):
        ret[c] = np.bincount(idx, weights=back[c].astype(float), minlength=len(order)) / counts
    # forward rows that have a return (inner join on station, forward order)
    pos = {int(k): i for i, k in enumerate(order.tolist())}
    f_at = [i for i, k in enumerate(fwd["station"].tolist()) if int(k) in pos]
    r_at = [pos[int(fwd["station"][i])] for i in f_at]
    d = ret["height_um"][r_at] - fwd["height_um"][f_at]
    dt_h = (ret["time_s"][r_at] - fwd["time_s"][f_at]) / 3600.0
    datum = int(fwd["station"][0])
    at_datum = fwd["station"][f_at] == datum
    closure = float(d[at_datum][0]) if at_datum.any() else None
    drift = float(np.sum(d * dt_h) / np.sum(dt_h**2)) if np.sum(dt_h**2) > 0 else None
    cols = ("station", "x_mm", "height_um")
    return ReturnPassSummary({c: fwd[c] for c in cols}, {c: ret[c] for c in cols}, closure, drift)
