"""Writing a run directory: :class:`RunStore` is an engine subscriber (docs/run-format.md).

``run.json`` is always replaced atomically (:mod:`.files`); every point is appended to
``points.csv``, flushed and fsynced before the engine continues, so a crash or kill loses at most
the point being captured.  :meth:`RunStore.for_resume` reopens an interrupted run to append to it.

points.csv is created with O_EXCL and appended to with O_NOFOLLOW: a link planted in its place (to make
the writer append to another file) is refused, never followed (docs/reliability.md).
"""

from __future__ import annotations

import errno
import math
import os
import stat
import time
from pathlib import Path
from typing import Any, TextIO

from processing.columns import OPTIONAL_DEFAULTS

from ..errors import FileWriteError, RunFormatError, UnsafeFileError, file_kind
from .files import fsync_dir, write_json_atomic, write_text_atomic
from .format import FORMAT, VERSION, format_cell, point_columns, utc_now_iso
from .lock import make_run_dir
from .plan import check_points_against_plan
from .reader import load_run

STATUS_BY_EXIT = {"success": "complete", "abort": "aborted", "fail": "aborted"}


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
        write_json_atomic(self.run_dir / "run.json", self.meta, inside=self.run_dir)
        self._last_meta_write = time.monotonic()

    @classmethod
    def for_resume(cls, run_dir: Path | str) -> RunStore:
        """A store that continues the interrupted run in ``run_dir`` (its points are kept).

        A partial last line of points.csv (a kill in the middle of a write) is cut off first.
        """
        for name in ("run.json", "points.csv"):  # the files it writes: not read through a planted link either
            try:
                mode = os.stat(Path(run_dir) / name, follow_symlinks=False).st_mode
            except OSError:
                continue  # missing: load_run says so
            if not stat.S_ISREG(mode):
                raise UnsafeFileError(Path(run_dir) / name, file_kind(mode))
        run = load_run(run_dir)
        if run.meta.get("status") == "complete":
            raise RunFormatError(f"{run.path}: the run is already complete; nothing to resume")
        check_points_against_plan(run)  # a point outside the plan is not continued (and marked complete)
        store = cls(run.path, {})
        store.meta = dict(run.meta)
        store._columns = point_columns(run.kind, run.meta.get("axis_type"))
        header = tuple(h.strip() for h in
                       (run.path / "points.csv").read_text(encoding="utf-8").split("\n", 1)[0].split(","))
        added = [c for c in store._columns if c not in header]
        if header != store._columns and (tuple(c for c in store._columns if c in header) != header
                                         or not all(c in OPTIONAL_DEFAULTS for c in added)):
            raise RunFormatError(f"{run.path}: points.csv was written by another format version; "
                                 "it cannot be resumed, start a new run")
        if added:  # written before a column existed (not_still): the file gains it with its default
            lines = _complete_lines(run.path / "points.csv")
            old = {c: i for i, c in enumerate(header)}
            rows = [line.split(",") for line in lines[1:]]
            store._rewrite_points([",".join(store._columns)] + [
                ",".join(r[old[c]] if c in old else format_cell(OPTIONAL_DEFAULTS[c]) for c in store._columns)
                for r in rows])
        elif run.warnings:  # the incomplete last line: rewrite the file without it
            store._rewrite_points(_complete_lines(run.path / "points.csv"))
        store.points_written = len(run.points)
        store.loaded_points = run.points.to_dict("records")
        store._prior_faults = list(run.meta.get("faults", []))
        store._resuming = True
        return store

    def prepare(self) -> None:
        """Create the directory exclusively, never through a link; refuse one that already holds files (its
        writer lock aside) (:func:`~saved_runs.store.lock.make_run_dir`)."""
        make_run_dir(self.run_dir)

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
        self._csv = open_points(self.run_dir / "points.csv", new=False)

    def _rewrite_points(self, lines: list[str]) -> None:
        """Replace points.csv atomically with ``lines`` (header first)."""
        write_text_atomic(self.run_dir / "points.csv", "".join(line + "\n" for line in lines), inside=self.run_dir)

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
        self._csv = open_points(self.run_dir / "points.csv", new=True)
        self._csv.write(",".join(self._columns) + "\n")
        self._sync_csv()
        fsync_dir(self.run_dir)

    def _sync_csv(self) -> None:
        assert self._csv is not None
        self._csv.flush()
        os.fsync(self._csv.fileno())

    def _event(self, doc: dict[str, Any]) -> None:
        try:
            self._write_row(doc["data"])
            self._sync_csv()
        except OSError as exc:  # a full disk: the run fails naming the file (and can be resumed)
            raise FileWriteError(self.run_dir / "points.csv", exc) from exc
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
        missing = [c for c in self._columns if c not in data and c not in OPTIONAL_DEFAULTS]
        if missing:
            raise ValueError(f"record lacks columns {missing}")
        # a column a later format version added (not_still) takes its default when the record has none
        self._csv.write(",".join(format_cell(data[c] if c in data else OPTIONAL_DEFAULTS[c])
                                 for c in self._columns) + "\n")

    def _stop(self, doc: dict[str, Any]) -> None:
        try:
            if self._csv is not None:
                csv, self._csv = self._csv, None
                try:
                    csv.flush()
                    os.fsync(csv.fileno())
                finally:
                    csv.close()
            self.meta.update(
                status=STATUS_BY_EXIT.get(doc["exit_status"], "aborted"),
                ended=utc_now_iso(),
                end_reason=doc.get("reason", ""),
                points=self.points_written,
            )
            self._write_meta()
        except (OSError, FileWriteError):
            # a run that failed (a full disk: that is its reason) stays "in-progress" on disk when its end
            # cannot be written either; --resume continues it all the same
            if doc["exit_status"] != "fail":
                raise


def open_points(path: Path, *, new: bool) -> TextIO:
    """points.csv opened to append to (``new``: created, and nothing may stand at ``path`` yet).

    Never through a link (O_NOFOLLOW; O_EXCL when new), never a pipe or a device (O_NONBLOCK, then the
    file checked to be regular), never a file with another hard link (appending would change it too):
    anything else is refused with :class:`UnsafeFileError`, link and target left as they are."""
    flags = os.O_WRONLY | os.O_APPEND | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    if new:
        flags |= os.O_CREAT | os.O_EXCL
    try:
        fd = os.open(path, flags, 0o666)
    except OSError as exc:
        if exc.errno not in (errno.ELOOP, errno.EEXIST, errno.ENXIO, errno.EISDIR):
            raise FileWriteError(path, exc) from exc
        try:
            mode = os.stat(path, follow_symlinks=False).st_mode
        except OSError:
            raise FileWriteError(path, exc) from exc
        if stat.S_ISREG(mode):  # new, and a file appeared since the directory was found empty
            raise RunFormatError(f"{path} appeared while the run was started; choose a new directory") from None
        raise UnsafeFileError(path, file_kind(mode)) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise UnsafeFileError(path, file_kind(st.st_mode))
        if st.st_nlink != 1:
            # a second name (a backup made with hard links, or a planted one): the points are the run's, keep them
            raise UnsafeFileError(path, "a file with other hard links", "a file of its own",
                                  f"give the run its own copy (cp {path} {path}.own && mv {path}.own {path})")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "a", encoding="utf-8", newline="")
    except BaseException:
        os.close(fd)
        raise


def _complete_lines(path: Path) -> list[str]:
    """The lines of a points file that end with a newline (a partial last line is dropped)."""
    text = path.read_text(encoding="utf-8")
    return text[: text.rfind("\n") + 1].splitlines()
