"""Runs written at once (``guideway import``, ``guideway simulate``): complete, or not there at all.

The run is written into a temporary directory next to ``--out`` (``.NAME.PID-XXXXXXXX.partial``, under its
writer lock), and renamed to ``--out`` only when run.json says complete: a process killed half way
leaves no run at ``--out`` that ``process`` could take for a crashed measurement.  A temporary
directory left by a killed writer (its process gone, its lock no longer held) is removed by the next
write to the same ``--out``.  The pid matters: a writer makes its directory before it can lock it, and
an unlocked directory of a live writer is not a leftover.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import shutil
import uuid
from pathlib import Path
from typing import Any

from ..errors import RunFormatError, UnsafeFileError
from .files import fsync_dir, pid_alive
from .lock import LOCK_NAME, RunInUseError, run_files, take_run_lock
from .writer import RunStore

PARTIAL_SUFFIX = ".partial"


def _check_out(out: Path) -> None:
    if out.exists() or out.is_symlink():
        if not out.is_dir():
            raise RunFormatError(f"{out} exists and is not a directory; choose another --out")
        if run_files(out) or os.path.lexists(out / LOCK_NAME):
            _refuse_taken(out)


def _refuse_taken(out: Path) -> None:
    """``out`` holds something: say whether a writer is at it (names the holder) or it is just not empty."""
    if os.path.lexists(out / LOCK_NAME):  # lexists: a lock that is a (dangling) link is refused by take_run_lock
        take_run_lock(out).release()  # raises RunInUseError naming the holder while one writes
        if not run_files(out):
            return
    raise RunFormatError(f"{out} is not empty; choose a new directory for the run")


def _remove_stale_partials(parent: Path, name: str) -> None:
    """Remove temporary directories of earlier writes to ``name`` whose writer is gone (process and lock)."""
    own = re.compile(rf"^\.{re.escape(name)}\.(?:(?P<pid>\d+)-)?[0-9a-f]{{8}}{re.escape(PARTIAL_SUFFIX)}$")
    for p in parent.glob(f".*{PARTIAL_SUFFIX}"):
        m = own.match(p.name)
        if m is None or not p.is_dir() or p.is_symlink():
            continue
        # made by a live process: perhaps not locked yet (_make_partial, then take_run_lock) - not a leftover
        if m.group("pid") is not None and pid_alive(int(m.group("pid"))):
            continue
        try:
            lock = take_run_lock(p)
        except (RunInUseError, RunFormatError, UnsafeFileError):
            continue  # another writer is at it right now (or something not ours stands at its lock: leave it)
        lock.release()
        shutil.rmtree(p, ignore_errors=True)


def _make_partial(parent: Path, name: str) -> Path:
    """A new temporary run directory next to ``--out``, with the mode an ordinary mkdir gives."""
    for _ in range(100):
        tmp = parent / f".{name}.{os.getpid()}-{secrets.token_hex(4)}{PARTIAL_SUFFIX}"
        try:
            tmp.mkdir(0o777)
            return tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary directory name next to {parent / name}")  # pragma: no cover


def write_whole_run(out: Path | str, header: dict[str, Any], kind: str, rows: list[dict[str, Any]],
                    reason: str) -> tuple[Path, int]:
    """Write a complete run of ``kind`` (run.json ``header``, points ``rows``) to the new directory
    ``out`` atomically; return (out, points written)."""
    out = Path(out)
    _check_out(out)
    parent = out.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except PermissionError:
        raise RunFormatError(f"{parent}: cannot create it (permission denied); choose an --out you may "
                             "write to") from None
    _remove_stale_partials(parent, out.name)
    try:
        tmp = _make_partial(parent, out.name)
    except PermissionError:
        raise RunFormatError(f"{parent}: cannot write in this directory (permission denied); choose an --out "
                             "you may write to") from None
    lock = take_run_lock(tmp)
    try:
        store = RunStore(tmp, header)
        store("start", {"kind": kind, "uid": uuid.uuid4().hex})
        store.record_many(rows)
        store("stop", {"exit_status": "success", "reason": reason})
        try:
            os.rename(tmp, out)  # replaces an empty directory; refuses one that holds anything
        except OSError as exc:
            if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR, errno.EISDIR):
                raise
            _refuse_taken(out)
            raise RunFormatError(f"{out} appeared while the run was written; choose a new directory") from None
        lock.moved_to(out)
        fsync_dir(parent)
    except BaseException:
        lock.release()
        with contextlib.suppress(OSError):
            shutil.rmtree(tmp)
        raise
    lock.release()
    return out, store.points_written
