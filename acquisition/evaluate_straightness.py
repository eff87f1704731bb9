"""Evaluation of a saved straightness run: geometry from run.json, processing,
result files and the printed summary."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from processing.geometry import BlockGeometry
from processing.straightness import StraightnessResult, evaluate_straightness

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
        for name, value in r.straightness_um().items():
            print(f"  straightness ({name.replace('_', ' ')} reference line): {value:.3f} um", file=stream)


def evaluate_straightness_run(run: LoadedRun, *, method: str = "first-order") -> StraightnessEvaluation:
    """Evaluate a loaded straightness run."""
    try:
        geometry = BlockGeometry.from_dict(run.meta["setup"]["geometry"])
    except (KeyError, TypeError, ValueError) as exc:
        raise RunFormatError(f"{run.path}/run.json: invalid setup.geometry ({exc})") from exc
    if len(run.points) < 2:
        raise RunFormatError(f"{run.path}: {len(run.points)} point(s) recorded; need at least 2 to evaluate")
    try:
        result = evaluate_straightness(run.points, geometry, method=method)
    except ValueError as exc:
        raise RunFormatError(f"{run.path}: {exc}") from exc
    return StraightnessEvaluation(run, result)
