"""The two runs of a comparison: which may be compared, and what each is (its identity in the output).

Refused with one line (exit 2): runs of different kinds, positioning runs of different axis types
(linear in µm against rotary in arcsec), runs that name different axes (unless the caller accepts it),
straightness runs stepped with different block lengths (their stations are not at the same places).
Different machines are allowed (a machine against its sister) and noted."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from saved_runs.errors import UserError
from saved_runs.report.common import simulated
from saved_runs.store.format import run_axis
from saved_runs.store.reader import LoadedRun


def axis_name(meta: dict[str, Any]) -> str:
    """The axis a run names (:func:`saved_runs.store.format.run_axis`), blanks stripped: compared, not stored."""
    return run_axis(meta).strip()


def check_comparable(run_a: LoadedRun, run_b: LoadedRun, *, any_axis: bool = False) -> list[str]:
    """Refuse two runs that cannot be compared (one-line :class:`UserError` saying what differs);
    return the notes on what differs but may be compared (machines)."""
    a, b = run_a.meta, run_b.meta
    if run_a.kind != run_b.kind:
        raise UserError(f"{run_a.path} is a {run_a.kind} run, {run_b.path} a {run_b.kind} run: compare needs two "
                        "runs of the same kind")
    if run_a.kind == "positioning":
        ta, tb = a.get("axis_type", "linear"), b.get("axis_type", "linear")
        if ta != tb:
            raise UserError(f"{run_a.path} is a {ta} axis, {run_b.path} a {tb} axis: their deviations are not in "
                            "the same unit; compare two runs of the same axis")
    name_a, name_b = axis_name(a), axis_name(b)
    if name_a and name_b and name_a.casefold() != name_b.casefold() and not any_axis:
        raise UserError(f"{run_a.path} is axis {name_a!r}, {run_b.path} axis {name_b!r}: compare runs of the same "
                        "axis, or pass --any-axis to compare them anyway")
    if run_a.kind == "straightness":
        la = (a.get("setup") or {}).get("block_length_mm")
        lb = (b.get("setup") or {}).get("block_length_mm")
        if isinstance(la, int | float) and isinstance(lb, int | float) and not math.isclose(la, lb, abs_tol=1e-6):
            raise UserError(f"{run_a.path} steps a {la:g} mm block, {run_b.path} a {lb:g} mm block: their stations "
                            "are not at the same places; compare runs made with the same block")
    notes = []
    ma, mb = str(a.get("machine") or "").strip(), str(b.get("machine") or "").strip()
    if ma and mb and ma != mb:
        notes.append(f"the runs are of different machines (A: {ma}, B: {mb})")
    if name_a and name_b and name_a.casefold() != name_b.casefold():
        notes.append(f"the runs name different axes (A: {name_a}, B: {name_b}); compared as asked (--any-axis)")
    return notes


@dataclass(frozen=True)
class RunIdentity:
    """What the comparison says of each run: where it is, what it is, how it ended, its verdict."""

    path: str
    uid: str
    kind: str
    machine: str
    axis: str
    created: str
    status: str
    points: int
    simulated: bool
    verdict: str | None  # pass / fail / not evaluated against the set-up's [tolerance]; None without one

    @staticmethod
    def of(run: LoadedRun, evaluation: Any) -> RunIdentity:
        m = run.meta
        verdict = getattr(evaluation, "verdict", None)
        return RunIdentity(str(run.path), str(m.get("uid") or ""), run.kind, str(m.get("machine") or ""),
                           axis_name(m), str(m.get("created") or ""), str(m.get("status") or ""), len(run.points),
                           simulated(m) is not None, None if verdict is None else verdict.result)

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)
