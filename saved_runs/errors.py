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


def what_to_do(error_number: int | None) -> str:
    """What the user can do about a file the system would not write, by the error number ("" when
    the reason says it all)."""
    if error_number in (errno.EACCES, errno.EPERM):
        return "; you may not write there (a read-only run or folder): copy the run elsewhere"
    if error_number == errno.EROFS:
        return "; copy the run to a writable disk"
    if error_number in (errno.ENOSPC, errno.EDQUOT):
        return " (the disk is full: free some space on it)"
    return ""


def os_error_line(exc: OSError) -> str:
    """One line for a file that could not be written or read: the file and the reason in words (not
    ``[Errno 13] Permission denied: '...'``), and what to do about it."""
    where = exc.filename if exc.filename is not None else "a file"
    return f"{where}: {exc.strerror or exc}{what_to_do(exc.errno)}"


class FileWriteError(UserError):
    """A file could not be written (disk full, read-only, no permission): the message names the file.

    ``path``: the file meant (not a temporary name); ``errno``: the system's error number."""

    def __init__(self, path: object, exc: OSError) -> None:
        self.path = path
        self.errno = exc.errno
        self.reason = exc.strerror or str(exc)
        super().__init__(f"cannot write {path}: {self.reason}{what_to_do(exc.errno)}")
