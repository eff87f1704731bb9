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


class UnsafeFileError(UserError):
    """A file or folder the tool would write is not what it should be: a symbolic link, a folder where a
    file belongs, a named pipe, a device.  Someone who may write into a shared runs folder could plant a
    link to make the next writer destroy another file, so the tool refuses it and touches neither the link
    nor what it points to (docs/reliability.md, "Files are written, never written through").

    ``path``: the entry refused; ``found``: what it is, in words (:func:`file_kind`); ``todo``: what to do
    about it."""

    def __init__(self, path: object, found: str, wanted: str = "a regular file",
                 todo: str = "remove it (and find out who put it there)") -> None:
        self.path = path
        self.found = found
        super().__init__(f"{path} is {found}, not {wanted}: guideway does not write through it; {todo}, "
                         "then try again")


def file_kind(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, in words (for :class:`UnsafeFileError`)."""
    import stat

    for test, words in ((stat.S_ISLNK, "a symbolic link"), (stat.S_ISDIR, "a directory"),
                        (stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISSOCK, "a socket"),
                        (stat.S_ISCHR, "a device"), (stat.S_ISBLK, "a device"), (stat.S_ISREG, "a regular file")):
        if test(mode):
            return words
    return "a special file"  # pragma: no cover


_ESCAPES = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def printable(text: object) -> str:
    """``text`` with its control characters escaped (a newline as ``\\n``, ESC as ``\\x1b``, others as
    ``\\xNN`` / ``\\uNNNN``): a run's machine, axis, operator or name comes from a run.json anyone may have
    written, and one holding a terminal escape code must not drive the terminal, nor a newline forge a line
    of a list or a table.  Every place that shows such a name (command line and TUI) goes through here."""
    def one(ch: str) -> str:
        if ch.isprintable():
            return ch
        return _ESCAPES.get(ch) or (f"\\x{ord(ch):02x}" if ord(ch) < 0x100 else f"\\u{ord(ch):04x}")

    return "".join(map(one, str(text)))
