"""Evaluation of a saved positioning run (ISO 230-2): environmental compensation,
deviations x_ij = actual − target, statistics, result files and the printed table."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import pandas as pd

from processing.environment import CompensationInfo, EnvironmentSettings, angular_deviation_deg, compensate_points
from processing.iso230_2 import (
    AXIS_QUANTITIES,
    DEFAULT_EDITION,
    QUANTITY_NAMES,
    VDI3441_QUANTITIES,
    Iso2302Result,
    evaluate_iso230_2,
)
from processing.positioning_budget import BudgetSettings, ValueBudget, positioning_budget, span_of

from ..errors import RunFormatError
from ..store.compensation import compensation_text, run_compensation
from ..store.plan import check_positioning_points
from ..store.reader import LoadedRun
from .limits import OutOfRange, out_of_range, out_of_range_dict, print_out_of_range
from .tolerance import DEFAULT_DECISION_RULE, Verdict, positioning_verdict, verdict_dict

ARCSEC_PER_DEG = 3600.0
UM_PER_MM = 1000.0
MAX_TARGET_ROWS = 40  # per-target rows printed in the terminal summary


@dataclass(frozen=True)
class PositioningEvaluation:
    run: LoadedRun
    result: Iso2302Result
    deviations: pd.DataFrame        # target_index, target, direction, run, deviation (result.unit)
    environment: CompensationInfo
    out_of_range: tuple[OutOfRange, ...] = ()  # accepted with --accept-out-of-range (.limits)
    verdict: Verdict | None = None  # against the set-up's [tolerance] (.tolerance)
    budget: dict[str, ValueBudget] | None = None  # U of each ISO 230-2 value (processing.positioning_budget)

    def to_dict(self) -> dict[str, Any]:
        """The object ``guideway process --json`` prints for a positioning run."""
        r = self.result.to_dict()
        return {
            "kind": "positioning",
            "axis_type": r.pop("axis_type"),
            "unit": r.pop("unit"),
            "iso230_2": r.pop("iso230_2"),
            "targets": r.pop("targets"),
            "vdi3441": r.pop("vdi3441"),
            "environment": self.environment.to_dict(),
            "deviation": "x_ij = actual - target (after environmental compensation)",
            "controller_compensation": run_compensation(self.run.meta),
            **r,
            "uncertainty": None if self.budget is None else {q: b.to_dict() for q, b in self.budget.items()},
            **verdict_dict(self.verdict),
            **out_of_range_dict(self.out_of_range),
        }

    def write(self, results_dir: Path, *, plot: bool = True) -> Path:
        """results/ as one set; positioning.png only with ``plot``."""
        from ..results.positioning import write_positioning_results  # matplotlib only when writing

        return write_positioning_results(results_dir, self.result, self.deviations, self.to_dict(), plot=plot)

    def print_summary(self, stream: TextIO) -> None:
        r = self.result
        pt = r.per_target
        print_out_of_range(self.out_of_range, stream)
        print(f"ISO 230-2 positioning ({r.edition}, k = {r.k:g}), {r.axis_type} axis, {len(pt)} targets, "
              f"runs up/down {r.runs_up}/{r.runs_down}, deviations in {r.unit}", file=stream)
        rows = pt if len(pt) <= MAX_TARGET_ROWS else pt.iloc[:MAX_TARGET_ROWS]
        print(f"  {'i':>4} {'target ' + r.target_unit:>12} {'mean up':>9} {'mean down':>9} {'B_i':>9} "
              f"{'s up':>8} {'s down':>8} {'R_i':>8}", file=stream)
        for t in rows.itertuples(index=False):
            print(f"  {t.target_index:>4} {t.target:>12.4f} {_fmt(t.mean_up):>9} {_fmt(t.mean_down):>9} "
                  f"{_fmt(t.reversal):>9} {_fmt(t.s_up):>8} {_fmt(t.s_down):>8} {_fmt(t.R_i):>8}", file=stream)
        if len(pt) > MAX_TARGET_ROWS:
            print(f"  ... {len(pt) - MAX_TARGET_ROWS} more targets in results/positioning.csv", file=stream)
        print(compensation_text(run_compensation(self.run.meta)), file=stream)
        env = self.environment
        print(f"environment: {env.reason}" + (f" ({env.equation_name})" if env.equation_name else ""), file=stream)
        budget = self.budget or {}
        for q in AXIS_QUANTITIES:
            b = budget.get(q)
            u = f"U {_fmt(b.U):>7} (k = {b.k:g})" if b is not None and b.U is not None else " " * 19
            print(f"  {q:<7} {_fmt(r.axis[q]):>10} {r.unit:<6} {u}  {QUANTITY_NAMES[q][0]}", file=stream)
        vdi = ", ".join(f"{q} {_fmt(r.vdi3441[q])}" for q in VDI3441_QUANTITIES)
        print(f"VDI/DGQ 3441 ({r.unit}): {vdi}", file=stream)
        for note in r.notes:
            print(f"note: {note}", file=stream)
        if self.verdict is not None:
            print(self.verdict.text(), file=stream)


def _fmt(v: float) -> str:
    return f"{v:.3f}" if math.isfinite(v) else "n/a"


def positioning_deviations(run: LoadedRun) -> tuple[pd.DataFrame, str, CompensationInfo]:
    """Deviations of a positioning run after environmental compensation.

    Returns (deviations with columns target_index, target, direction, run, deviation;
    axis_type; what compensation was applied).  Linear axes: µm, rotary: arcsec.
    """
    axis_type = run.meta.get("axis_type", "linear")
    if axis_type not in ("linear", "rotary"):
        raise RunFormatError(f"{run.path}/run.json: axis_type must be linear or rotary, got {axis_type!r}")
    pts = run.points
    if len(pts) == 0:
        raise RunFormatError(f"{run.path}: no points recorded; nothing to evaluate")
    setup = run.meta.get("setup") or {}
    try:
        settings = EnvironmentSettings.from_dict(setup.get("environment"))
    except ValueError as exc:
        raise RunFormatError(f"{run.path}/run.json: {exc}") from None
    if axis_type == "rotary":
        target = pts["target_deg"].to_numpy(dtype=float)
        dev = angular_deviation_deg(pts["reading_deg"].to_numpy(dtype=float), target) * ARCSEC_PER_DEG
        info = CompensationInfo(applied=False, reason="rotary axis: angular readings are not air-compensated "
                                "(the index cancels in an angular interferometer)")
    else:
        target = pts["target_mm"].to_numpy(dtype=float)
        try:
            length_mm, info = compensate_points(pts, settings)
        except ValueError as exc:
            raise RunFormatError(f"{run.path}: {exc}") from None
        dev = (length_mm - target) * UM_PER_MM
    bad = np.flatnonzero(~np.isfinite(dev))
    if bad.size:
        raise RunFormatError(f"{run.path}: points.csv data row {bad[0] + 1} has no reading or target")
    deviations = pd.DataFrame({
        "target_index": pts["target_index"].to_numpy(),
        "target": target,
        "direction": pts["direction"].to_numpy(),
        "run": pts["run"].to_numpy(),
        "deviation": dev,
    })
    return deviations, axis_type, info


def evaluate_positioning_run(run: LoadedRun, *, k: float = 2.0, edition: str = DEFAULT_EDITION,
                             accept_out_of_range: bool = False,
                             decision_rule: str = DEFAULT_DECISION_RULE) -> PositioningEvaluation:
    """Evaluate a loaded positioning run (ISO 230-2, VDI/DGQ 3441); readings further from their
    target than the set-up allows are refused unless ``accept_out_of_range``."""
    check_positioning_points(run)
    accepted = out_of_range(run, accept=accept_out_of_range) if len(run.points) else ()
    deviations, axis_type, info = positioning_deviations(run)
    try:
        result = evaluate_iso230_2(deviations, axis_type=axis_type, k=k, edition=edition)
    except ValueError as exc:
        raise RunFormatError(f"{run.path}: {exc}") from None
    per_target = result.per_target
    budget = value_budget(run, result, info)
    verdict = positioning_verdict(run.meta, f"{run.path}/run.json", result.axis, result.unit,
                                  ([int(n) for n in per_target["n_up"]], [int(n) for n in per_target["n_down"]]),
                                  rule=decision_rule, uncertainty={q: b.U for q, b in budget.items()})
    return PositioningEvaluation(run, result, deviations, info, accepted, verdict, budget)


def _mean(points: pd.DataFrame, column: str, factor: float = 1.0) -> float:
    """Mean of a points.csv column (NaN when absent or empty)."""
    if column not in points:
        return math.nan
    v = points[column].to_numpy(dtype=float)
    v = v[np.isfinite(v)]
    return float(v.mean()) * factor if v.size else math.nan


def value_budget(run: LoadedRun, result: Iso2302Result, info: CompensationInfo) -> dict[str, ValueBudget]:
    """The uncertainty budget of each ISO 230-2 value of ``result`` (processing.positioning_budget): the
    run's mean air and material conditions, its set-up's [environment] and [uncertainty], and the
    repeatability of each value from the run's own approaches (value_uncertainty's Monte Carlo)."""
    from .value_uncertainty import axis_value_spread

    setup = run.meta.get("setup") or {}
    try:
        settings = BudgetSettings.from_dict(setup.get("uncertainty"))
        env = EnvironmentSettings.from_dict(setup.get("environment"))
    except ValueError as exc:
        raise RunFormatError(f"{run.path}/run.json: {exc}") from None
    pts = run.points
    air = (_mean(pts, "air_temp_c"), _mean(pts, "air_pressure_hpa", 100.0), _mean(pts, "humidity_pct"))
    return positioning_budget(
        axis_type=result.axis_type, unit=result.unit, span_mm=span_of(result.per_target["target"].to_numpy(float)),
        repeatability=axis_value_spread(result).u, settings=settings, k=result.k, air=air,
        material_temp_c=_mean(pts, "material_temp_c"), expansion_ppm_per_k=env.expansion_ppm_per_k,
        equation=env.index_equation, wavelength_nm=env.wavelength_nm, co2_ppm=env.co2_ppm)

