"""Two positioning runs compared target by target and direction by direction (ISO 230-2 deviations).

Per target P_i and direction (↑ "+", ↓ "-"): the mean deviations x̄_a, x̄_b of the two runs, the change
x̄_b − x̄_a, and its expanded uncertainty from the runs' own repeated approaches:

    u(x̄) = s / √n                       (standard uncertainty of a mean of n approaches, s with n − 1)
    U    = k · √(s_a²/n_a + s_b²/n_b)    (k = the evaluation's coverage factor, default 2)

The targets are matched by position (within :data:`TARGET_TOLERANCE`); a target or a direction measured
in one run only is listed with the other side empty, never dropped.  The ISO 230-2 axis values of both
runs are set side by side with their change in %."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from processing.iso230_2 import AXIS_QUANTITIES
from saved_runs.errors import UserError
from saved_runs.evaluation.positioning import PositioningEvaluation

from .changes import change, change_pct, combined_expanded, finite, none_if_nan, significant

# Targets closer than this are the same target (mm, deg): well below any target spacing, well above
# the rounding of a target written to points.csv.
TARGET_TOLERANCE = {"mm": 1e-3, "deg": 1e-4}
DIRECTIONS = ((1, "+", "up"), (-1, "-", "down"))


@dataclass(frozen=True)
class Side:
    """One run's mean deviation at a target in one direction: mean, sample standard deviation, approaches."""

    mean: float
    s: float  # NaN with fewer than 2 approaches
    n: int

    @property
    def u_mean(self) -> float | None:
        """Standard uncertainty of the mean, s / √n (None with fewer than 2 approaches)."""
        return self.s / math.sqrt(self.n) if self.n >= 2 and finite(self.s) else None


@dataclass(frozen=True)
class TargetChange:
    """The change at one target in one direction; ``a`` or ``b`` is None where that run has no approach."""

    target: float
    direction: int  # +1 up, -1 down
    a: Side | None
    b: Side | None
    k: float

    @property
    def change(self) -> float | None:
        return change(self.a.mean if self.a else None, self.b.mean if self.b else None)

    @property
    def expanded(self) -> float | None:
        """U of the change (None where a side is missing or has fewer than 2 approaches)."""
        if self.a is None or self.b is None:
            return None
        return combined_expanded(self.a.u_mean, self.b.u_mean, self.k)

    @property
    def significant(self) -> bool | None:
        return significant(self.change, self.expanded)

    @property
    def dof(self) -> float | None:
        """Effective degrees of freedom of the combined u (Welch-Satterthwaite), to judge what k covers."""
        if self.expanded is None:
            return None
        ua, ub = self.a.u_mean, self.b.u_mean  # type: ignore[union-attr]
        den = ua**4 / (self.a.n - 1) + ub**4 / (self.b.n - 1)  # type: ignore[operator, union-attr]
        return (ua**2 + ub**2) ** 2 / den if den > 0 else None  # type: ignore[operator]

    @property
    def only_in(self) -> str | None:
        return "a" if self.b is None else "b" if self.a is None else None

    def to_dict(self, unit: str, target_unit: str) -> dict[str, Any]:
        return {
            f"target_{target_unit}": self.target,
            "direction": "+" if self.direction > 0 else "-",
            f"a_{unit}": self.a.mean if self.a else None,
            f"b_{unit}": self.b.mean if self.b else None,
            f"change_{unit}": self.change,
            f"u_{unit}": self.expanded,
            "significant": self.significant,
            "dof": self.dof,
            "n_a": self.a.n if self.a else 0,
            "n_b": self.b.n if self.b else 0,
            f"s_a_{unit}": none_if_nan(self.a.s) if self.a else None,
            f"s_b_{unit}": none_if_nan(self.b.s) if self.b else None,
            "only_in": self.only_in,
        }


def _sides(evaluation: PositioningEvaluation) -> dict[int, dict[int, Side]]:
    """row index → {direction: Side} for every direction measured at that target."""
    out: dict[int, dict[int, Side]] = {}
    pt = evaluation.result.per_target
    for i, row in enumerate(pt.itertuples(index=False)):
        sides = {}
        for d, _, name in DIRECTIONS:
            n = int(getattr(row, f"n_{name}"))
            if n > 0:
                sides[d] = Side(float(getattr(row, f"mean_{name}")), float(getattr(row, f"s_{name}")), n)
        out[i] = sides
    return out


def match_targets(ta: np.ndarray, tb: np.ndarray, tolerance: float) -> list[tuple[float, int | None, int | None]]:
    """(target, row in A or None, row in B or None) for the union of both runs' targets, ascending."""
    rows: list[tuple[float, int | None, int | None]] = []
    used_b: set[int] = set()
    for i, t in enumerate(ta):
        j = int(np.argmin(np.abs(tb - t))) if len(tb) else -1
        if j >= 0 and abs(tb[j] - t) <= tolerance and j not in used_b:
            used_b.add(j)
            rows.append((float(t), i, j))
        else:
            rows.append((float(t), i, None))
    rows += [(float(t), None, j) for j, t in enumerate(tb) if j not in used_b]
    return sorted(rows, key=lambda r: r[0])


@dataclass(frozen=True)
class PositioningComparison:
    a: PositioningEvaluation
    b: PositioningEvaluation
    targets: tuple[TargetChange, ...]
    notes: tuple[str, ...]

    @property
    def unit(self) -> str:
        return self.a.result.unit

    @property
    def target_unit(self) -> str:
        return self.a.result.target_unit

    @property
    def k(self) -> float:
        return self.a.result.k

    def values(self) -> dict[str, dict[str, float | None]]:
        """ISO 230-2 axis values of both runs: {"E": {"a", "b", "change", "change_pct"}, ...}."""
        out = {}
        for q in AXIS_QUANTITIES:
            va, vb = none_if_nan(self.a.result.axis[q]), none_if_nan(self.b.result.axis[q])
            out[q] = {"a": va, "b": vb, "change": change(va, vb), "change_pct": change_pct(va, vb)}
        return out

    def matched(self) -> list[TargetChange]:
        return [t for t in self.targets if t.only_in is None]

    def to_dict(self) -> dict[str, Any]:
        return {"targets": [t.to_dict(self.unit, self.target_unit) for t in self.targets], "values": self.values(),
                "unit": self.unit, "target_unit": self.target_unit, "axis_type": self.a.result.axis_type,
                "k": self.k, "edition": self.a.result.edition,
                "uncertainty": f"U = k * sqrt(s_a^2/n_a + s_b^2/n_b), k = {self.k:g}: the standard uncertainty of "
                               "each run's mean from its own repeated approaches, combined in quadrature",
                "deviation": "x_ij = actual - target (after environmental compensation); change = b - a"}


def compare_positioning(a: PositioningEvaluation, b: PositioningEvaluation) -> PositioningComparison:
    """Match the targets of two evaluated positioning runs and compute the change at each."""
    ra, rb = a.result, b.result
    if ra.k != rb.k:  # both are evaluated with the same options; a guard for callers that are not
        raise UserError(f"the runs were evaluated with different coverage factors ({ra.k:g}, {rb.k:g})")
    tol = TARGET_TOLERANCE[ra.target_unit]
    ta = ra.per_target["target"].to_numpy(dtype=float)
    tb = rb.per_target["target"].to_numpy(dtype=float)
    pairs = match_targets(ta, tb, tol)
    if not any(i is not None and j is not None for _, i, j in pairs):
        u = ra.target_unit
        raise UserError(f"the runs share no target: {a.run.path} has {len(ta)} targets {ta.min():g} … {ta.max():g} "
                        f"{u}, {b.run.path} {len(tb)} targets {tb.min():g} … {tb.max():g} {u}; compare needs runs "
                        f"of the same targets (within {tol:g} {u})")
    sa, sb = _sides(a), _sides(b)
    rows = []
    for t, i, j in pairs:
        da = sa[i] if i is not None else {}
        db = sb[j] if j is not None else {}
        for d, _, _ in DIRECTIONS:
            if d in da or d in db:
                rows.append(TargetChange(t, d, da.get(d), db.get(d), ra.k))
    notes = []
    only = {"a": sorted({r.target for r in rows if r.only_in == "a"}),
            "b": sorted({r.target for r in rows if r.only_in == "b"})}
    for side, run in (("a", a), ("b", b)):
        if only[side]:
            listed = ", ".join(f"{t:g}" for t in only[side][:8]) + (" ..." if len(only[side]) > 8 else "")
            notes.append(f"measured in run {side.upper()} only ({run.run.path}): {len(only[side])} target/direction "
                         f"row(s) at {listed} {ra.target_unit}; no change there")
    if only["a"] or only["b"]:
        notes.append("the ISO 230-2 values of each run cover all its own targets, so they are not like for like")
    if any(r.only_in is None and r.expanded is None for r in rows):
        notes.append("where a run has fewer than 2 approaches at a target (a single run, the long-axis rule) the "
                     "uncertainty of its mean cannot be evaluated from the run: no U and no significance there")
    return PositioningComparison(a, b, tuple(rows), tuple(notes))
