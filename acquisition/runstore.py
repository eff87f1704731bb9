"""Crash-safe run directories (docs/run-format.md).

Writing: :class:`RunStore` is an engine subscriber.  ``run.json`` is always
replaced atomically (temp file, fsync, rename, fsync of the directory);
every point is appended to ``points.csv``, flushed and fsynced before the
engine continues, so a crash or kill loses at most the point being captured.
:meth:`RunStore.for_resume` reopens an interrupted run to append to it.

Reading: :func:`load_run` validates the directory and returns the metadata
and the points as a DataFrame, or raises :class:`RunFormatError` with a
one-line reason.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import secrets
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, TextIO

import pandas as pd

from processing.columns import (
    OPTIONAL_DEFAULTS,
    POSITIONING_LINEAR,
    POSITIONING_ROTARY,
    STRAIGHTNESS_POINTS_V2,
)

from .errors import RunFormatError

FORMAT = "guideway-run"
VERSION = 2
SUPPORTED_VERSIONS = (1, 2)
KINDS = ("straightness", "positioning")


def point_columns(kind: str, axis_type: str | None = None) -> tuple[str, ...]:
    """The points.csv columns of a run kind (and axis type for positioning runs), current version.

    Reading an older version, a column it lacks takes its default (``OPTIONAL_DEFAULTS``).
    """
    if kind == "straightness":
        return STRAIGHTNESS_POINTS_V2
    if kind == "positioning":
        if axis_type == "rotary":
            return POSITIONING_ROTARY
        if axis_type in (None, "linear"):
            return POSITIONING_LINEAR
        raise RunFormatError(f"unknown axis_type {axis_type!r} (use linear or rotary)")
    raise RunFormatError(f"unknown run kind {kind!r}")
STATUS_BY_EXIT = {"success": "complete", "abort": "aborted", "fail": "aborted"}


def utc_now_iso() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds").replace("+00:00", "Z")


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _create_temp(path: Path) -> tuple[int, str]:
    """A new temporary file next to ``path``, opened for writing, with the mode an ordinary
    ``open()`` gives (0666 less the user's umask): ``tempfile.mkstemp`` would make it 0600, and
    the rename would give results, reports and tables that mode."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
    for _ in range(100):
        tmp = str(path.parent / f".{path.name}.{secrets.token_hex(4)}.tmp")
        try:
            return os.open(tmp, flags, 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary file name next to {path}")  # pragma: no cover


def write_text_atomic(path: Path | str, text: str) -> None:
    """Replace ``path`` with ``text`` (UTF-8, ``\\n`` line ends): a temporary file in the same
    directory, fsynced, renamed over ``path``, directory fsynced.  A reader sees the old or the
    new file, never a half-written one."""
    path = Path(path)
    fd, tmp = _create_temp(path)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)


def write_json_atomic(path: Path | str, obj: Any) -> None:
    """Replace ``path`` with ``obj`` as JSON (no NaN), atomically (:func:`write_text_atomic`)."""
    write_text_atomic(path, json.dumps(obj, indent=2, allow_nan=False) + "\n")


def format_cell(value: Any) -> str:
    """CSV text of one value: ints as ints, floats round-trip exactly (repr)."""
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else "nan"
    return str(value)


class RunStore:
    """Engine subscriber that writes a run directory.

    ``header`` holds run.json's descriptive fields (machine, axis, operator,
    notes, setup, instruments); the store adds format, version, kind, status
    and timestamps.
    """

    def __init__(self, run_dir: Path | str, header: dict[str, Any]) -> None:
        self.run_dir = Path(run_dir)
        self.header = header
        self.meta: dict[str, Any] = {}
        self._csv: TextIO | None = None
        self._columns: tuple[str, ...] = ()
        self.points_written = 0
        self.loaded_points: list[dict[str, Any]] = []  # the points already on disk (resume)
        self._resuming = False
        self._prior_faults: list[str] = []
        self.progress_interval_s = 1.0
        self._last_meta_write = -math.inf

    def _write_meta(self) -> None:
        write_json_atomic(self.run_dir / "run.json", self.meta)
        self._last_meta_write = time.monotonic()

    @classmethod
    def for_resume(cls, run_dir: Path | str) -> RunStore:
        """A store that continues the interrupted run in ``run_dir`` (its points are kept).

        A partial last line of points.csv (a kill in the middle of a write) is cut off first.
        """
        run = load_run(run_dir)
        if run.meta.get("status") == "complete":
            raise RunFormatError(f"{run.path}: the run is already complete; nothing to resume")
        store = cls(run.path, {})
        store.meta = dict(run.meta)
        store._columns = point_columns(run.kind, run.meta.get("axis_type"))
        header = (run.path / "points.csv").read_text(encoding="utf-8").split("\n", 1)[0].split(",")
        if tuple(h.strip() for h in header) != store._columns:
            raise RunFormatError(f"{run.path}: points.csv was written by another format version; "
                                 "it cannot be resumed, start a new run")
        if run.warnings:  # the incomplete last line: rewrite the file without it
            store._rewrite_points(_complete_lines(run.path / "points.csv"))
        store.points_written = len(run.points)
        store.loaded_points = run.points.to_dict("records")
        store._prior_faults = list(run.meta.get("faults", []))
        store._resuming = True
        return store

    def prepare(self) -> None:
        """Create the directory; refuse one that already holds files."""
        if self.run_dir.exists():
            if not self.run_dir.is_dir():
                raise RunFormatError(f"{self.run_dir} exists and is not a directory; choose another --out")
            if any(self.run_dir.iterdir()):
                raise RunFormatError(f"{self.run_dir} is not empty; choose a new directory for the run")
        self.run_dir.mkdir(parents=True, exist_ok=True)

    def __call__(self, name: str, doc: dict[str, Any]) -> None:
        if name == "start":
            self._start(doc)
        elif name == "event":
            self._event(doc)
        elif name == "annotate":
            value = doc["value"]
            if doc["key"] == "faults":  # this session's faults after those of earlier sessions (resume)
                value = self._prior_faults + list(value)
            self.meta[doc["key"]] = value
            # progress after a point is already implied by the fsynced point: write it at most
            # every progress_interval_s (one atomic replace costs two fsyncs)
            if doc["key"] != "progress" or time.monotonic() - self._last_meta_write >= self.progress_interval_s:
                self._write_meta()
        elif name == "state" and doc.get("state") == "paused" and self.meta:
            self._write_meta()  # a paused run shows its current progress
        elif name == "retract":
            self._retract(doc["match"])
        elif name == "stop":
            self._stop(doc)

    def close(self) -> None:
        """Close the points file without ending the run (the run stays in progress)."""
        if self._csv is not None:
            self._csv.close()
            self._csv = None

    def _reopen_csv(self) -> None:
        self._csv = open(self.run_dir / "points.csv", "a", encoding="utf-8", newline="")  # noqa: SIM115

    def _rewrite_points(self, lines: list[str]) -> None:
        """Replace points.csv atomically with ``lines`` (header first)."""
        write_text_atomic(self.run_dir / "points.csv", "".join(line + "\n" for line in lines))

    def _retract(self, match: dict[str, Any]) -> None:
        """Withdraw the last point whose fields equal ``match`` (a redo); rewrites points.csv atomically."""
        if self._csv is not None:
            self._csv.close()
        lines = _complete_lines(self.run_dir / "points.csv")
        header = lines[0].split(",")
        want = {header.index(k): format_cell(v) for k, v in match.items()}
        for i in range(len(lines) - 1, 0, -1):
            cells = lines[i].split(",")
            if all(cells[j] == v for j, v in want.items()):
                del lines[i]
                break
        else:
            self._reopen_csv()
            raise RuntimeError(f"retract: no point matches {match}")
        self._rewrite_points(lines)
        self.points_written -= 1
        self._reopen_csv()

    def _start(self, doc: dict[str, Any]) -> None:
        if self._resuming:
            self.meta.update(status="in-progress", points=self.points_written)
            self.meta.pop("ended", None)
            self.meta.pop("end_reason", None)
            self.meta.setdefault("resumed", []).append({"at": utc_now_iso(), "points": self.points_written})
            self._write_meta()
            self._reopen_csv()
            return
        self.prepare()
        kind = doc["kind"]
        self._columns = point_columns(kind, self.header.get("axis_type"))
        self.meta = {
            "format": FORMAT,
            "version": VERSION,
            "kind": kind,
            "status": "in-progress",
            "created": utc_now_iso(),
            "uid": doc["uid"],
            **self.header,
            "points": 0,
        }
        self._write_meta()
        self._csv = open(self.run_dir / "points.csv", "w", encoding="utf-8", newline="")  # noqa: SIM115
        self._csv.write(",".join(self._columns) + "\n")
        self._sync_csv()
        _fsync_dir(self.run_dir)

    def _sync_csv(self) -> None:
        assert self._csv is not None
        self._csv.flush()
        os.fsync(self._csv.fileno())

    def _event(self, doc: dict[str, Any]) -> None:
        self._write_row(doc["data"])
        self._sync_csv()
        self.points_written += 1

    def record_many(self, rows: list[dict[str, Any]]) -> None:
        """Append ``rows`` with one flush and fsync at the end (a run generated at once, e.g. by
        ``guideway simulate``, where a crash loses nothing that cannot be generated again)."""
        for data in rows:
            self._write_row(data)
        self._sync_csv()
        self.points_written += len(rows)

    def _write_row(self, data: dict[str, Any]) -> None:
        if self._csv is None:
            raise RuntimeError("event before start")
        missing = [c for c in self._columns if c not in data]
        if missing:
            raise ValueError(f"record lacks columns {missing}")
        self._csv.write(",".join(format_cell(data[c]) for c in self._columns) + "\n")

    def _stop(self, doc: dict[str, Any]) -> None:
        if self._csv is not None:
            self._sync_csv()
            self._csv.close()
            self._csv = None
        self.meta.update(
            status=STATUS_BY_EXIT.get(doc["exit_status"], "aborted"),
            ended=utc_now_iso(),
            end_reason=doc.get("reason", ""),
            points=self.points_written,
        )
        self._write_meta()


def _complete_lines(path: Path) -> list[str]:
    """The lines of a points file that end with a newline (a partial last line is dropped)."""
    text = path.read_text(encoding="utf-8")
    return text[: text.rfind("\n") + 1].splitlines()


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
    if not meta_path.is_file():
        raise RunFormatError(f"{run_dir}: no run.json; this is not a run directory")
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
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
    points, warnings = _read_points(run_dir / "points.csv", point_columns(kind, meta.get("axis_type")))
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
    if not path.is_file():
        raise RunFormatError(f"{path.parent}: no points.csv")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise RunFormatError(f"{path}: not UTF-8 text ({exc})") from exc
    warnings = []
    if text and not text.endswith("\n"):
        # A crash between write and flush can leave a partial last line: drop it, say so.
        cut = text.rfind("\n") + 1
        warnings.append(f"{path.name}: ignored an incomplete last line ({text[cut:][:40]!r})")
        text = text[:cut]
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        raise RunFormatError(f"{path}: empty file (no header)")
    header = [h.strip() for h in rows[0]]
    # A column added by a later format version may be absent: it takes its documented default.
    defaults = {c: OPTIONAL_DEFAULTS[c] for c in columns if c not in header and c in OPTIONAL_DEFAULTS}
    columns = tuple(c for c in columns if c not in defaults)
    missing = [c for c in columns if c not in header]
    if missing:
        raise RunFormatError(f"{path}: missing column(s) {', '.join(missing)}")
    idx = [header.index(c) for c in columns]
    data: dict[str, list[float]] = {c: [] for c in columns}
    for lineno, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise RunFormatError(f"{path}:{lineno}: expected {len(header)} fields, found {len(row)}")
        for c, i in zip(columns, idx, strict=True):
            try:
                data[c].append(float(row[i]))
            except ValueError:
                raise RunFormatError(f"{path}:{lineno}: column {c} is not a number: {row[i]!r}") from None
    df = pd.DataFrame(data, columns=list(columns))
    for c, v in defaults.items():
        df[c] = v
    for col in ("station", "run", "direction", "target_index", "pass"):
        if col in df:
            if not all(float(v).is_integer() for v in df[col]):
                raise RunFormatError(f"{path}: column {col} must hold integers")
            df[col] = df[col].astype(int)
    return df, warnings
