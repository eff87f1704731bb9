"""Expected failures that reach the user as one-line messages (exit code 2)."""

import errno

from drivers.errors import DriverError


class UserError(Exception):
    """A problem the user can fix: bad input, bad file, unreachable device.

    The message names the problem and what to do about it.
    """


class RunFormatError(UserError):
    """A run directory is missing, malformed or of an unknown format."""


class SetupError(UserError):
    """A setup file or option is invalid."""


# Every failure the command line reports as one line with exit code 2 (no traceback).
EXPECTED_ERRORS: tuple[type[Exception], ...] = (UserError, DriverError)


def os_error_line(exc: OSError) -> str:
    """One line for a file that could not be written or read: the file and the reason in words (not
    ``[Errno 13] Permission denied: '...'``), and what to do for a permission problem."""
    where = exc.filename if exc.filename is not None else "a file"
    reason = (exc.strerror or str(exc)).lower()
    if exc.errno in (errno.EACCES, errno.EPERM):
        return f"{where}: {reason}; you may not write there (a read-only run or folder): copy the run elsewhere"
    if exc.errno == errno.EROFS:
        return f"{where}: {reason}; copy the run to a writable disk"
    return f"{where}: {reason}"


class FileWriteError(UserError):
    """A file could not be written (disk full, read-only, no permission): the message names the file.

    ``path``: the file meant (not a temporary name); ``errno``: the system's error number."""

    def __init__(self, path: object, exc: OSError) -> None:
        import errno as errnos

        self.path = path
        self.errno = exc.errno
        self.reason = exc.strerror or str(exc)
        hint = (" (the disk is full: free some space on it)"
                if exc.errno in (errnos.ENOSPC, errnos.EDQUOT) else "")
        super().__init__(f"cannot write {path}: {self.reason}{hint}")
