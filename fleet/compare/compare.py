"""``compare_runs``: load two runs, check they may be compared, evaluate both exactly as ``guideway process``
does (the same evaluators and options, nothing written into the runs), and compare them."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from saved_runs.evaluation.evaluate import evaluate_run
from saved_runs.store.reader import LoadedRun, load_run

from .positioning import PositioningComparison, compare_positioning
from .runs import RunIdentity, check_comparable
from .straightness import StraightnessComparison, compare_straightness


@dataclass(frozen=True)
class Comparison:
    """Two runs (A before, B after) and their comparison of the kind both are."""

    kind: str
    a: RunIdentity
    b: RunIdentity
    detail: PositioningComparison | StraightnessComparison
    notes: tuple[str, ...]

    @property
    def runs(self) -> tuple[LoadedRun, LoadedRun]:
        return self.detail.a.run, self.detail.b.run

    def to_dict(self) -> dict[str, Any]:
        """The object ``guideway compare --json`` prints (docs/compare.md)."""
        return {"kind": self.kind, "a": self.a.to_dict(), "b": self.b.to_dict(), **self.detail.to_dict(),
                "notes": [*self.notes, *self.detail.notes]}

    def significant_count(self) -> tuple[int, int]:
        """(changes larger than their U, changes with a U)."""
        rows = [r for r in self.detail.matched() if r.significant is not None]
        return sum(bool(r.significant) for r in rows), len(rows)


def compare_runs(run_a: Path | str, run_b: Path | str, *, any_axis: bool = False, **options: Any) -> Comparison:
    """Compare ``run_a`` (before) with ``run_b`` (after).

    ``options`` are the evaluator options of ``guideway process`` (method, mc_trials, k, edition,
    accept_out_of_range), applied to both runs; ``any_axis`` compares runs that name different axes.
    Anything that cannot be compared is a one-line :class:`~saved_runs.errors.UserError`."""
    la, lb = load_run(run_a), load_run(run_b)
    notes = check_comparable(la, lb, any_axis=any_axis)
    ea, eb = evaluate_run(la, **options), evaluate_run(lb, **options)
    detail: PositioningComparison | StraightnessComparison
    if la.kind == "positioning":
        detail = compare_positioning(ea, eb)  # type: ignore[arg-type]
    else:
        detail = compare_straightness(ea, eb)  # type: ignore[arg-type]
    for label, run in (("A", la), ("B", lb)):
        if run.meta.get("status") != "complete":
            notes.append(f"run {label} is {run.meta.get('status')!r}: only its {len(run.points)} recorded point(s) "
                         "are compared")
    return Comparison(la.kind, RunIdentity.of(la, ea), RunIdentity.of(lb, eb), detail, tuple(notes))
