"""Evaluation of a saved straightness run: geometry from run.json, processing,
result files and the printed summary."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from processing.decoupling import DEFAULT_METHOD
from processing.geometry import BlockGeometry
from processing.straightness import StraightnessResult, evaluate_straightness
from processing.uncertainty import UncertaintyInputs

from ..errors import RunFormatError
from ..store.plan import check_straightness_points, gap_text, straightness_gaps
from ..store.reader import LoadedRun
from .limits import OutOfRange, out_of_range, out_of_range_dict, print_out_of_range

# the Monte Carlo defaults live in .options (no NumPy: the catalogue compares a summary's options with them)
from .options import MC_SAMPLE_BUDGET, MC_TRIALS, default_mc_trials  # noqa: F401
from .tolerance import DEFAULT_DECISION_RULE, Verdict, straightness_verdict, verdict_dict


@dataclass(frozen=True)
class StraightnessEvaluation:
    run: LoadedRun
    result: StraightnessResult
    out_of_range: tuple[OutOfRange, ...] = ()  # accepted with --accept-out-of-range (.limits)
    verdict: Verdict | None = None  # against the set-up's [tolerance] (.tolerance)
    gaps: tuple[tuple[int, int], ...] = ()  # planned (pass, station) steps neither on disk nor skipped

    def to_dict(self) -> dict[str, Any]:
        missing = {"missing_steps": {"steps": [{"pass": p, "station": k} for p, k in self.gaps],
                                     "text": gap_text(list(self.gaps))}} if self.gaps else {}
        return {**self.result.to_dict(), **verdict_dict(self.verdict), **out_of_range_dict(self.out_of_range),
                **missing}

    def write(self, results_dir: Path, *, plot: bool = True) -> Path:
        """results/ as one set; profile.png only with ``plot`` (matplotlib only then)."""
        from ..results.straightness import write_straightness_results

        # summary.json is this object, verdict included (the catalogue reads the verdict from it)
        return write_straightness_results(results_dir, self.result, self.to_dict(), plot=plot)

    def print_summary(self, stream: TextIO) -> None:
        r = self.result
        n = len(r.profile_columns["x_mm"])
        span = float(r.profile_columns["x_mm"][-1]) if n else 0.0
        print_out_of_range(self.out_of_range, stream)
        if self.gaps:
            print(f"warning: {self.run.path}/points.csv: {gap_text(list(self.gaps))}; the profile spans the "
                  "stations measured and no verdict can pass", file=stream)
        print(f"stations: {n}, travel {span:g} mm, decoupling: {r.method}", file=stream)
        mc = r.uncertainty.to_dict().get("straightness", {}) if r.uncertainty else {}
        for name, value in r.straightness_um().items():
            unc = f" +/- {mc[name]:.3f} um (k = 2)" if name in mc else ""
            print(f"  straightness ({name.replace('_', ' ')} reference line): {value:.3f} um{unc}", file=stream)
        if r.wavelengths:
            w = r.wavelengths[0]
            print(f"  dominant wavelength: {w.wavelength_mm:.0f} mm, amplitude {w.amplitude_um:.3f} um", file=stream)
        if r.datum is not None:
            print(f"  datum angles (laser frame): {datum_text(r)}", file=stream)
        if r.return_pass is not None:
            rp = r.return_pass
            closure = "n/a" if rp.closure_um is None else f"{rp.closure_um:.3f} um"
            drift = "n/a" if rp.drift_um_per_h is None else f"{rp.drift_um_per_h:.3f} um/h"
            print(f"  return pass: profile = mean of both passes; closure error {closure}, drift {drift}",
                  file=stream)
        if self.verdict is not None:
            print(self.verdict.text(), file=stream)


def datum_text(r: StraightnessResult) -> str:
    """The datum block's angles the exact method used, and where each came from, in one line."""
    d = r.datum
    assert d is not None
    values = {"roll": d.roll_urad, "yaw": d.yaw_urad, "pitch": d.pitch_urad}
    parts, assumed = [], []
    for axis in ("pitch", "roll", "yaw"):
        how = d.source[axis]
        if how == "assumed":
            assumed.append(f"{axis} 0")
        elif how == "estimated":
            u = f" (u = {r.datum_pitch_u_urad:.2f} urad)" if r.datum_pitch_u_urad is not None else ""
            parts.append(f"{axis} {values[axis]:.3f} urad estimated from the first step{u}")
        else:
            parts.append(f"{axis} {values[axis]:.3f} urad measured")
    if assumed:
        why = "no first step to estimate the pitch from" if d.source["pitch"] == "assumed" else "not measured"
        parts.append(f"{' and '.join(assumed)} assumed ({why})")
    return "; ".join(parts)


# The channels each decoupling method uses (docs/conventions.md); a NaN/inf there cannot be decoupled.
METHOD_COLUMNS: dict[str, tuple[str, ...]] = {
    "exact": ("x_mm", "lin_um", "stry_um", "strz_um", "pitch_urad", "yaw_urad", "roll_urad", "sensor_mm"),
    "first-order": ("x_mm", "stry_um", "pitch_urad", "roll_urad", "sensor_mm"),
    "patent": ("x_mm", "stry_um", "pitch_urad", "roll_urad", "sensor_mm"),
}


def check_finite(run: LoadedRun, method: str) -> None:
    """A one-line error naming the first point and channel that holds no finite value."""
    pts = run.columns
    for col in METHOD_COLUMNS.get(method, ()):
        values = np.asarray(pts[col], dtype=float)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            i = int(bad[0])
            where = f"station {int(pts['station'][i])}" + (" (return pass)" if "pass" in pts and int(pts["pass"][i])
                                                          else "")
            raise RunFormatError(
                f"{run.path}/points.csv: {where} has {col} = {values[bad[0]]} ({bad.size} such value(s)); "
                f"the {method} decoupling needs it - redo that station or remove its row"
            )


def run_geometry(run: LoadedRun) -> BlockGeometry:
    """The set-up geometry of a straightness run (run.json ``setup.geometry``); a one-line error if invalid."""
    try:
        return BlockGeometry.from_dict(run.meta["setup"]["geometry"])
    except KeyError:
        raise RunFormatError(f"{run.path}/run.json: no setup.geometry (where the mirror and the sensor sit on the "
                             "block); restore run.json from the run's original") from None
    except (TypeError, ValueError) as exc:
        raise RunFormatError(f"{run.path}/run.json: invalid setup.geometry ({exc}); fix or restore run.json") from None


def evaluate_straightness_run(run: LoadedRun, *, method: str = DEFAULT_METHOD, mc_trials: int | None = None,
                              mc_seed: int = 0, accept_out_of_range: bool = False,
                              progress: Callable[[int, int], None] | None = None,
                              decision_rule: str = DEFAULT_DECISION_RULE) -> StraightnessEvaluation:
    """Evaluate a loaded straightness run (``decision_rule``: of the ``[tolerance]`` verdict, .tolerance).

    ``mc_trials``: Monte Carlo trials for the straightness uncertainty; 0 skips it, None takes
    :func:`default_mc_trials` of the number of points.  Values outside the set-up's validation
    limits are refused unless ``accept_out_of_range`` (.limits).  ``progress(done, trials)``: after each
    chunk of Monte Carlo trials, the long part of a big run (a front end's progress display).
    """
    geometry = run_geometry(run)
    plan = check_straightness_points(run)
    gaps = straightness_gaps(run, plan)
    if run.n_points < 2:
        raise RunFormatError(f"{run.path}: {run.n_points} point(s) recorded; need at least 2 to evaluate")
    try:
        inputs = UncertaintyInputs.from_dict(run.meta["setup"].get("uncertainty"))
    except ValueError as exc:
        raise RunFormatError(f"{run.path}/run.json: {exc}") from exc
    accepted = out_of_range(run, accept=accept_out_of_range)
    check_finite(run, method)
    if mc_trials is None:
        mc_trials = default_mc_trials(run.n_points)
    try:
        result = evaluate_straightness(run.columns, geometry, method=method, uncertainty=inputs,
                                       mc_trials=mc_trials, mc_seed=mc_seed, mc_progress=progress)
    except ValueError as exc:
        raise RunFormatError(f"{run.path}: {exc}") from exc
    u = result.uncertainty.to_dict().get("straightness", {}) if result.uncertainty is not None else {}
    verdict = straightness_verdict(run.meta, f"{run.path}/run.json", result.straightness_um(), u,
                                   incomplete=gap_text(gaps) if gaps else "", rule=decision_rule)
    return StraightnessEvaluation(run, result, accepted, verdict, tuple(gaps))
