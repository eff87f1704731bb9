"""The points of a run against its own plan (run.json ``setup``): nothing silently wrong.

A point the plan cannot have produced - a station outside 0 … stations − 1, a return-pass point in a
run without one, an ``x_mm`` that is not the station's nominal position k × L, a positioning
``target_index`` outside the set-up's targets or a target value that is not that target's, a step on
disk twice - is refused with one line naming the file, the line and the column: evaluating it would
give a number without saying it is wrong, and resuming it would mark a damaged run complete.

A planned step that is neither on disk nor recorded as skipped is a gap: the run is evaluated, the gap
is stated, and no verdict can be PASS (:func:`straightness_gaps`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..errors import RunFormatError
from .reader import LoadedRun

X_TOLERANCE_MM = 1e-6  # x_mm is written as k * L (exactly round-trip): allow float rounding only
TARGET_TOLERANCE = 1e-9  # mm or deg: target_mm is written as the set-up's target itself
# The documented maximum of setup.stations (docs/acquisition.md "Sizes"; acquisition/setup/maxima.py, which
# this layer may not import; tests/saved_runs/test_plan_in_run_json.py holds the two equal): a damaged
# run.json with 10^30 stations is refused before its steps are listed, not a process killed for memory.
STATIONS_MAX = 100_000


def _positive_number(meta_path: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not (math.isfinite(value) and value > 0):
        raise RunFormatError(f"{meta_path}: setup.{key} must be a positive number, got {value!r}; "
                             "fix or restore run.json")
    return float(value)


def _positive_int(meta_path: str, key: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise RunFormatError(f"{meta_path}: setup.{key} must be a positive whole number, got {value!r}; "
                             "fix or restore run.json")
    return value


@dataclass(frozen=True)
class StraightnessPlan:
    """What a straightness run's set-up planned: L (mm), the stations, the return pass."""

    block_length_mm: float | None
    stations: int | None
    return_pass: bool

    def steps(self) -> list[tuple[int, int]]:
        """The planned (pass, station) steps; empty when run.json gives no station count."""
        if self.stations is None:
            return []
        fwd = [(0, k) for k in range(self.stations)]
        return fwd + ([(1, k) for k in range(self.stations - 1, -1, -1)] if self.return_pass else [])


def straightness_plan(run: LoadedRun) -> StraightnessPlan:
    """run.json ``setup.block_length_mm``, ``stations``, ``return_pass``, checked (absent keys: not checked)."""
    setup = run.meta.get("setup") or {}
    where = f"{run.path}/run.json"
    length = _positive_number(where, "block_length_mm", setup["block_length_mm"]) \
        if "block_length_mm" in setup else None
    stations = _positive_int(where, "stations", setup["stations"]) if "stations" in setup else None
    if stations is not None and stations > STATIONS_MAX:
        raise RunFormatError(f"{where}: setup.stations = {stations} is beyond the maximum of {STATIONS_MAX} "
                             "stations (docs/acquisition.md, Sizes); fix or restore run.json")
    return StraightnessPlan(length, stations, bool(setup.get("return_pass", False)))


def _line(i: int) -> int:
    """The points.csv line of data row ``i`` (the header is line 1)."""
    return i + 2


def _check_skipped(run: LoadedRun) -> None:
    """run.json ``skipped``: each ``{"station": k, "pass": 0|1, ...}`` (version 1: no ``pass``, the forward
    pass); a damaged record is one line, not a traceback when the gaps or the resume point are worked out."""
    skipped = run.meta.get("skipped") or []
    for i, s in enumerate(skipped if isinstance(skipped, list) else []):
        station = s.get("station") if isinstance(s, dict) else None
        p = s.get("pass", 0) if isinstance(s, dict) else None
        if not (isinstance(station, int) and not isinstance(station, bool)) or p not in (0, 1) \
                or isinstance(p, bool):
            raise RunFormatError(f"{run.path}/run.json: skipped[{i}] must be {{\"station\": k, \"pass\": 0 or 1, "
                                 f"\"reason\": ...}}, got {s!r:.60}; fix or restore run.json")


def check_straightness_points(run: LoadedRun) -> StraightnessPlan:
    """Refuse a point outside the plan (one line: file, line, column); return the plan."""
    plan = straightness_plan(run)
    _check_skipped(run)
    csv_path = f"{run.path}/points.csv"
    seen: dict[tuple[int, int], int] = {}
    pts = run.columns
    passes = pts["pass"].tolist() if "pass" in pts else [0] * run.n_points
    for i, (k, p, x) in enumerate(zip(pts["station"].tolist(), passes, pts["x_mm"].tolist(), strict=True)):
        line = _line(i)
        if plan.stations is not None and not 0 <= k < plan.stations:
            raise RunFormatError(f"{csv_path}:{line}: column station = {k} is outside the plan (stations 0 to "
                                 f"{plan.stations - 1}, run.json setup.stations = {plan.stations}); remove the row "
                                 "or restore the file")
        if p not in (0, 1) or (p == 1 and not plan.return_pass):
            has = "a forward and a return pass (0 and 1)" if plan.return_pass else "no return pass (0 only)"
            raise RunFormatError(f"{csv_path}:{line}: column pass = {p}, but the run has {has}; remove the row "
                                 "or restore the file")
        if plan.block_length_mm is not None:
            nominal = k * plan.block_length_mm
            if not (math.isfinite(x) and abs(x - nominal) <= X_TOLERANCE_MM * max(1.0, abs(nominal))):
                raise RunFormatError(f"{csv_path}:{line}: column x_mm = {x:g} mm, but station {k} lies at "
                                     f"{k} x {plan.block_length_mm:g} = {nominal:g} mm (run.json "
                                     "setup.block_length_mm); restore the file")
        if (p, k) in seen:
            raise RunFormatError(f"{csv_path}:{line}: column station = {k}{' (return pass)' if p else ''} is on disk "
                                 f"twice (first on line {seen[(p, k)]}); remove one of the rows")
        seen[(p, k)] = line
    return plan


def straightness_gaps(run: LoadedRun, plan: StraightnessPlan) -> list[tuple[int, int]]:
    """The planned (pass, station) steps with no point on disk and no ``skipped`` record, in plan order."""
    pts = run.columns
    passes = pts["pass"].tolist() if "pass" in pts else [0] * run.n_points
    done = set(zip(passes, pts["station"].tolist(), strict=True))
    for s in run.meta.get("skipped") or []:
        if isinstance(s, dict) and isinstance(s.get("station"), int):
            done.add((int(s.get("pass", 0)), int(s["station"])))
    return [s for s in plan.steps() if s not in done]


def gap_text(gaps: list[tuple[int, int]]) -> str:
    """``station 17 missing`` / ``stations 3, 17 (return pass) missing`` (first ten)."""
    names = [f"{k}{' (return pass)' if p else ''}" for p, k in gaps[:10]]
    more = f" and {len(gaps) - 10} more" if len(gaps) > 10 else ""
    return (f"{'station' if len(gaps) == 1 else 'stations'} {', '.join(names)}{more} not measured and not "
            "recorded as skipped")


def check_positioning_points(run: LoadedRun) -> None:
    """Refuse a point outside the positioning set-up: target_index beyond its targets, a target value
    that is not that target's, a run beyond ``setup.runs``, a direction other than +1/-1, a stop twice."""
    setup = run.meta.get("setup") or {}
    unit = "deg" if run.meta.get("axis_type") == "rotary" else "mm"
    csv_path = f"{run.path}/points.csv"
    targets = setup.get(f"targets_{unit}")
    if targets is not None and not (isinstance(targets, list) and targets
                                    and all(isinstance(t, int | float) and not isinstance(t, bool)
                                            and math.isfinite(t) for t in targets)):
        raise RunFormatError(f"{run.path}/run.json: setup.targets_{unit} must be a list of numbers; "
                             "fix or restore run.json")
    runs = _positive_int(f"{run.path}/run.json", "runs", setup["runs"]) if "runs" in setup else None
    pts = run.columns
    seen: dict[tuple[int, int, int], int] = {}
    cols = zip(pts["run"].tolist(), pts["direction"].tolist(), pts["target_index"].tolist(),
               pts[f"target_{unit}"].tolist(), strict=True)
    for i, (r, d, ti, target) in enumerate(cols):
        line = _line(i)
        if d not in (1, -1):
            raise RunFormatError(f"{csv_path}:{line}: column direction = {d}; it must be +1 or -1")
        if targets is not None:
            if not 1 <= ti <= len(targets):
                raise RunFormatError(f"{csv_path}:{line}: column target_index = {ti} is outside the set-up "
                                     f"(targets 1 to {len(targets)}, run.json setup.targets_{unit}); remove the "
                                     "row or restore the file")
            if not abs(target - targets[ti - 1]) <= TARGET_TOLERANCE * max(1.0, abs(targets[ti - 1])):
                raise RunFormatError(f"{csv_path}:{line}: column target_{unit} = {target:g}, but target {ti} of "
                                     f"the set-up is {targets[ti - 1]:g} {unit}; restore the file")
        if runs is not None and not 1 <= r <= runs:
            raise RunFormatError(f"{csv_path}:{line}: column run = {r} is outside the set-up (runs 1 to {runs}, "
                                 "run.json setup.runs); remove the row or restore the file")
        key = (r, d, ti)
        if key in seen:
            raise RunFormatError(f"{csv_path}:{line}: run {r}, direction {d:+d}, target {ti} is on disk twice "
                                 f"(first on line {seen[key]}); remove one of the rows")
        seen[key] = line


def check_points_against_plan(run: LoadedRun) -> None:
    """:func:`check_straightness_points` or :func:`check_positioning_points`, by the run's kind."""
    if run.kind == "straightness":
        check_straightness_points(run)
    elif run.kind == "positioning":
        check_positioning_points(run)
