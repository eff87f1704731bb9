"""One writer per run: an OS lock on ``RUN_DIR/.writer.lock`` held while a process writes the run.

Every writer of a run directory (``guideway acquire``, ``acquire --resume``, the TUI's acquisition,
``guideway demo``, ``guideway import``, ``guideway simulate``) holds an exclusive ``flock`` on the
lock file for as long as it writes.  A second writer is refused at once with one line naming the
holder (pid, host, since when), read from the lock file.  The lock belongs to the open file: when
the process ends - even by SIGKILL - the kernel releases it, so a lock file left behind by a dead
process is no obstacle (the next writer takes the lock and rewrites the holder).  Readers
(``process``, ``report``, the runs browser) never take it: they read a consistent snapshot
(run.json is replaced atomically, points.csv only grows by whole fsynced lines).

The lock file is removed when the writer ends.  Removing a lock file is safe only because a
writer, after taking the lock, checks that the path still names the file it locked (a rival
that opened the file just before it was removed would otherwise lock an orphan).

The lock file is opened without following a symbolic link (O_NOFOLLOW) and without waiting on a
named pipe (O_NONBLOCK), and must be a regular file with no other hard link: anyone who may write
into a shared runs folder could otherwise plant ``RUN/.writer.lock`` as a link to any file and have
the next writer truncate it.  Anything else there is refused (:class:`UnsafeFileError`, exit 2) and
left as it is, link and target.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import socket
import stat
import time
from collections.abc import Iterator
from pathlib import Path

from ..errors import FileWriteError, RunFormatError, UnsafeFileError, file_kind
from .files import pid_alive
from .format import utc_now_iso

LOCK_NAME = ".writer.lock"
HOLDER_WAIT_S = 1.0  # how long a refused writer waits for the holder to record itself in the lock file
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
# no link followed, no wait on a named pipe: a lock file that is not a plain file is refused (module docstring)
_LOCK_FLAGS = os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | _CLOEXEC


def _read_record(lock_path: Path) -> str:
    """The text of the lock file, read without following a link or waiting on a pipe ("" if it is not a
    plain file)."""
    fd = os.open(lock_path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | _CLOEXEC)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return ""
        return os.read(fd, 1 << 12).decode("utf-8")
    finally:
        os.close(fd)


def _refuse_unsafe(path: Path, fd: int | None) -> None:
    """Raise :class:`UnsafeFileError` if the lock file (open as ``fd``, or not openable: None) is not a plain
    file of its own (a link, a directory, a pipe, a socket, another file's hard link)."""
    if fd is None:
        try:
            mode = os.stat(path, follow_symlinks=False).st_mode
        except OSError:
            return
        raise UnsafeFileError(path, file_kind(mode))
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        raise UnsafeFileError(path, file_kind(st.st_mode))
    if st.st_nlink != 1:
        raise UnsafeFileError(path, "a hard link of another file", "a lock file of its own")


class RunInUseError(RunFormatError):
    """Another process writes the run directory."""


def holder_text(lock_path: Path) -> str:
    """``pid N on host H, since T`` of the process holding ``lock_path`` (as it recorded itself).

    The holder writes its record just after taking the lock; until then the file is empty or still
    names the writer before it (a killed writer leaves its record behind), so a record of a process
    that no longer runs on this host is read again until the holder's own is there."""
    deadline = time.monotonic() + HOLDER_WAIT_S
    while True:
        try:
            info = json.loads(_read_record(lock_path))
            pid = int(info["pid"])
            if info["host"] != socket.gethostname() or pid_alive(pid):
                return f"pid {pid} on host {info['host']}, since {info['since']}"
        except (OSError, ValueError, KeyError, TypeError):
            pass  # the holder has taken the lock but not written its name yet (or the file just went away)
        if time.monotonic() > deadline:
            return "a process that has not recorded its pid yet"
        time.sleep(0.02)


class RunLock:
    """The held lock of one run directory; :meth:`moved_to` follows a rename of the directory."""

    def __init__(self, run_dir: Path, fd: int) -> None:
        self.run_dir = run_dir
        self._fd: int | None = fd

    @property
    def path(self) -> Path:
        return self.run_dir / LOCK_NAME

    def moved_to(self, run_dir: Path) -> None:
        """The directory was renamed to ``run_dir`` (the lock goes with the file: still held)."""
        self.run_dir = run_dir

    def release(self) -> None:
        """Remove the lock file, then let the lock go (in this order: see the module docstring)."""
        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            if os.stat(self.path, follow_symlinks=False).st_ino == os.fstat(self._fd).st_ino:
                self.path.unlink()
        os.close(self._fd)  # closing the last descriptor of the file releases the flock
        self._fd = None


def take_run_lock(run_dir: Path | str, what: str = "the run") -> RunLock:
    """Lock ``run_dir`` (an existing directory) for this process, or raise :class:`RunInUseError`
    naming the holder.  ``what`` names the directory in messages."""
    run_dir = Path(run_dir)
    path = run_dir / LOCK_NAME
    for _ in range(100):
        try:
            fd = os.open(path, _LOCK_FLAGS, 0o666)
        except PermissionError:
            raise RunFormatError(f"{run_dir}: cannot write in this directory (permission denied); "
                                 f"{what} needs a directory you may write to") from None
        except OSError as exc:
            if exc.errno == errno.EROFS:
                raise RunFormatError(f"{run_dir}: the file system is read-only; {what} cannot be written "
                                     "there") from None
            if exc.errno in (errno.ELOOP, errno.EISDIR, errno.ENXIO, errno.EOPNOTSUPP):
                _refuse_unsafe(path, None)  # a link (even a dangling one), a directory, a socket
            raise FileWriteError(path, exc) from exc
        try:
            _refuse_unsafe(path, fd)
        except UnsafeFileError:
            os.close(fd)
            raise
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise RunInUseError(f"{run_dir} is in use: another guideway process is writing it "
                                f"({holder_text(path)}); wait until it ends or stop it, then try again") from None
        try:
            same = os.stat(path, follow_symlinks=False).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if not same:  # the holder removed the file between our open and our lock: lock the new one
            os.close(fd)
            continue
        info = json.dumps({"pid": os.getpid(), "host": socket.gethostname(), "since": utc_now_iso()})
        os.ftruncate(fd, 0)
        os.pwrite(fd, (info + "\n").encode("utf-8"), 0)
        return RunLock(run_dir, fd)
    raise RunInUseError(f"{run_dir} is in use: its lock file keeps changing; try again")  # pragma: no cover


@contextlib.contextmanager
def run_writer_lock(run_dir: Path | str, *, new: bool) -> Iterator[RunLock | None]:
    """Hold the writer lock of ``run_dir`` for the ``with`` block.

    ``new``: the run is to be created there; the directory is made (with its parents) so that it can
    be locked before anything checks or writes it.  A run to resume that does not exist is not locked
    (yields None): reading it fails with its own message.
    """
    run_dir = Path(run_dir)
    if new:
        make_run_dir(run_dir, require_empty=False)  # (emptiness: checked by the store, under the lock)
    elif not run_dir.is_dir():
        yield None
        return
    lock = take_run_lock(run_dir)
    try:
        yield lock
    finally:
        lock.release()


def make_run_dir(run_dir: Path | str, *, require_empty: bool = True) -> None:
    """Create the directory of a new run (and its parents), exclusively and without following a link.

    The default names (``runs/demo-<UTC time>``, the TUI's ``runs/KIND-<UTC time>``) are predictable: a symbolic
    link planted at one would make the new run be written into the link's target.  ``mkdir`` never follows a
    link (a link there, dangling or not, makes it fail), so what stands at the name afterwards is checked with
    ``lstat``: a link is refused (:class:`UnsafeFileError`, exit 2) and left alone; an existing real directory
    is taken only when it is empty (its lock file aside), as ``--out`` made beforehand (``require_empty``
    False: not checked here, as the writer lock makes the directory before it is locked; a second writer
    racing for the same new run is then told the run is in use, and the store checks under the lock)."""
    run_dir = Path(run_dir)
    try:
        run_dir.parent.mkdir(parents=True, exist_ok=True)
        os.mkdir(run_dir)
        return
    except FileExistsError:
        pass
    except PermissionError:
        raise RunFormatError(f"{run_dir}: cannot create the run directory (permission denied); "
                             "choose an --out you may write to") from None
    except NotADirectoryError:
        raise RunFormatError(f"{run_dir}: a parent of it is not a directory; choose another --out") from None
    mode = os.lstat(run_dir).st_mode
    if stat.S_ISLNK(mode):
        raise UnsafeFileError(run_dir, "a symbolic link", "a new run directory",
                              "remove the link (and find out who put it there) or choose another --out")
    if not stat.S_ISDIR(mode):
        raise RunFormatError(f"{run_dir} exists and is not a directory; choose another --out")
    if require_empty and run_files(run_dir):
        raise RunFormatError(f"{run_dir} is not empty; choose a new directory for the run")


def run_files(run_dir: Path) -> list[Path]:
    """The entries of a run directory other than its lock file (a new run needs none)."""
    return [p for p in run_dir.iterdir() if p.name != LOCK_NAME]
