"""Atomic files: a reader sees the old or the new file, never a half-written one.

Each file is written to a temporary file in the same directory (with the mode an ordinary
``open()`` gives), fsynced, renamed over the target and the directory fsynced.  Every file the tool
writes next to a run or at ``--out`` (run.json, results, reports, tables) goes through here.
"""

from __future__ import annotations

import json
import os
import secrets
from pathlib import Path
from typing import Any


def fsync_dir(path: Path) -> None:
    """Flush a directory's entries to disk (a file created or renamed in it survives a crash)."""
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
    fsync_dir(path.parent)


def write_json_atomic(path: Path | str, obj: Any) -> None:
    """Replace ``path`` with ``obj`` as JSON (no NaN), atomically (:func:`write_text_atomic`)."""
    write_text_atomic(path, json.dumps(obj, indent=2, allow_nan=False) + "\n")
