"""Atomic files: a reader sees the old or the new file, never a half-written one.

Each file is written to a temporary file in the same directory (with the mode an ordinary
``open()`` gives), fsynced, renamed over the target and the directory fsynced.  Every file the tool
writes next to a run or at ``--out`` (run.json, results, reports, tables) goes through here.
"""

from __future__ import annotations

import datetime
import json
import os
import re
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

from ..errors import FileWriteError

# The temporary names of this module: ".NAME.PID-HEX.tmp" (a file being written), ".NAME.PID-HEX.tmpdir"
# (a set of files being written, saved_runs/results/result_set.py); older versions wrote ".NAME.HEX.tmp"
# and ".NAME.tmp.png".  The pid lets the next writer tell a
# leftover of a killed process from a file another process is writing right now.
TEMP_NAME = re.compile(r"^\.(?P<name>.+?)\.(?:(?:(?P<pid>\d+)-)?[0-9a-f]{8}\.tmp(?:dir)?|tmp\.png)$")


def fsync_dir(path: Path) -> None:
    """Flush a directory's entries to disk (a file created or renamed in it survives a crash)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def create_temp(path: Path) -> tuple[int, str]:
    """A new temporary file next to ``path``, opened for writing, with the mode an ordinary
    ``open()`` gives (0666 less the user's umask): ``tempfile.mkstemp`` would make it 0600, and
    the rename would give results, reports and tables that mode."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
    for _ in range(100):
        tmp = str(path.parent / f".{path.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp")
        try:
            return os.open(tmp, flags, 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary file name next to {path}")  # pragma: no cover


def write_atomic(path: Path | str, write: Callable[[BinaryIO], None]) -> None:
    """Replace ``path`` with what ``write`` writes to the binary file it is given: a temporary file in
    the same directory, fsynced, renamed over ``path``, directory fsynced.  A reader sees the old or the
    new file, never a half-written one; a failure (a full disk, a crash) leaves no temporary file and
    raises :class:`FileWriteError` naming ``path``."""
    path = Path(path)
    try:
        fd, tmp = create_temp(path)
    except OSError as exc:
        raise FileWriteError(path, exc) from exc
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
        fsync_dir(path.parent)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise FileWriteError(path, exc) from exc
        raise


def write_text_atomic(path: Path | str, text: str) -> None:
    """Replace ``path`` with ``text`` (UTF-8, ``\\n`` line ends) atomically (:func:`write_atomic`)."""
    data = text.encode("utf-8")
    write_atomic(path, lambda f: f.write(data))


def _iso_date(value: Any) -> str:
    """A TOML date, date-time or time as ISO 8601 text (json's ``default``); anything else is refused."""
    if isinstance(value, datetime.date | datetime.time):
        return value.isoformat()
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")


def write_json_atomic(path: Path | str, obj: Any) -> None:
    """Replace ``path`` with ``obj`` as JSON (no NaN), atomically (:func:`write_atomic`).  Encoded
    piece by piece into the file: the summary of a 100 000-station run is never held as one string."""

    def write(f: BinaryIO) -> None:
        pieces: list[str] = []
        size = 0
        # as json.dumps(indent=2); TOML dates (a set-up's [[instrument]] in setup_source) as ISO 8601 text
        for piece in json.JSONEncoder(indent=2, allow_nan=False, default=_iso_date).iterencode(obj):
            pieces.append(piece)
            size += len(piece)
            if size >= 1 << 16:
                f.write("".join(pieces).encode("utf-8"))
                pieces, size = [], 0
        pieces.append("\n")
        f.write("".join(pieces).encode("utf-8"))

    write_atomic(path, write)


def temp_owner_alive(name: str) -> bool:
    """Whether the temporary file or directory ``name`` (:data:`TEMP_NAME`) belongs to a process that still
    runs on this machine (a name without a pid, from an older version, belongs to none)."""
    m = TEMP_NAME.match(name)
    if m is None or m.group("pid") is None:
        return False
    return pid_alive(int(m.group("pid")))


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` runs on this machine."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def remove_stale_temps(directory: Path) -> list[str]:
    """Remove the temporary files and directories in ``directory`` left by a killed writer (their
    process is gone); return their names."""
    import shutil

    removed = []
    try:
        entries = list(os.scandir(directory))
    except FileNotFoundError:
        return removed
    for e in entries:
        if TEMP_NAME.match(e.name) and not temp_owner_alive(e.name):
            if e.is_dir(follow_symlinks=False):
                shutil.rmtree(e.path, ignore_errors=True)
            else:
                Path(e.path).unlink(missing_ok=True)
            removed.append(e.name)
    return removed
