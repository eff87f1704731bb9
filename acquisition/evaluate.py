"""Process a saved run: load it, evaluate it, write the results."""

from __future__ import annotations

from pathlib import Path

from processing.geometry import BlockGeometry
from processing.straightness import StraightnessResult, evaluate_straightness

from .errors import RunFormatError
from .runstore import LoadedRun, load_run


def evaluate_run(run: LoadedRun, *, method: str = "first-order") -> StraightnessResult:
    """Evaluate a loaded straightness run."""
    if run.kind != "straightness":
        raise RunFormatError(f"{run.path}: cannot evaluate a {run.kind!r} run yet")
    try:
        geometry = BlockGeometry.from_dict(run.meta["setup"]["geometry"])
    except (KeyError, TypeError, ValueError) as exc:
        raise RunFormatError(f"{run.path}/run.json: invalid setup.geometry ({exc})") from exc
    if len(run.points) < 2:
        raise RunFormatError(f"{run.path}: {len(run.points)} point(s) recorded; need at least 2 to evaluate")
    try:
        return evaluate_straightness(run.points, geometry, method=method)
    except ValueError as exc:
        raise RunFormatError(f"{run.path}: {exc}") from exc


def process_run_dir(run_dir: Path | str, *, method: str = "first-order") -> tuple[LoadedRun, StraightnessResult]:
    """Load and evaluate ``run_dir``."""
    run = load_run(run_dir)
    return run, evaluate_run(run, method=method)
