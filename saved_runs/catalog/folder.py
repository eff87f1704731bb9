"""The saved runs in a folder (the TUI's run browser): one summary per run directory, from its
run.json and a plain reading of its points.csv (no pandas: a folder lists at once).

The points are counted on disk, not taken from run.json (which counts them only when a run ends):
an in-progress or interrupted run shows the points it holds.  points.csv is read with the checks of
the run reader (saved_runs/store/reader.py): a row with the wrong number of fields or a value that
is not a number marks the run *damaged*, whatever run.json's status says; a partial last line (a
kill in the middle of a write) is not damage.  A summary is kept while the files' size and time
stay the same, so a folder of long runs is read once.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import RunFormatError
from ..store.files import read_run_file  # O_NONBLOCK, regular files only: a FIFO never hangs the browser
from ..store.format import FORMAT, run_axis  # the format's names only: the run browser's first paint loads no pandas

DAMAGED = "damaged"


@dataclass(frozen=True)
class RunSummary:
    """What the run browser lists of one run directory; ``problem`` is set when run.json is unreadable
    or points.csv is damaged (``status`` is then ``damaged``)."""

    path: Path
    kind: str = ""
    created: str = ""
    machine: str = ""
    axis: str = ""
    status: str = ""
    points: int = 0  # points on disk (complete rows of points.csv)
    problem: str = ""
    planned: int | None = None  # points the set-up plans (None: unknown)

    @property
    def resumable(self) -> bool:
        """An aborted, crashed or interrupted run (anything started and not complete)."""
        return not self.problem and self.status != "complete"

    @property
    def points_text(self) -> str:
        """``18/20``: points on disk of those planned (or the count alone)."""
        return f"{self.points}/{self.planned}" if self.planned else str(self.points)


def planned_points(meta: dict[str, Any]) -> int | None:
    """Points the run's set-up plans: straightness stations (twice with a return pass); positioning
    targets x runs x 2 directions.  None when run.json does not say."""
    s = meta.get("setup")
    if not isinstance(s, dict):
        return None
    try:
        if meta.get("kind") == "positioning":
            targets = s.get("targets_mm", s.get("targets_deg"))
            return len(targets) * int(s.get("runs", 5)) * 2 if isinstance(targets, list) else None
        stations = s.get("stations")
        return int(stations) * (2 if s.get("return_pass") else 1) if isinstance(stations, int) else None
    except (TypeError, ValueError):
        return None


def points_on_disk(path: Path) -> tuple[int, str]:
    """(complete rows of points.csv, why it is damaged or ''); a missing file holds 0 points."""
    try:
        text = read_run_file(path).decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")
    except FileNotFoundError:
        return 0, ""
    except RunFormatError:  # a named pipe, a device: never read (it would hang the browser)
        return 0, "points.csv is not a regular file"
    except (OSError, UnicodeDecodeError) as exc:
        return 0, f"points.csv unreadable ({exc.__class__.__name__})"
    text = text[:text.rfind("\n") + 1]  # a partial last line is a kill mid-write, not damage
    rows = csv.reader(io.StringIO(text))
    header = next(rows, None)
    if header is None:
        return 0, ""
    n = 0
    for lineno, row in enumerate(rows, start=2):
        if len(row) != len(header):
            return n, f"points.csv line {lineno}: {len(row)} fields, the header has {len(header)}"
        for name, cell in zip(header, row, strict=True):
            try:
                float(cell)
            except ValueError:
                return n, f"points.csv line {lineno}: {name.strip()} is not a number ({cell[:20]!r})"
        n += 1
    return n, ""


_CACHE: dict[Path, tuple[tuple[int, ...], RunSummary]] = {}


def files_stamp(run_dir: Path, names: tuple[str, ...] = ("run.json", "points.csv")) -> tuple[int, ...]:
    """Modification time (ns) and size of each of ``names`` in ``run_dir`` ((0, -1) for one that is missing):
    a cached reading of those files is still good while the stamp is the same."""
    out: list[int] = []
    for name in names:
        try:
            st = (run_dir / name).stat()
            out += [st.st_mtime_ns, st.st_size]
        except OSError:
            out += [0, -1]
    return tuple(out)


def run_summary(run_dir: Path) -> RunSummary:
    """Summary of ``run_dir`` (never raises for a bad file: ``problem`` says why)."""
    stamp = files_stamp(run_dir)
    cached = _CACHE.get(run_dir)
    if cached is not None and cached[0] == stamp:
        return cached[1]
    summary = _summary(run_dir)
    _CACHE[run_dir] = (stamp, summary)
    return summary


def _summary(run_dir: Path) -> RunSummary:
    try:
        meta: Any = json.loads(read_run_file(run_dir / "run.json").decode("utf-8"))
    except RunFormatError:
        return RunSummary(run_dir, status=DAMAGED, problem="run.json is not a regular file")
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        return RunSummary(run_dir, status=DAMAGED, problem=f"run.json unreadable ({exc.__class__.__name__})")
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        return RunSummary(run_dir, status=DAMAGED, problem="not a guideway run")
    axis = run_axis(meta)
    points, damage = points_on_disk(run_dir / "points.csv")
    status = str(meta.get("status", ""))
    recorded = meta.get("points")
    if not damage and status == "complete" and isinstance(recorded, int) and recorded != points:
        damage = f"points.csv holds {points} points, run.json {recorded}"
    planned = planned_points(meta)
    return RunSummary(run_dir, kind=str(meta.get("kind", "")), created=str(meta.get("created", "")),
                      machine=str(meta.get("machine", "")), axis=str(axis),
                      status=DAMAGED if damage else status, points=points, problem=damage,
                      planned=planned if planned is None or math.isfinite(planned) else None)


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
