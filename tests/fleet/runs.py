"""Run directories for the catalogue tests, written here: run.json and points.csv in the run format
(docs/run-format.md) and results/summary.json with values the test chooses."""

from __future__ import annotations

import json
import os
import uuid
from pathlib import Path
from typing import Any


def straightness_summary(mz_um: float, u_mz_um: float, k: float = 2.0) -> dict[str, Any]:
    """A ``process --json`` object of a straightness run: values per line, U = k u."""
    lines = {"endpoint": mz_um + 0.5, "least_squares": mz_um + 0.25, "minimum_zone": mz_um}
    return {"kind": "straightness", "straightness_um": lines,
            "uncertainty_um": {"k": k, "straightness": dict.fromkeys(lines, k * u_mz_um)}, "verdict": None}


def positioning_summary(values: dict[str, float], verdict: str | None = None) -> dict[str, Any]:
    return {"kind": "positioning", "unit": "um", "iso230_2": values,
            "verdict": None if verdict is None else {"result": verdict, "checks": []}}


def write_run(folder: Path, name: str, *, kind: str = "straightness", created: str = "2026-01-01T00:00:00Z",
              machine: str = "mill-1", axis: str = "X", uid: str | None = None, status: str = "complete",
              summary: dict[str, Any] | None = None, tolerance: dict[str, Any] | None = None) -> Path:
    """A run directory ``folder/name``; with ``summary``, results/summary.json written after the run's files."""
    run = folder / name
    (run / "results").mkdir(parents=True, exist_ok=True)
    meta = {"format": "guideway-run", "version": 2, "kind": kind, "status": status, "created": created,
            "uid": uid or uuid.uuid4().hex, "machine": machine, "axis": axis,
            "setup": {"tolerance": tolerance} if tolerance else {}}
    (run / "run.json").write_text(json.dumps(meta), encoding="utf-8")
    (run / "points.csv").write_text("station,x_mm\n0,0.0\n", encoding="utf-8")
    if summary is not None:
        out = run / "results" / "summary.json"
        out.write_text(json.dumps(summary), encoding="utf-8")
        later = max((run / f).stat().st_mtime_ns for f in ("run.json", "points.csv")) + 1_000_000
        os.utime(out, ns=(later, later))
    return run
