"""ISO 230-2 positioning statistics (and VDI/DGQ 3441 for comparison).

Formulas: ``../shared/reference/standards.md`` section 1.3 (ISO 230-2, editions
1997, 2006 and 2014 share them) and 1.5 (VDI/DGQ 3441).  Notation: target
i = 1 … m, approach j = 1 … n per direction, ↑ = positive direction ("up"),
↓ = negative direction ("down"), deviation x_ij = P_ij − P_i (actual minus
target).  The coverage factor k (default 2) replaces the standard's "2" in
±2 s and 4 s (4 s = 2·k·s).

Units: deviations and every result are in the unit of the input deviations –
µm for linear axes, arcsec for rotary axes (``unit``).  Targets are mm or deg.

The input is either a long DataFrame (:func:`evaluate_iso230_2`, columns
``target_index, target, direction, run, deviation``) or two arrays of shape
(m, n) per direction with NaN where an approach is missing
(:func:`iso230_2_from_arrays`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # the set-up loaders use the target rules; pandas only with deviations
    import pandas as pd

DEFAULT_EDITION = "ISO 230-2:2014"
# Editions whose formulas are the ones implemented (1988 used ±3 s and is not supported).
EDITIONS = ("ISO 230-2:1997", "ISO 230-2:2006", "ISO 230-2:2014")
UNITS = {"linear": "um", "rotary": "arcsec"}
TARGET_UNITS = {"linear": "mm", "rotary": "deg"}

# ISO 230-2 target rule (standards.md §1.4): linear axes up to LONG_AXIS_MM need at least
# MIN_TARGETS_PER_METRE per metre and MIN_TARGETS in total; longer ones about one every
# LONG_AXIS_INTERVAL_MM; rotary axes at least MIN_TARGETS.  Below MIN_TARGETS_EVALUATED
# there is no range of deviations (E, M, A) at all.
MIN_TARGETS = 5
MIN_TARGETS_PER_METRE = 5.0
LONG_AXIS_MM = 2000.0
LONG_AXIS_INTERVAL_MM = 250.0
MIN_TARGETS_EVALUATED = 2
TARGET_RULE = (f"at least {MIN_TARGETS} targets and at least {MIN_TARGETS_PER_METRE:g} per metre; "
               f"about one every {LONG_AXIS_INTERVAL_MM:g} mm above {LONG_AXIS_MM:g} mm")

# Axis-level quantities, in the order of the ISO 230-2 table.
AXIS_QUANTITIES = ("B", "B_mean", "R_up", "R_down", "R", "E_up", "E_down", "E", "M", "A_up", "A_down", "A")

# Names of the quantities in ISO 230-2 (English) and GB/T 17421.2 (Chinese adoption).
# The Chinese terms are those of GB/T 17421.2-2000/-2016 as commonly quoted; check the
# clause wording against the standard before quoting it in a contract.
QUANTITY_NAMES: dict[str, tuple[str, str]] = {
    "mean_up": ("mean unidirectional positional deviation at a position (↑)", "某一位置的单向平均位置偏差 (↑)"),
    "mean_down": ("mean unidirectional positional deviation at a position (↓)", "某一位置的单向平均位置偏差 (↓)"),
    "mean_bi": ("mean bidirectional positional deviation at a position", "某一位置的双向平均位置偏差"),
    "reversal": ("reversal value at a position B_i", "某一位置的反向差值 B_i"),
    "s_up": ("estimator of the unidirectional standard uncertainty at a position (↑)",
             "某一位置的单向定位标准不确定度的估算值 (↑)"),
    "s_down": ("estimator of the unidirectional standard uncertainty at a position (↓)",
               "某一位置的单向定位标准不确定度的估算值 (↓)"),
    "R_i_up": ("unidirectional positioning repeatability at a position (↑)", "某一位置的单向重复定位精度 (↑)"),
    "R_i_down": ("unidirectional positioning repeatability at a position (↓)", "某一位置的单向重复定位精度 (↓)"),
    "R_i": ("bidirectional positioning repeatability at a position", "某一位置的双向重复定位精度"),
    "B": ("reversal value of an axis", "轴线反向差值"),
    "B_mean": ("mean reversal value of an axis", "轴线平均反向差值"),
    "R_up": ("unidirectional positioning repeatability of an axis (↑)", "轴线单向重复定位精度 (↑)"),
    "R_down": ("unidirectional positioning repeatability of an axis (↓)", "轴线单向重复定位精度 (↓)"),
    "R": ("bidirectional positioning repeatability of an axis", "轴线双向重复定位精度"),
    "E_up": ("unidirectional systematic positional deviation of an axis (↑)", "轴线单向定位系统偏差 (↑)"),
    "E_down": ("unidirectional systematic positional deviation of an axis (↓)", "轴线单向定位系统偏差 (↓)"),
    "E": ("bidirectional systematic positional deviation of an axis", "轴线双向定位系统偏差"),
    "M": ("range of the mean bidirectional positional deviation of an axis", "轴线双向平均位置偏差范围"),
    "A_up": ("unidirectional accuracy of positioning of an axis (↑)", "轴线单向定位精度 (↑)"),
    "A_down": ("unidirectional accuracy of positioning of an axis (↓)", "轴线单向定位精度 (↓)"),
    "A": ("bidirectional accuracy of positioning of an axis", "轴线双向定位精度"),
}

# VDI/DGQ 3441 quantities (standards.md 1.5).
VDI3441_QUANTITIES = ("P", "Pa", "Ps_max", "Ps_mean", "U_max", "U_mean")
VDI3441_NAMES = {
    "P": "Positionsunsicherheit (positional uncertainty)",
    "Pa": "Positionsabweichung (position deviation)",
    "Ps_max": "maximale Positionsstreubreite (max. positional scatter, 6 s)",
    "Ps_mean": "mittlere Positionsstreubreite (mean positional scatter)",
    "U_max": "maximale Umkehrspanne (max. reversal span)",
    "U_mean": "mittlere Umkehrspanne (mean reversal span)",
}

PER_TARGET_COLUMNS = (
    "target_index",  # i = 1 … m
    "target",        # P_i, mm (linear) or deg (rotary)
    "n_up", "n_down",  # approaches used per direction
    "mean_up", "mean_down",  # x̄_i↑, x̄_i↓ (NaN where a direction is missing)
    "mean_bi",       # x̄_i
    "reversal",      # B_i = x̄_i↑ − x̄_i↓ (signed)
    "s_up", "s_down",  # s_i↑, s_i↓ (ddof = 1; NaN with fewer than 2 approaches)
    "R_i_up", "R_i_down",  # 2 k s_i
    "R_i",           # max(k s↑ + k s↓ + |B_i|, R_i↑, R_i↓)
)


def _nanmax(a: np.ndarray) -> float:
    """max over the finite entries; NaN if there is none (no RuntimeWarning)."""
    a = a[np.isfinite(a)]
    return float(a.max()) if a.size else math.nan


def _nanmean(a: np.ndarray) -> float:
    a = a[np.isfinite(a)]
    return float(a.mean()) if a.size else math.nan


def _nanmin(a: np.ndarray) -> float:
    a = a[np.isfinite(a)]
    return float(a.min()) if a.size else math.nan


def _mean_std(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row-wise count, mean and sample standard deviation (ddof = 1) ignoring NaN.

    Mean is NaN for rows without values, std NaN for rows with fewer than 2.
    """
    ok = np.isfinite(x)
    n = ok.sum(axis=1)
    filled = np.where(ok, x, 0.0)
    # The only divisions by zero are 0/0 (n = 0 for the mean, n = 1 for std): NaN, "invalid" only.
    with np.errstate(invalid="ignore"):
        mean = filled.sum(axis=1) / n
        resid = np.where(ok, x - mean[:, None], 0.0)
        std = np.sqrt((resid**2).sum(axis=1) / (n - 1))
    std = np.where(n >= 2, std, np.nan)  # n = 0 gives sqrt(0 / -1) = 0, not NaN
    return n, mean, std


@dataclass(frozen=True)
class Iso2302Result:
    """ISO 230-2 evaluation of one axis.

    ``per_target`` has the columns :data:`PER_TARGET_COLUMNS`; ``axis`` maps the
    names of :data:`AXIS_QUANTITIES` to values (NaN where not evaluable);
    ``vdi3441`` the names of :data:`VDI3441_QUANTITIES`.  All deviations in ``unit``.
    """

    axis_type: str
    unit: str
    k: float
    edition: str
    per_target: pd.DataFrame
    axis: dict[str, float]
    vdi3441: dict[str, float]
    directions: str                 # "bidirectional", "up" or "down"
    runs_up: int                    # most approaches at a target, ↑
    runs_down: int
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def target_unit(self) -> str:
        return TARGET_UNITS[self.axis_type]

    @property
    def repeatability_evaluated(self) -> bool:
        return any(math.isfinite(self.axis[q]) for q in ("R_up", "R_down", "R"))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (NaN → None)."""
        records = self.per_target.to_dict(orient="records")  # pragma: no mutate (equivalent: pandas lower-cases it)
        return {
            "axis_type": self.axis_type,
            "unit": self.unit,
            "target_unit": self.target_unit,
            "edition": self.edition,
            "k": self.k,
            "directions": self.directions,
            "runs_up": self.runs_up,
            "runs_down": self.runs_down,
            "repeatability_evaluated": self.repeatability_evaluated,
            "notes": list(self.notes),
            "iso230_2": {q: _json_num(v) for q, v in self.axis.items()},
            "vdi3441": {q: _json_num(v) for q, v in self.vdi3441.items()},
            "targets": [{c: _json_num(v) for c, v in row.items()}
                        for row in records],
        }


def _json_num(v: Any) -> Any:
    if isinstance(v, (int, np.integer)):
        return int(v)
    v = float(v)
    return v if math.isfinite(v) else None


def iso230_2_from_arrays(
    targets: np.ndarray,
    up: np.ndarray,
    down: np.ndarray,
    *,
    axis_type: str = "linear",
    k: float = 2.0,
    edition: str = DEFAULT_EDITION,
    travel: float | None = None,
) -> Iso2302Result:
    """ISO 230-2 statistics from per-direction deviation arrays.

    ``targets``: shape (m,), mm or deg, ascending.  ``up``/``down``: shape
    (m, n↑)/(m, n↓), deviations x_ij in µm (linear) or arcsec (rotary), NaN where
    an approach is missing; a direction with no values at all (or n = 0 columns)
    was not measured.  ``travel`` (mm) defaults to the target span; it only
    selects the explanatory note of the long-axis rule.
    """
    if axis_type not in UNITS:
        raise ValueError(f"unknown axis_type {axis_type!r} (use linear or rotary)")
    if edition not in EDITIONS:
        raise ValueError(f"unsupported edition {edition!r}; choose one of {', '.join(EDITIONS)}")
    if not k > 0:
        raise ValueError(f"coverage factor k must be positive, got {k}")
    targets = np.asarray(targets, dtype=float)
    m = targets.shape[0]
    if m == 0:
        raise ValueError("no target positions")
    target_note = check_target_count(targets, axis_type)
    up = np.asarray(up, dtype=float)  # None (a missing approach) becomes NaN
    down = np.asarray(down, dtype=float)
    up = up.reshape(m, -1)  # pragma: no mutate (equivalent: numpy takes any negative size as "the rest")
    down = down.reshape(m, -1)  # pragma: no mutate (equivalent: numpy takes any negative size as "the rest")

    n_up, mean_up, s_up = _mean_std(up)
    n_dn, mean_dn, s_dn = _mean_std(down)
    has_up, has_dn = bool(n_up.any()), bool(n_dn.any())
    if not (has_up or has_dn):
        raise ValueError("no deviations to evaluate")
    directions = "bidirectional" if has_up and has_dn else ("up" if has_up else "down")

    mean_bi = (mean_up + mean_dn) / 2
    reversal = mean_up - mean_dn
    R_i_up = 2 * k * s_up
    R_i_dn = 2 * k * s_dn
    # max() of the three terms; NaN only if a term is NaN (missing s or direction).
    R_i = np.maximum(np.maximum(k * s_up + k * s_dn + np.abs(reversal), R_i_up), R_i_dn)

    def spread(hi: np.ndarray, lo: np.ndarray) -> float:
        return _nanmax(hi) - _nanmin(lo)

    both_means = np.concatenate([mean_up, mean_dn])
    axis = {
        "B": _nanmax(np.abs(reversal)),
        "B_mean": _nanmean(reversal),
        "R_up": _nanmax(R_i_up),
        "R_down": _nanmax(R_i_dn),
        "R": _nanmax(R_i),
        "E_up": spread(mean_up, mean_up),
        "E_down": spread(mean_dn, mean_dn),
        "E": spread(both_means, both_means) if directions == "bidirectional" else math.nan,
        "M": spread(mean_bi, mean_bi),
        "A_up": spread(mean_up + k * s_up, mean_up - k * s_up),
        "A_down": spread(mean_dn + k * s_dn, mean_dn - k * s_dn),
        # A unidirectional test has no s in the other direction: the check below makes A NaN.
        "A": spread(np.concatenate([mean_up + k * s_up, mean_dn + k * s_dn]),
                    np.concatenate([mean_up - k * s_up, mean_dn - k * s_dn])),
    }
    # A accuracy value needs s at every target of the direction(s) it covers.
    for q, s in (("A_up", s_up), ("A_down", s_dn)):
        if not np.all(np.isfinite(s)):
            axis[q] = math.nan
    if not (np.all(np.isfinite(s_up)) and np.all(np.isfinite(s_dn))):
        axis["A"] = math.nan

    notes: list[str] = [target_note] if target_note else []
    runs_up, runs_dn = int(n_up.max()), int(n_dn.max())
    if directions != "bidirectional":
        notes.append(f"unidirectional test ({'↑' if has_up else '↓'} only): reversal (B, B_mean), E, M and A "
                     "are bidirectional quantities and not evaluated")
    measured = [n for n, h in ((n_up, has_up), (n_dn, has_dn)) if h]
    if any(int(n.max()) < 2 for n in measured):
        span = float(travel) if travel is not None else float(targets.max() - targets.min())
        why = (f"travel {span:g} mm > 2000 mm: ISO 230-2 long-axis test"
               if axis_type == "linear" and span > 2000 else "fewer than 2 approaches per direction")
        notes.append(f"single run ({why}): no repeatability figures (s, R, A) from one run; "
                     "only E, M, B, B_mean are evaluated")
    elif any(int(n.min()) < 2 for n in measured):
        notes.append("some targets have fewer than 2 approaches: their s and R are not evaluated, "
                     "A is not evaluated")
    if any(int(n.min()) != int(n.max()) for n in measured):
        notes.append("the number of approaches differs between targets (missing points)")

    # VDI/DGQ 3441: needs both directions; Ps uses 6 × the mean of the two standard deviations.
    U = np.abs(reversal)
    Ps = 6 * (s_up + s_dn) / 2
    vdi = {
        "P": spread(mean_bi + (U + Ps) / 2, mean_bi - (U + Ps) / 2)
        if np.all(np.isfinite(Ps)) and np.all(np.isfinite(U)) else math.nan,
        "Pa": axis["M"],
        "Ps_max": _nanmax(Ps),
        "Ps_mean": float(np.mean(Ps)),  # NaN if any target lacks s (NaN propagates)
        "U_max": _nanmax(U),
        "U_mean": float(np.mean(U)),
    }

    import pandas as pd

    per_target = pd.DataFrame({
        "target_index": np.arange(1, m + 1),
        "target": targets,
        "n_up": n_up, "n_down": n_dn,
        "mean_up": mean_up, "mean_down": mean_dn, "mean_bi": mean_bi, "reversal": reversal,
        "s_up": s_up, "s_down": s_dn, "R_i_up": R_i_up, "R_i_down": R_i_dn, "R_i": R_i,
    }, columns=list(PER_TARGET_COLUMNS))  # pragma: no mutate (equivalent: the dict has this order)
    return Iso2302Result(axis_type=axis_type, unit=UNITS[axis_type], k=float(k), edition=edition,
                          per_target=per_target, axis=axis, vdi3441=vdi, directions=directions,
                          runs_up=runs_up, runs_down=runs_dn, notes=tuple(notes))


def required_targets(span: float, axis_type: str = "linear") -> int:
    """Fewest targets ISO 230-2 accepts over ``span`` (mm; rotary axes: deg, :data:`MIN_TARGETS`)."""
    if axis_type != "linear":
        return MIN_TARGETS
    if span > LONG_AXIS_MM:
        return max(MIN_TARGETS, round(span / LONG_AXIS_INTERVAL_MM) + 1)
    return max(MIN_TARGETS, math.ceil(MIN_TARGETS_PER_METRE * span / 1000.0 - 1e-9))


def check_target_count(targets: Any, axis_type: str = "linear", span: float | None = None) -> str | None:
    """The ISO 230-2 target rule applied to ``targets`` (mm or deg) over ``span`` (default: their range).

    Raises ValueError below :data:`MIN_TARGETS_EVALUATED` distinct targets (no E, M or A); returns
    a note when there are fewer than :func:`required_targets`, else None.
    """
    t = np.unique(np.asarray(targets, dtype=float))
    if t.size < MIN_TARGETS_EVALUATED:
        raise ValueError(f"{t.size} target position(s): E, M and A need at least {MIN_TARGETS_EVALUATED} "
                         f"targets (ISO 230-2 target rule: {TARGET_RULE})")
    span = float(t.max() - t.min()) if span is None else float(span)
    need = required_targets(span, axis_type)
    if t.size < need:
        over = f" over {span:g} mm" if axis_type == "linear" else ""
        return (f"{t.size} targets{over} (at least {need} required): the test does not meet ISO 230-2's "
                f"target rule ({TARGET_RULE})")
    return None


DEVIATION_COLUMNS = ("target_index", "target", "direction", "run", "deviation")


def deviation_arrays(deviations: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Reshape long deviations (columns :data:`DEVIATION_COLUMNS`) into
    ``(target_index, targets, up, down)``; up/down have shape (m, max run) with NaN holes.

    Raises ValueError on a direction other than ±1, a run < 1, two rows for the same
    (target, direction, run) or a target index with two different targets.
    """
    missing = [c for c in DEVIATION_COLUMNS if c not in deviations]
    if missing:
        raise ValueError(f"deviations lack column(s) {', '.join(missing)}")
    ti = deviations["target_index"].to_numpy(dtype=np.int64)
    tg = deviations["target"].to_numpy(dtype=float)
    dr = deviations["direction"].to_numpy(dtype=np.int64)
    rn = deviations["run"].to_numpy(dtype=np.int64)
    dev = deviations["deviation"].to_numpy(dtype=float)  # pragma: no mutate (equivalent: stored into floats)
    if ti.size == 0:
        raise ValueError("no points")
    if not np.all((dr == 1) | (dr == -1)):
        raise ValueError("direction must be +1 or -1")
    if rn.min() < 1:
        raise ValueError("run numbers count from 1")
    index, inverse = np.unique(ti, return_inverse=True)
    targets = np.full(index.size, np.nan)
    targets[inverse] = tg
    if not np.array_equal(targets[inverse], tg):
        raise ValueError("a target_index appears with two different target positions")
    n = int(rn.max())
    out = []
    for d in (1, -1):
        sel = dr == d
        arr = np.full((index.size, n), np.nan)
        flat = inverse[sel] * n + (rn[sel] - 1)
        values, counts = np.unique(flat, return_counts=True)
        if values.size != flat.size:
            twice = int(values[counts > 1][0])
            raise ValueError(f"two points for target {int(index[twice // n])}, direction {d:+d}, run {twice % n + 1}; "
                             "remove one of them")
        arr.flat[flat] = dev[sel]
        out.append(arr)
    order = np.lexsort((index, targets))  # by target, equal targets by index
    return index[order], targets[order], out[0][order], out[1][order]


def evaluate_iso230_2(deviations: pd.DataFrame, *, axis_type: str = "linear", k: float = 2.0,
                      edition: str = DEFAULT_EDITION) -> Iso2302Result:
    """ISO 230-2 statistics of a long table of deviations.

    ``deviations`` columns: ``target_index`` (int), ``target`` (mm or deg),
    ``direction`` (+1 ↑ / −1 ↓), ``run`` (1 …), ``deviation`` (x_ij = actual −
    target, µm for linear, arcsec for rotary axes).  Targets are reported in
    ascending order, numbered 1 … m in that order.
    """
    # Runs without a point in a direction are all-NaN columns: they change no statistic.
    _, targets, up, down = deviation_arrays(deviations)
    return iso230_2_from_arrays(targets, up, down, axis_type=axis_type, k=k, edition=edition)
