"""Reading a run directory: :func:`load_run` validates run.json and points.csv of any supported
format version and returns the metadata and the points (numpy columns; a DataFrame on demand), or raises
:class:`~saved_runs.errors.RunFormatError` with a one-line reason.  A partial last line of
points.csv (a kill in the middle of a write) is ignored with a warning."""

from __future__ import annotations

import csv
import json
from array import array
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from processing.columns import OPTIONAL_DEFAULTS

from ..errors import RunFormatError
from .files import read_run_file
from .format import FORMAT, KINDS, SUPPORTED_VERSIONS, point_columns

if TYPE_CHECKING:  # pandas only when a reader asks for the DataFrame (``process`` of a straightness run does not)
    import pandas as pd

INTEGER_COLUMNS = ("station", "run", "direction", "target_index", "pass", "not_still")


@dataclass(frozen=True)
class LoadedRun:
    """A run directory read back: run.json and the points.

    ``columns``: points.csv column name -> read-only 1-D array (float64; int64 for the integer columns), in
    file order, absent optional columns appended with their default; ``points``: the same as a DataFrame,
    built (and pandas imported) on first use."""

    path: Path
    meta: dict[str, Any]
    columns: Mapping[str, np.ndarray]
    warnings: tuple[str, ...] = ()

    @property
    def kind(self) -> str:
        return str(self.meta["kind"])

    @cached_property
    def points(self) -> pd.DataFrame:
        import pandas as pd

        return pd.DataFrame({c: v.copy() for c, v in self.columns.items()}, columns=list(self.columns))

    @property
    def n_points(self) -> int:
        return len(next(iter(self.columns.values()), ()))


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


def _read_points(path: Path, columns: tuple[str, ...]) -> tuple[dict[str, np.ndarray], list[str]]:
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
    n = len(data[columns[0]]) if columns else 0
    cols: dict[str, np.ndarray] = {c: np.frombuffer(data[c], dtype=float) for c in columns}
    for c, v in defaults.items():
        cols[c] = np.full(n, v, dtype=np.asarray(v).dtype)
    for col in INTEGER_COLUMNS:
        if col in cols and cols[col].dtype.kind == "f":
            a = cols[col]
            if not np.all(np.isfinite(a) & (a == np.floor(a))):
                raise RunFormatError(f"{path}: column {col} must hold integers")
            cols[col] = a.astype(np.int64)
    if "not_still" in cols and not np.isin(cols["not_still"], (0, 1)).all():
        raise RunFormatError(f"{path}: column not_still must be 0 or 1")
    for v in cols.values():
        v.flags.writeable = False  # shared by every reader of the run: nobody changes the points read
    return cols, warnings
