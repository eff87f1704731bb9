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
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import socket
import time
from collections.abc import Iterator
from pathlib import Path

from ..errors import RunFormatError
from .files import pid_alive
from .format import utc_now_iso

LOCK_NAME = ".writer.lock"
HOLDER_WAIT_S = 1.0  # how long a refused writer waits for the holder to record itself in the lock file


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
            info = json.loads(lock_path.read_text(encoding="utf-8"))
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
            if os.stat(self.path).st_ino == os.fstat(self._fd).st_ino:
                self.path.unlink()
        os.close(self._fd)  # closing the last descriptor of the file releases the flock
        self._fd = None


def take_run_lock(run_dir: Path | str, what: str = "the run") -> RunLock:
    """Lock ``run_dir`` (an existing directory) for this process, or raise :class:`RunInUseError`
    naming the holder.  ``what`` names the directory in messages."""
    run_dir = Path(run_dir)
    path = run_dir / LOCK_NAME
    flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
    for _ in range(100):
        try:
            fd = os.open(path, flags, 0o666)
        except PermissionError:
            raise RunFormatError(f"{run_dir}: cannot write in this directory (permission denied); "
                                 f"{what} needs a directory you may write to") from None
        except OSError as exc:
            if exc.errno == errno.EROFS:
                raise RunFormatError(f"{run_dir}: the file system is read-only; {what} cannot be written "
                                     "there") from None
            raise
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise RunInUseError(f"{run_dir} is in use: another guideway process is writing it "
                                f"({holder_text(path)}); wait until it ends or stop it, then try again") from None
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
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
        if run_dir.exists() and not run_dir.is_dir():
            raise RunFormatError(f"{run_dir} exists and is not a directory; choose another --out")
        try:
            run_dir.mkdir(parents=True, exist_ok=True)
        except PermissionError:
            raise RunFormatError(f"{run_dir}: cannot create the run directory (permission denied); "
                                 "choose an --out you may write to") from None
    elif not run_dir.is_dir():
        yield None
        return
    lock = take_run_lock(run_dir)
    try:
        yield lock
    finally:
        lock.release()


def run_files(run_dir: Path) -> list[Path]:
    """The entries of a run directory other than its lock file (a new run needs none)."""
    return [p for p in run_dir.iterdir() if p.name != LOCK_NAME]
