"""Process a saved run: load it, pick the evaluator for its kind, evaluate.

An evaluator takes a :class:`~saved_runs.store.reader.LoadedRun` and returns an
object with ``to_dict()`` (the ``guideway process --json`` object),
``write(results_dir)`` and ``print_summary(stream)``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, TextIO

from ..errors import RunFormatError, UserError
from ..store.reader import LoadedRun, load_run


class Evaluation(Protocol):
    def to_dict(self) -> dict[str, Any]: ...

    def write(self, results_dir: Path, *, plot: bool = True) -> Path: ...

    def print_summary(self, stream: TextIO) -> None: ...


def _straightness(run: LoadedRun, **options: Any) -> Evaluation:
    from .straightness import evaluate_straightness_run

    return evaluate_straightness_run(run, **options)


def _positioning(run: LoadedRun, **options: Any) -> Evaluation:
    from .positioning import evaluate_positioning_run  # pandas and the ISO 230-2 code: only for these runs

    return evaluate_positioning_run(run, **options)


EVALUATORS: dict[str, Callable[..., Evaluation]] = {
    "straightness": _straightness,
    "positioning": _positioning,
}


# The options each evaluator takes (command-line flags --method, --mc-trials, --k, --edition,
# --accept-out-of-range, --decision-rule).
EVALUATOR_OPTIONS: dict[str, tuple[str, ...]] = {
    "straightness": ("method", "mc_trials", "accept_out_of_range", "decision_rule"),
    "positioning": ("k", "edition", "accept_out_of_range", "decision_rule"),
}


def option_flags(names: Any) -> str:
    return ", ".join(f"--{n.replace('_', '-')}" for n in names)


def evaluate_run(run: LoadedRun, *, progress: Callable[[int, int], None] | None = None,
                 **options: Any) -> Evaluation:
    """Evaluate a loaded run with the evaluator for its kind.

    ``options`` that are None are left out; one that the run's kind does not take is a
    one-line :class:`UserError` (e.g. ``--method`` on a positioning run).  ``progress(done, total)``:
    the straightness evaluator's Monte Carlo trials (the long part of a big run; a positioning
    evaluation is quick and reports nothing)."""
    try:
        evaluator = EVALUATORS[run.kind]
    except KeyError:
        raise RunFormatError(f"{run.path}: no evaluator for {run.kind!r} runs in this version") from None
    options = {k: v for k, v in options.items() if v is not None}
    wrong = [k for k in options if k not in EVALUATOR_OPTIONS[run.kind]]
    if wrong:
        raise UserError(f"{option_flags(wrong)}: not an option for {run.kind} runs ({run.path} is one; "
                        f"they take {option_flags(EVALUATOR_OPTIONS[run.kind])})")
    if progress is not None and run.kind == "straightness":
        options["progress"] = progress
    return evaluator(run, **options)


def process_run_dir(run_dir: Path | str, *, progress: Callable[[int, int], None] | None = None,
                    **options: Any) -> tuple[LoadedRun, Evaluation]:
    """Load and evaluate ``run_dir`` (``progress``: as :func:`evaluate_run`)."""
    run = load_run(run_dir)
    return run, evaluate_run(run, progress=progress, **options)
