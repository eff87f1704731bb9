"""Expected failures that reach the user as one-line messages (exit code 2)."""

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
