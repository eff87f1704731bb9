"""The saved runs in a folder (the TUI's run browser): one summary per run directory, from its
run.json alone, so a folder of long runs lists quickly."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..store.format import FORMAT  # the format's names only: the run browser's first paint loads no pandas


@dataclass(frozen=True)
class RunSummary:
    """What the run browser lists of one run directory; ``problem`` is set when run.json is unreadable."""

    path: Path
    kind: str = ""
    created: str = ""
    machine: str = ""
    axis: str = ""
    status: str = ""
    points: int = 0
    problem: str = ""

    @property
    def resumable(self) -> bool:
        """An aborted, crashed or interrupted run (anything started and not complete)."""
        return not self.problem and self.status != "complete"


def run_summary(run_dir: Path) -> RunSummary:
    """Summary of ``run_dir`` from its run.json (never raises for a bad file: ``problem`` says why)."""
    try:
        meta: Any = json.loads((run_dir / "run.json").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        return RunSummary(run_dir, problem=f"run.json unreadable ({exc.__class__.__name__})")
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        return RunSummary(run_dir, problem="not a guideway run")
    axis = meta.get("axis") or (meta.get("setup") or {}).get("axis_name") or ""
    points = meta.get("points", 0)
    return RunSummary(run_dir, kind=str(meta.get("kind", "")), created=str(meta.get("created", "")),
                      machine=str(meta.get("machine", "")), axis=str(axis), status=str(meta.get("status", "")),
                      points=points if isinstance(points, int) else 0)


def list_runs(folder: Path | str) -> list[RunSummary]:
    """Every run directory directly in ``folder`` (those holding a run.json), newest first; hidden ones
    (a ``.NAME.XXXXXXXX.partial`` import or simulation being written, or killed: saved_runs/store/whole.py)
    are not runs."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    runs = [run_summary(d) for d in sorted(folder.iterdir())
            if not d.name.startswith(".") and (d / "run.json").is_file()]
    return sorted(runs, key=lambda r: (r.created, r.path.name), reverse=True)
