"""Evaluation of a saved straightness run: geometry from run.json, processing,
result files and the printed summary."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from processing.decoupling import DEFAULT_METHOD
from processing.geometry import BlockGeometry
from processing.straightness import StraightnessResult, evaluate_straightness
from processing.uncertainty import UncertaintyInputs

from .errors import RunFormatError
from .runstore import LoadedRun


@dataclass(frozen=True)
class StraightnessEvaluation:
    run: LoadedRun
    result: StraightnessResult

    def to_dict(self) -> dict[str, Any]:
        return self.result.to_dict()

    def write(self, results_dir: Path) -> Path:
        from .results import write_straightness_results  # matplotlib only when writing

        return write_straightness_results(results_dir, self.result)

    def print_summary(self, stream: TextIO) -> None:
        r = self.result
        n = len(r.profile)
        span = float(r.profile["x_mm"].iloc[-1]) if n else 0.0
        print(f"stations: {n}, travel {span:g} mm, decoupling: {r.method}", file=stream)
        mc = r.uncertainty.to_dict().get("straightness", {}) if r.uncertainty else {}
        for name, value in r.straightness_um().items():
            unc = f" +/- {mc[name]:.3f} um (k = 2)" if name in mc else ""
            print(f"  straightness ({name.replace('_', ' ')} reference line): {value:.3f} um{unc}", file=stream)
        if r.wavelengths:
            w = r.wavelengths[0]
            print(f"  dominant wavelength: {w.wavelength_mm:.0f} mm, amplitude {w.amplitude_um:.3f} um", file=stream)
        if r.return_pass is not None:
            rp = r.return_pass
            closure = "n/a" if rp.closure_um is None else f"{rp.closure_um:.3f} um"
            drift = "n/a" if rp.drift_um_per_h is None else f"{rp.drift_um_per_h:.3f} um/h"
            print(f"  return pass: profile = mean of both passes; closure error {closure}, drift {drift}",
                  file=stream)


def evaluate_straightness_run(run: LoadedRun, *, method: str = DEFAULT_METHOD, mc_trials: int = 10_000,
                              mc_seed: int = 0) -> StraightnessEvaluation:
    """Evaluate a loaded straightness run (``mc_trials`` = 0 skips the Monte Carlo evaluation)."""
    try:
        geometry = BlockGeometry.from_dict(run.meta["setup"]["geometry"])
    except (KeyError, TypeError, ValueError) as exc:
        raise RunFormatError(f"{run.path}/run.json: invalid setup.geometry ({exc})") from exc
    if len(run.points) < 2:
        raise RunFormatError(f"{run.path}: {len(run.points)} point(s) recorded; need at least 2 to evaluate")
    try:
        inputs = UncertaintyInputs.from_dict(run.meta["setup"].get("uncertainty"))
    except ValueError as exc:
        raise RunFormatError(f"{run.path}/run.json: {exc}") from exc
    try:
        result = evaluate_straightness(run.points, geometry, method=method, uncertainty=inputs,
                                       mc_trials=mc_trials, mc_seed=mc_seed)
    except ValueError as exc:
        raise RunFormatError(f"{run.path}: {exc}") from exc
    return StraightnessEvaluation(run, result)
