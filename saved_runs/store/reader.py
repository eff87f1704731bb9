"""Reading a run directory: :func:`load_run` validates run.json and points.csv of any supported
format version and returns the metadata and the points as a DataFrame, or raises
:class:`~saved_runs.errors.RunFormatError` with a one-line reason.  A partial last line of
points.csv (a kill in the middle of a write) is ignored with a warning."""

from __future__ import annotations

import csv
import json
from array import array
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from processing.columns import OPTIONAL_DEFAULTS

from ..errors import RunFormatError
from .files import read_run_file
from .format import FORMAT, KINDS, SUPPORTED_VERSIONS, point_columns

if TYPE_CHECKING:  # pandas when points are read, not when the set-up loaders import LoadedRun
    import pandas as pd


@dataclass(frozen=True)
class LoadedRun:
    """A run directory read back: run.json and the points."""

    path: Path
    meta: dict[str, Any]
    points: pd.DataFrame
    warnings: tuple[str, ...] = ()

    @property
    def kind(self) -> str:
        return str(self.meta["kind"])


def load_run(run_dir: Path | str) -> LoadedRun:
    """Read and validate a run directory of any supported format version."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise RunFormatError(f"{run_dir}: no such run directory")
    meta_path = run_dir / "run.json"
    try:
        raw = read_run_file(meta_path)
    except FileNotFoundError:
        raise RunFormatError(f"{run_dir}: no run.json; this is not a run directory") from None
    except OSError as exc:
        raise RunFormatError(f"{meta_path}: cannot be read ({exc.strerror or exc})") from None
    try:
        meta = json.loads(raw.decode("utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise RunFormatError(f"{meta_path}: not valid JSON ({exc})") from exc
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise RunFormatError(f"{meta_path}: not a guideway run (\"format\" must be \"{FORMAT}\")")
    version = meta.get("version")
    if version not in SUPPORTED_VERSIONS:
        raise RunFormatError(
            f"{meta_path}: run format version {version!r} is not supported by this tool "
            f"(supports {', '.join(map(str, SUPPORTED_VERSIONS))}); upgrade guideway"
        )
    kind = meta.get("kind")
    if kind not in KINDS:
        raise RunFormatError(f"{meta_path}: unknown run kind {kind!r}")
    _check_meta_types(meta, meta_path)
    try:
        columns = point_columns(kind, meta.get("axis_type"))
    except RunFormatError as exc:
        raise RunFormatError(f"{meta_path}: {exc}; fix or restore run.json") from None
    points, warnings = _read_points(run_dir / "points.csv", columns)
    return LoadedRun(run_dir, meta, points, tuple(warnings))


# Types of the run.json keys every reader relies on (absent keys are allowed).
META_TYPES: dict[str, tuple[type, ...]] = {
    "status": (str,), "created": (str,), "ended": (str,), "end_reason": (str,), "uid": (str,),
    "machine": (str,), "axis": (str,), "operator": (str,), "notes": (str,), "points": (int,),
    "setup": (dict,), "instruments": (dict,), "axis_type": (str,),
}


def _check_meta_types(meta: dict[str, Any], meta_path: Path) -> None:
    """A hand-edited run.json with a key of the wrong type is refused in one line, not a traceback later."""
    for key, types in META_TYPES.items():
        if key in meta and meta[key] is not None and not isinstance(meta[key], types):
            raise RunFormatError(f"{meta_path}: {key!r} must be {' or '.join(t.__name__ for t in types)}, "
                                 f"got {type(meta[key]).__name__} {meta[key]!r:.40}; fix or restore run.json")
    for role, info in (meta.get("instruments") or {}).items():
        if not isinstance(info, dict):
            raise RunFormatError(f"{meta_path}: instruments.{role} must be an object, got {info!r:.40}")


def _read_points(path: Path, columns: tuple[str, ...]) -> tuple[pd.DataFrame, list[str]]:
    try:
        # (universal newlines, as read_text gave: a points.csv saved with CRLF reads the same)
        text = read_run_file(path).decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")
    except FileNotFoundError:
        raise RunFormatError(f"{path.parent}: no points.csv") from None
    except OSError as exc:
        raise RunFormatError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise RunFormatError(f"{path}: not UTF-8 text ({exc})") from exc
    warnings = []
    if text and not text.endswith("\n"):
        # A crash between write and flush can leave a partial last line: drop it, say so.
        cut = text.rfind("\n") + 1
        warnings.append(f"{path.name}: ignored an incomplete last line ({text[cut:][:40]!r})")
        text = text[:cut]
    # row by row into float arrays: a 100 000-point run as a list of rows of strings took ~230 MB
    lines = text.splitlines()
    del text
    rows = csv.reader(lines)
    first = next(rows, None)
    if first is None:
        raise RunFormatError(f"{path}: empty file (no header)")
    header = [h.strip() for h in first]
    # A column added by a later format version may be absent: it takes its documented default.
    defaults = {c: OPTIONAL_DEFAULTS[c] for c in columns if c not in header and c in OPTIONAL_DEFAULTS}
    columns = tuple(c for c in columns if c not in defaults)
    missing = [c for c in columns if c not in header]
    if missing:
        raise RunFormatError(f"{path}: missing column(s) {', '.join(missing)}")
    idx = [header.index(c) for c in columns]
    data: dict[str, array[float]] = {c: array("d") for c in columns}
    for lineno, row in enumerate(rows, start=2):
        if len(row) != len(header):
            raise RunFormatError(f"{path}:{lineno}: expected {len(header)} fields, found {len(row)}")
        for c, i in zip(columns, idx, strict=True):
            try:
                data[c].append(float(row[i]))
            except ValueError:
                raise RunFormatError(f"{path}:{lineno}: column {c} is not a number: {row[i]!r}") from None
    import pandas as pd

    df = pd.DataFrame({c: np.frombuffer(data[c], dtype=float) for c in columns}, columns=list(columns))
    for c, v in defaults.items():
        df[c] = v
    for col in ("station", "run", "direction", "target_index", "pass", "not_still"):
        if col in df:
            if not all(float(v).is_integer() for v in df[col]):
                raise RunFormatError(f"{path}: column {col} must hold integers")
            df[col] = df[col].astype(int)
    if "not_still" in df and not df["not_still"].isin((0, 1)).all():
        raise RunFormatError(f"{path}: column not_still must be 0 or 1")
    return df, warnings
