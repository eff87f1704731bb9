"""Atomic files: a reader sees the old or the new file, never a half-written one.

Each file is written to a temporary file in the same directory (with the mode an ordinary
``open()`` gives), fsynced, renamed over the target and the directory fsynced.  Every file the tool
writes next to a run or at ``--out`` (run.json, results, reports, tables) goes through here.  Nothing is
written through a symbolic link, and inside a run a link where a file or folder belongs is refused
(:func:`write_atomic`; docs/reliability.md).
"""

from __future__ import annotations

import contextlib
import datetime
import errno
import json
import os
import re
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

from ..errors import FileWriteError, RunFormatError, UnsafeFileError, file_kind

_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_DIR_FLAGS = os.O_RDONLY | os.O_DIRECTORY | _CLOEXEC

# The temporary names of this module: ".NAME.PID-HEX.tmp" (a file being written), ".NAME.PID-HEX.tmpdir"
# (a set of files being written, saved_runs/results/result_set.py); older versions wrote ".NAME.HEX.tmp"
# and ".NAME.tmp.png".  The pid lets the next writer tell a
# leftover of a killed process from a file another process is writing right now.
TEMP_NAME = re.compile(r"^\.(?P<name>.+?)\.(?:(?:(?P<pid>\d+)-)?[0-9a-f]{8}\.tmp(?:dir)?|tmp\.png)$")


_READ_FLAGS = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)


def read_run_file(path: Path | str) -> bytes:
    """The bytes of a file of a run (run.json, points.csv, results/summary.json), or
    :class:`~saved_runs.errors.RunFormatError` naming it when it is not a regular file.

    Opened with ``O_NONBLOCK`` and checked with ``fstat`` on what was opened (no check-then-open race): a named
    pipe (FIFO) planted at run.json would otherwise make ``catalog add``, ``process`` or the runs browser wait
    forever for a writer, and a device would be read without end.  A symbolic link is followed: reading
    through it is harmless (nothing is written), and the file it leads to must be a regular file all the
    same (docs/reliability.md).  ``FileNotFoundError`` (and other ``OSError``) pass to the caller."""
    fd = os.open(path, _READ_FLAGS)
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise RunFormatError(f"{path} is {file_kind(mode)}, not a regular file: guideway does not read it "
                                 "(a named pipe would wait forever); replace it with the run's own file")
        with os.fdopen(fd, "rb") as f:
            fd = -1  # closed with f
            return f.read()
    finally:
        if fd >= 0:
            os.close(fd)


def fsync_dir(path: Path) -> None:
    """Flush a directory's entries to disk (a file created or renamed in it survives a crash)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def run_root(path: Path | str, inside: Path | str | None = None) -> Path | None:
    """The directory below which ``path`` is written strictly (:func:`write_atomic`): the outermost of its
    parent directories (by name, links not followed) that holds a run.json, or ``inside`` if that lies
    further out; None for a file outside any run (a file the user named with ``--out``)."""
    here = Path(os.path.abspath(path)).parent
    root = None
    for d in (here, *here.parents):
        try:
            if stat.S_ISREG(os.stat(d / "run.json", follow_symlinks=False).st_mode):
                root = d
        except OSError:
            continue
    if inside is not None:
        top = Path(os.path.abspath(inside))
        if (top == here or top in here.parents) and (root is None or top in root.parents):
            root = top
    return root


def _open_dir(directory: Path, root: Path | None, *, create: bool) -> int:
    """A descriptor of ``directory``.  Below ``root`` each component is opened without following a link
    (a link or a file there raises :class:`UnsafeFileError`), so that a link planted in a run (``RUN/results
    -> /etc``) is never written through; ``create``: missing components are made (as ``mkdir`` makes them)."""
    if root is None:
        if create:
            os.makedirs(directory, exist_ok=True)
        return os.open(directory, _DIR_FLAGS)
    fd = os.open(root, _DIR_FLAGS)
    here = root
    try:
        for part in Path(os.path.abspath(directory)).relative_to(root).parts:
            here = here / part
            try:
                try:
                    sub = os.open(part, _DIR_FLAGS | os.O_NOFOLLOW, dir_fd=fd)
                except FileNotFoundError:
                    if not create:
                        raise
                    with contextlib.suppress(FileExistsError):
                        os.mkdir(part, 0o777, dir_fd=fd)
                    sub = os.open(part, _DIR_FLAGS | os.O_NOFOLLOW, dir_fd=fd)
            except OSError as exc:
                exc.filename = str(here)
                mode = os.stat(part, dir_fd=fd, follow_symlinks=False).st_mode if exc.errno in (
                    errno.ELOOP, errno.ENOTDIR) else stat.S_IFDIR
                if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
                    raise  # an ordinary failure (a file where a folder is meant, no permission): FileWriteError
                raise UnsafeFileError(here, file_kind(mode), "a directory") from None
            os.close(fd)
            fd = sub
    except BaseException:
        os.close(fd)
        raise
    return fd


def _create_temp_at(dir_fd: int, name: str) -> tuple[int, str]:
    """A new temporary file for ``name`` in the directory ``dir_fd``, opened for writing, with the mode an
    ordinary ``open()`` gives (0666 less the user's umask): ``tempfile.mkstemp`` would make it 0600, and the
    rename would give results, reports and tables that mode.  O_EXCL and O_NOFOLLOW: a name planted in
    advance (a link to another file) is never opened, another name is drawn."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | _CLOEXEC
    for _ in range(100):
        tmp = f".{name}.{os.getpid()}-{os.urandom(4).hex()}.tmp"
        try:
            return os.open(tmp, flags, 0o666, dir_fd=dir_fd), tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary file name next to {name}")  # pragma: no cover


def write_atomic(path: Path | str, write: Callable[[BinaryIO], None], *, inside: Path | str | None = None,
                 make_parents: bool = False) -> None:
    """Replace ``path`` with what ``write`` writes to the binary file it is given: a temporary file in
    the same directory, fsynced, renamed over ``path``, directory fsynced.  A reader sees the old or the
    new file, never a half-written one; a failure (a full disk, a crash) leaves no temporary file and
    raises :class:`FileWriteError` naming ``path``.

    Nothing is written through a link: the rename replaces whatever stands at ``path`` (a link is replaced
    by the new file, its target untouched).  Inside a run (:func:`run_root`; ``inside``: a folder of the
    tool's own files, such as volumetric's ``--out``) a link or a non-regular file at ``path``, or a link
    in place of a folder below the run, is refused (:class:`UnsafeFileError`) and left as it is.
    ``make_parents``: missing folders of ``path`` are made."""
    path = Path(path)
    root = run_root(path, inside)
    try:
        dir_fd = _open_dir(path.parent, root, create=make_parents)
    except OSError as exc:
        raise FileWriteError(path, exc) from exc
    try:
        if root is not None:
            try:
                mode = os.stat(path.name, dir_fd=dir_fd, follow_symlinks=False).st_mode
            except FileNotFoundError:
                mode = stat.S_IFREG
            if not stat.S_ISREG(mode):
                raise UnsafeFileError(path, file_kind(mode))
        try:
            fd, tmp = _create_temp_at(dir_fd, path.name)
        except OSError as exc:
            raise FileWriteError(path, exc) from exc
        try:
            with os.fdopen(fd, "wb") as f:
                write(f)
                f.flush()
                os.fsync(f.fileno())
            # a rename replaces the entry at path itself: a link swapped in after the check above is replaced,
            # never followed
            os.replace(tmp, path.name, src_dir_fd=dir_fd, dst_dir_fd=dir_fd)
            os.fsync(dir_fd)
        except BaseException as exc:
            with contextlib.suppress(OSError):
                os.unlink(tmp, dir_fd=dir_fd)
            if isinstance(exc, OSError):
                raise FileWriteError(path, exc) from exc
            raise
    finally:
        os.close(dir_fd)


def write_text_atomic(path: Path | str, text: str, *, inside: Path | str | None = None,
                      make_parents: bool = False) -> None:
    """Replace ``path`` with ``text`` (UTF-8, ``\\n`` line ends) atomically (:func:`write_atomic`)."""
    data = text.encode("utf-8")
    write_atomic(path, lambda f: f.write(data), inside=inside, make_parents=make_parents)


def _iso_date(value: Any) -> str:
    """A TOML date, date-time or time as ISO 8601 text (json's ``default``); anything else is refused."""
    if isinstance(value, datetime.date | datetime.time):
        return value.isoformat()
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")


def write_json_atomic(path: Path | str, obj: Any, *, inside: Path | str | None = None) -> None:
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

    write_atomic(path, write, inside=inside)


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
