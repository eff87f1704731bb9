"""One evaluation's files in RUN/results/ as one set: all of the new evaluation or all of the old one.

The set (profile.csv, profile.png, summary.json; or positioning.csv, positioning.png, summary.json) is
written into a temporary directory next to results/ (``RUN/.results.PID-HEX.tmpdir``), the other files
of results/ (reports, compensation tables) are hard-linked into it, and the two directories are
exchanged in one step (Linux ``renameat2(RENAME_EXCHANGE)``; elsewhere two renames, between which a
crash leaves no results/ at all, never a mixture).  A kill at any moment therefore leaves results/
holding one evaluation's complete set.  A file another command (``report``, ``export``) writes into
results/ meanwhile is kept: after the swap, what it wrote into the old directory is moved into the new
one (:func:`_carry_late_files`).  Leftovers of a killed writer (its temporary directory or
files, recognised by the dead pid in their name) are removed by the next writer.
"""

from __future__ import annotations

import ctypes
import errno
import os
import shutil
import stat
from collections.abc import Callable
from pathlib import Path

from ..errors import FileWriteError, UserError
from ..store.files import TEMP_NAME, fsync_dir, remove_stale_temps

# The files an evaluation writes (``guideway process``): replaced together, never carried over.
SET_FILES = frozenset({"profile.csv", "profile.png", "positioning.csv", "positioning.png", "summary.json"})
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Swap the directories ``a`` and ``b`` atomically; False where the system cannot."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):  # a file system or kernel without exchange
        return False
    raise OSError(err, os.strerror(err), str(b))


def _carry_late_files(old: Path, results: Path) -> None:
    """Move into ``results`` the files another command (``report``, ``export``) wrote into the old
    results/ after they were carried over and before the swap: new names, or names it replaced (another
    inode than the link carried over).  After the swap no writer reaches the old directory by its path,
    so none is lost and none is left as its older copy."""
    for e in os.scandir(old):
        if e.name in SET_FILES or TEMP_NAME.match(e.name):
            continue
        try:
            now = os.stat(results / e.name, follow_symlinks=False)
        except FileNotFoundError:
            now = None
        if now is None or (not e.is_dir(follow_symlinks=False)
                           and e.inode() != now.st_ino):
            os.replace(e.path, results / e.name)


def _refuse_link(results: Path) -> UserError:
    return UserError(f"{results} is not a directory (a link or a file); move it away, then evaluate again")


def _open_results(results: Path) -> int | None:
    """A descriptor of ``results`` to list the files it carries over (None if there is none yet), opened
    without following a link: a link put in its place since the check is refused, never listed (its
    target's files would be linked into the run)."""
    try:
        return os.open(results, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        return None
    except OSError as exc:
        if exc.errno in (errno.ELOOP, errno.ENOTDIR):
            raise _refuse_link(results) from None
        raise


def write_result_set(results_dir: Path | str, write: Callable[[Path], None]) -> Path:
    """Replace the evaluation's files in ``results_dir`` by those ``write(directory)`` writes into the
    directory it is given, as one set (module docstring); return ``results_dir``."""
    results = Path(results_dir)
    run_dir = results.parent
    if results.is_symlink() or (results.exists() and not results.is_dir()):
        raise _refuse_link(results)
    remove_stale_temps(run_dir)
    remove_stale_temps(results)
    tmp = run_dir / f".{results.name}.{os.getpid()}-{os.urandom(4).hex()}.tmpdir"
    try:
        tmp.mkdir()
    except OSError as exc:
        raise FileWriteError(results, exc) from exc
    try:
        try:
            write(tmp)
        except FileWriteError as exc:  # name the file meant, not its place in the temporary directory
            raise FileWriteError(results / Path(str(exc.path)).name, OSError(exc.errno, exc.reason)) from exc
        try:
            listing = _open_results(results)
            if listing is not None:
                try:
                    for e in os.scandir(listing):  # the other files of results/ stay (reports, tables)
                        if e.name in SET_FILES or TEMP_NAME.match(e.name) or os.path.lexists(tmp / e.name):
                            continue
                        if e.is_dir(follow_symlinks=False):
                            shutil.copytree(results / e.name, tmp / e.name, symlinks=True)
                        else:
                            try:
                                os.link(e.name, tmp / e.name, src_dir_fd=listing, follow_symlinks=False)
                            except OSError:
                                shutil.copy2(results / e.name, tmp / e.name, follow_symlinks=False)
                finally:
                    os.close(listing)
            fsync_dir(tmp)
            if results.is_dir():
                if not _exchange(tmp, results):
                    old = run_dir / f".{results.name}.{os.getpid()}-{os.urandom(4).hex()}.tmpdir"
                    os.rename(results, old)
                    os.rename(tmp, results)
                    tmp = old
                # the old results/ is now at tmp; had someone put a link in its place since the check above,
                # the exchange moved the link there: never carry the files of what it points to
                if stat.S_ISDIR(os.stat(tmp, follow_symlinks=False).st_mode):
                    _carry_late_files(tmp, results)
            else:
                os.rename(tmp, results)
            fsync_dir(run_dir)
        except OSError as exc:
            raise FileWriteError(results, exc) from exc
    finally:
        shutil.rmtree(tmp, ignore_errors=True)  # the old set after the exchange, or the unfinished new one
    return results
