"""``verify_runs``: an as-found run, the table exported from it, an as-left run measured with that table
active — did the table do what the export predicted? (docs/compensation.md, "Verify").

1. **Which table.**  AS_LEFT's run.json ``compensation`` names the table that was active (file, format,
   SHA-256).  It is the table exported from AS_FOUND when AS_FOUND/results/exports.json records an export
   of those bytes from that run, or a ``results/compensation-*.*`` file has them
   (saved_runs/export/provenance.py); otherwise verify says which table it was and that it is not.
2. **The values.**  Both runs evaluated as ``guideway process`` evaluates them; the prediction is AS_FOUND
   with the table applied as its controller applies it (saved_runs/export/predict.py).  Per ISO 230-2
   value: found, left, predicted, reduction = 100·(1 − |left| / |found|) %, each with its standard
   uncertainty u (saved_runs/evaluation/value_uncertainty.py; u of the reduction propagated to first order).
3. **Flags.**  A value whose gain |found| − |left| is smaller than AS_LEFT's repeatability (R, R↑, R↓ for
   the bidirectional, ↑ and ↓ values) or than the drift between the runs is flagged.  **Drift** = the range
   (max − min) over targets and directions of x̄_left − x̄_predicted: the change between the runs that the
   table does not explain (the machine's drift between the runs, temperature, and the noise of the means).

Refused with one line (exit 2): runs that are not both positioning runs, of different axes, axis types
or machines, that cannot be evaluated, whose targets differ, and an AS_LEFT measured with no table active
or that does not record it (``guideway compare`` compares such runs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from processing.iso230_2 import AXIS_QUANTITIES
from saved_runs.errors import UserError
from saved_runs.evaluation.evaluate import evaluate_run
from saved_runs.evaluation.positioning import PositioningEvaluation
from saved_runs.evaluation.value_uncertainty import axis_value_spread
from saved_runs.export.predict import Prediction, predict_as_left
from saved_runs.export.provenance import Provenance, find_export
from saved_runs.store.compensation import compensation_text, live_compensation_stopped, run_compensation
from saved_runs.store.reader import LoadedRun, load_run

from ..compare.compare import Comparison
from ..compare.positioning import TARGET_TOLERANCE, PositioningComparison, compare_positioning, match_targets
from ..compare.runs import RunIdentity, check_comparable

# a table does not change the repeatability: R is shown, never flagged
REPEATABILITY = ("R_up", "R_down", "R")
# the repeatability a value's gain is held against (AS_LEFT's)
REPEATABILITY_OF = {q: "R_up" if q.endswith("_up") else "R_down" if q.endswith("_down") else "R"
                    for q in AXIS_QUANTITIES}


def _finite(v: float | None) -> bool:
    return v is not None and math.isfinite(v)


def _num(v: float | None) -> float | None:
    return float(v) if _finite(v) else None


@dataclass(frozen=True)
class TableCheck:
    """The table AS_LEFT was measured with (``record``: its run.json ``compensation``) and where it comes
    from (``provenance`` in AS_FOUND's results/, None when it is not a table exported from AS_FOUND)."""

    record: dict[str, Any]
    provenance: Provenance | None

    @property
    def exported_from_found(self) -> bool:
        return self.provenance is not None

    def text(self) -> str:
        what = compensation_text(self.record).removeprefix("controller compensation: ")
        if self.provenance is None:
            return (f"AS_LEFT was measured with {what}: NOT a table exported from AS_FOUND (no export of that "
                    "SHA-256 in AS_FOUND/results/); the prediction applies that table to AS_FOUND")
        rec = self.provenance.record
        model = f", model {rec['model']} {rec.get('mode', '')}".rstrip() if rec.get("model") else ""
        return f"AS_LEFT was measured with {what}: the table exported from AS_FOUND ({self.provenance.how}{model})"

    def to_dict(self) -> dict[str, Any]:
        p = self.provenance
        return {"file": self.record.get("file"), "path": self.record.get("path"), "format": self.record.get("format"),
                "sha256": self.record.get("sha256"), "comp_file_type": self.record.get("comp_file_type"),
                "exported_from_found": self.exported_from_found,
                "found_as": None if p is None else p.how,
                "export": None if p is None else {k: p.record.get(k) for k in ("file", "path", "model", "mode",
                                                                                "written", "as_written")},
                "text": self.text()}


@dataclass(frozen=True)
class ValueCheck:
    """One ISO 230-2 value in the three runs (found, left, predicted), with standard uncertainties; ``k`` the
    coverage factor of "agrees"; ``repeatability`` AS_LEFT's R for this value; ``drift`` (module docstring)."""

    name: str
    found: float | None
    left: float | None
    predicted: float | None
    u_found: float | None
    u_left: float | None
    u_predicted: float | None
    k: float
    repeatability: float | None
    drift: float | None
    expected: float | None = None  # the prediction's value a repeat measurement is expected to show (Monte Carlo)

    @property
    def reduction_pct(self) -> float | None:
        """100·(1 − |left| / |found|): the share of the value the table removed (magnitudes: B_mean is signed)."""
        if not (_finite(self.found) and _finite(self.left)) or self.found == 0:
            return None
        return 100.0 * (1.0 - abs(self.left) / abs(self.found))  # type: ignore[arg-type]

    @property
    def predicted_reduction_pct(self) -> float | None:
        if not (_finite(self.found) and _finite(self.predicted)) or self.found == 0:
            return None
        return 100.0 * (1.0 - abs(self.predicted) / abs(self.found))  # type: ignore[arg-type]

    @property
    def u_reduction_pct(self) -> float | None:
        """u of the reduction: 100·√((u_l/f)² + (l·u_f/f²)²), first order, the runs independent."""
        if self.reduction_pct is None or not (_finite(self.u_found) and _finite(self.u_left)):
            return None
        f, lv = abs(self.found), abs(self.left)  # type: ignore[arg-type]
        return 100.0 * math.hypot(self.u_left / f, lv * self.u_found / f**2)  # type: ignore[operator]

    @property
    def gain(self) -> float | None:
        return abs(self.found) - abs(self.left) if _finite(self.found) and _finite(self.left) else None  # type: ignore[arg-type]

    @property
    def agrees(self) -> bool | None:
        """|left − expected| ≤ k·u_predicted: ``expected`` and ``u_predicted`` are the mean and the spread of the
        value a repeat measurement with the table shows, the noise of the as-found means carried into the
        prediction and the repeat's own noise both drawn (value_uncertainty; a max − min of noisy means is
        biased upwards); None without them."""
        if not (_finite(self.left) and _finite(self.expected) and _finite(self.u_predicted)):
            return None
        return abs(self.left - self.expected) <= self.k * self.u_predicted  # type: ignore[operator]

    @property
    def flags(self) -> list[str]:
        if self.name in REPEATABILITY or self.gain is None:
            return []
        out = []
        if _finite(self.repeatability) and self.gain < self.repeatability:  # type: ignore[operator]
            out.append(f"gain {self.gain:.3f} < repeatability {REPEATABILITY_OF[self.name]} {self.repeatability:.3f}")
        if _finite(self.drift) and self.gain < self.drift:  # type: ignore[operator]
            out.append(f"gain {self.gain:.3f} < drift {self.drift:.3f}")
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"found": _num(self.found), "left": _num(self.left), "predicted": _num(self.predicted),
                "reduction_pct": self.reduction_pct, "predicted_reduction_pct": self.predicted_reduction_pct,
                "u_found": self.u_found, "u_left": self.u_left, "u_predicted": self.u_predicted,
                "u_reduction_pct": self.u_reduction_pct, "gain": self.gain,
                "predicted_expected": _num(self.expected), "agrees": self.agrees,
                "flags": self.flags}


@dataclass(frozen=True)
class Drift:
    """x̄_left − x̄_predicted per target and direction (``residual``: compare's rows, A = predicted,
    B = left, with their U): ``range`` = max − min, the largest |difference| and where."""

    residual: PositioningComparison

    def _rows(self) -> list[Any]:
        return [t for t in self.residual.matched() if t.change is not None]

    @property
    def range(self) -> float | None:
        ch = [t.change for t in self._rows()]
        return max(ch) - min(ch) if ch else None

    @property
    def largest(self) -> Any:
        rows = self._rows()
        return max(rows, key=lambda t: abs(t.change)) if rows else None

    def text(self, unit: str) -> str:
        big = self.largest
        if big is None:
            return "drift between the runs: not evaluable"
        n_sig = sum(t.significant is True for t in self._rows())
        return (f"drift between the runs (x_left - x_predicted, range over targets and directions): {self.range:.3f} "
                f"{unit}; largest {big.change:+.3f} {unit} at {big.target:g} {self.residual.target_unit} "
                f"{'+' if big.direction > 0 else '-'}; {n_sig} of {len(self._rows())} larger than their U")

    def to_dict(self) -> dict[str, Any]:
        big = self.largest
        return {"range": self.range, "largest": None if big is None else big.change,
                "at_target": None if big is None else big.target,
                "direction": None if big is None else ("+" if big.direction > 0 else "-"),
                "significant": sum(t.significant is True for t in self._rows()), "of": len(self._rows()),
                "definition": "max - min over targets and directions of (as-left mean - predicted mean): the "
                              "change between the runs the table does not explain"}


@dataclass(frozen=True)
class BetweenPoints:
    """An as-left run on shifted targets (between the table's points): the error it leaves there against the
    export's leave-one-target-out residual of the model (exports.json; None when the table has no record).
    ``rms``, ``max_abs`` over every as-left point (each run, each direction), in the deviation unit."""

    shift: float
    rms: float
    max_abs: float
    points: int
    loto: dict[str, Any] | None

    def text(self, unit: str, target_unit: str) -> str:
        head = (f"error left between the table's points (targets shifted by {self.shift:g} {target_unit}): RMS "
                f"{self.rms:.3f}, max {self.max_abs:.3f} {unit} at {self.points} points")
        lo = self.loto
        if lo is None or lo.get("rms") is None:
            why = "no export record of the table" if lo is None else str(lo.get("unavailable"))
            return f"{head}; no leave-one-target-out prediction ({why})"
        return (f"{head}; leave-one-target-out predicted RMS {lo['rms']:.3f}, max {lo['max']:.3f} {unit} "
                f"({'within' if self.rms <= lo['rms'] else 'MORE than'} predicted)")

    def to_dict(self) -> dict[str, Any]:
        lo = self.loto or {}
        return {"shift": self.shift, "rms": self.rms, "max": self.max_abs, "points": self.points,
                "leave_one_target_out": None if self.loto is None else {k: lo.get(k) for k in
                                                                        ("rms", "max", "points", "unavailable")},
                "definition": "the as-left deviations at every point (compensated) against the export's "
                              "leave-one-target-out residual: the model refitted without each target, scored there"}


@dataclass(frozen=True)
class Verification:
    """The verify of AS_FOUND → table → AS_LEFT: the comparison found → left (compare's, for its table and
    overlay), the table check, the prediction and its comparison with AS_LEFT (the drift), the values."""

    comparison: Comparison
    table: TableCheck
    prediction: Prediction | None  # None on shifted targets (no prediction at the as-left targets)
    drift: Drift | None
    values: dict[str, ValueCheck]
    notes: tuple[str, ...]
    between: BetweenPoints | None = None  # an as-left run on shifted targets

    @property
    def found(self) -> RunIdentity:
        return self.comparison.a

    @property
    def left(self) -> RunIdentity:
        return self.comparison.b

    @property
    def detail(self) -> PositioningComparison:
        return self.comparison.detail  # type: ignore[return-value]

    @property
    def unit(self) -> str:
        return self.detail.unit

    def flagged(self) -> list[str]:
        return [q for q, v in self.values.items() if v.flags]

    def verdict(self) -> str:
        """One line: what the table did to E (or M for a one-direction run)."""
        q = "E" if _finite(self.values["E"].found) else "M"
        v = self.values[q]
        if v.reduction_pct is None:
            return f"{q} not evaluable in both runs"
        if self.between is not None:
            flags = f"; flagged: {'; '.join(v.flags)}" if v.flags else ""
            return (f"{q} {v.found:.3f} -> {v.left:.3f} {self.unit} ({v.reduction_pct:.1f} % smaller) between the "
                    f"table's points{flags}")
        agree = {True: "as predicted (within U)", False: "NOT as predicted (beyond U)", None: "(no U to judge the "
                 "prediction)"}[v.agrees]
        flags = f"; flagged: {'; '.join(v.flags)}" if v.flags else ""
        again = "" if v.expected is None else f", {v.expected:.3f} as a repeat measurement shows it"
        return (f"{q} {v.found:.3f} -> {v.left:.3f} {self.unit} ({v.reduction_pct:.1f} % smaller), predicted "
                f"{v.predicted:.3f}{again}: {agree}{flags}")

    def to_dict(self) -> dict[str, Any]:
        """The object ``guideway verify --json`` prints (docs/compensation.md)."""
        d = self.detail
        return {"found": self.found.to_dict(), "left": self.left.to_dict(), "table": self.table.to_dict(),
                "unit": d.unit, "target_unit": d.target_unit, "axis_type": d.a.result.axis_type, "k": d.k,
                "edition": d.a.result.edition, "values": {q: v.to_dict() for q, v in self.values.items()},
                "drift": None if self.drift is None else self.drift.to_dict(), "verdict": self.verdict(),
                "between_points": None if self.between is None else self.between.to_dict(),
                "targets": [] if self.drift is None else
                [self._target(t, p) for t, p in zip(d.targets, self.drift.residual.targets, strict=True)],
                "uncertainty": "u_found, u_left = standard uncertainty of each value from its run's repeated "
                               "approaches (parametric Monte Carlo); u_predicted, predicted_expected = the spread and "
                               "mean of the value a repeat measurement with the table shows (the as-found means' "
                               "noise carried into the prediction and the repeat's own); u of the reduction to first "
                               f"order; agrees = |left - predicted_expected| <= k * u_predicted, k = {d.k:g}",
                "notes": list(self.notes)}

    def _target(self, t: Any, p: Any) -> dict[str, Any]:
        return {f"target_{self.detail.target_unit}": t.target, "direction": "+" if t.direction > 0 else "-",
                "found": t.a.mean if t.a else None, "left": t.b.mean if t.b else None,
                "predicted": p.a.mean if p.a else None, "left_minus_predicted": p.change, "u": p.expanded}


def _left_record(run: LoadedRun) -> dict[str, Any]:
    rec = run_compensation(run.meta)
    if rec.get("active") is None:
        raise UserError(f"AS_LEFT {run.path} does not record which compensation table was active (a run from before "
                        "the tool recorded it): verify cannot check it; guideway compare shows the change")
    if not rec["active"]:
        raise UserError(f"AS_LEFT {run.path} was measured with no compensation table active (run.json compensation): "
                        "load the table and measure again (--compensation FILE), or use guideway compare")
    if stopped := live_compensation_stopped(run.meta):  # no gain is claimed from it
        raise UserError(f"AS_LEFT {run.path}: {stopped}")
    return rec


def _check_runs(found: LoadedRun, left: LoadedRun) -> list[str]:
    for label, run in (("AS_FOUND", found), ("AS_LEFT", left)):
        if run.kind != "positioning":
            raise UserError(f"{label} {run.path} is a {run.kind} run; verify needs two positioning runs (ISO 230-2) "
                            "of one axis")
    notes = check_comparable(found, left)
    ma, mb = str(found.meta.get("machine") or "").strip(), str(left.meta.get("machine") or "").strip()
    if ma and mb and ma != mb:
        raise UserError(f"AS_FOUND is of machine {ma!r}, AS_LEFT of {mb!r}: a table is verified on the machine it "
                        "was made for")
    return notes


def _same_targets(ef: PositioningEvaluation, el: PositioningEvaluation) -> None:
    """Refuse runs whose targets differ (matched as compare matches them)."""
    unit = ef.result.target_unit
    ta = ef.result.per_target["target"].to_numpy(dtype=float)
    tb = el.result.per_target["target"].to_numpy(dtype=float)
    only = [(t, "AS_FOUND" if j is None else "AS_LEFT") for t, i, j in match_targets(ta, tb, TARGET_TOLERANCE[unit])
            if i is None or j is None]
    if only:
        where = ", ".join(f"{t:g} (only {side})" for t, side in only[:4]) + (" ..." if len(only) > 4 else "")
        raise UserError(f"the runs' targets do not match ({len(only)} target(s) in one run only: {where} {unit}); "
                        "verify needs AS_LEFT measured on AS_FOUND's targets (the same set-up), or moved by "
                        "acquire --shift-targets S to measure between the table's points")


def verify_runs(found_dir: Path | str, left_dir: Path | str, **options: Any) -> Verification:
    """Verify ``left_dir`` (as-left) against ``found_dir`` (as-found); ``options``: the evaluator options of
    ``guideway process`` for both runs.  Anything that cannot be verified is a one-line UserError."""
    found, left = load_run(found_dir), load_run(left_dir)
    notes = _check_runs(found, left)
    record = _left_record(left)
    ef, el = evaluate_run(found, **options), evaluate_run(left, **options)
    assert isinstance(ef, PositioningEvaluation) and isinstance(el, PositioningEvaluation)
    shift = target_shift(left.meta)
    if shift:
        return _verify_shifted(found, left, ef, el, record, shift, notes)
    _same_targets(ef, el)
    detail = compare_positioning(ef, el)
    provenance = find_export(found.path, str(record.get("sha256")), found.meta.get("uid"))
    prediction = predict_as_left(ef, record)
    predicted = PositioningEvaluation(found, prediction.result, prediction.deviations, ef.environment)
    drift = Drift(compare_positioning(predicted, el))
    spread = {"found": axis_value_spread(ef.result), "left": axis_value_spread(el.result),
              "predicted": axis_value_spread(prediction.result, means_uncertain=True)}
    u = {k: v.u for k, v in spread.items()}
    values = {}
    for q in AXIS_QUANTITIES:
        values[q] = ValueCheck(q, _num(ef.result.axis[q]), _num(el.result.axis[q]), _num(prediction.result.axis[q]),
                               u["found"][q], u["left"][q], u["predicted"][q], ef.result.k,
                               _num(el.result.axis[REPEATABILITY_OF[q]]), drift.range,
                               spread["predicted"].expected[q])
    for label, run in (("AS_FOUND", found), ("AS_LEFT", left)):
        if run.meta.get("status") != "complete":
            notes.append(f"{label} is {run.meta.get('status')!r}: only its {len(run.points)} recorded point(s) are "
                         "used")
    notes += list(prediction.notes)
    comparison = Comparison("positioning", RunIdentity.of(found, ef), RunIdentity.of(left, el), detail, ())
    return Verification(comparison, TableCheck(record, provenance), prediction, drift, values, tuple(notes))


def target_shift(meta: dict[str, Any]) -> float:
    """run.json ``setup.shift_targets_mm`` (``_deg``): how far the run's targets were moved (0: not)."""
    setup = meta.get("setup") or {}
    v = setup.get("shift_targets_deg" if meta.get("axis_type") == "rotary" else "shift_targets_mm", 0.0)
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) else 0.0


def _verify_shifted(found: LoadedRun, left: LoadedRun, ef: PositioningEvaluation, el: PositioningEvaluation,
                    record: dict[str, Any], shift: float, notes: list[str]) -> Verification:
    """AS_LEFT measured between the table's points: the values of both runs (each over its own targets), and the
    error left there against the leave-one-target-out residual the export recorded."""
    import numpy as np

    provenance = find_export(found.path, str(record.get("sha256")), found.meta.get("uid"))
    dev = el.deviations["deviation"].to_numpy(float)
    loto = None if provenance is None else provenance.record.get("leave_one_target_out")
    between = BetweenPoints(shift, float(np.sqrt(np.mean(dev**2))), float(np.max(np.abs(dev))), len(dev), loto)
    u = {"found": axis_value_spread(ef.result).u, "left": axis_value_spread(el.result).u}
    values = {q: ValueCheck(q, _num(ef.result.axis[q]), _num(el.result.axis[q]), None, u["found"][q], u["left"][q],
                            None, ef.result.k, _num(el.result.axis[REPEATABILITY_OF[q]]), None)
              for q in AXIS_QUANTITIES}
    notes.append(f"AS_LEFT was measured on AS_FOUND's targets shifted by {shift:g} {ef.result.target_unit} (between "
                 "the table's points): no prediction per target there; each run's values cover its own targets")
    detail = PositioningComparison(ef, el, (), ())
    comparison = Comparison("positioning", RunIdentity.of(found, ef), RunIdentity.of(left, el), detail, ())
    return Verification(comparison, TableCheck(record, provenance), None, None, values, tuple(notes), between)
