"""Typed errors raised by every driver.

Three families, so callers can decide what to do without parsing messages:

* :class:`TransportError` - the bytes did not arrive (timeout, port closed,
  connection refused).  Retrying or reconnecting may help.
* :class:`ProtocolError` - bytes arrived but are not a valid frame (malformed,
  wrong header, bad checksum).  The line is noisy or the protocol setting is wrong.
* :class:`DeviceError` - a well-formed reply in which the device reports an
  error (code plus the manual's text).
"""

from __future__ import annotations


class DriverError(Exception):
    """Base class of every error a driver raises."""


class TransportError(DriverError):
    """The transport failed: nothing or not enough arrived, or the link is down."""


class TransportTimeout(TransportError):
    """No complete reply within the deadline."""


class ConnectionLost(TransportError):
    """The port or connection was closed or could not be opened."""


class CompletionTimeout(TransportTimeout):
    """The device answers requests, but an operation it started (a measurement) did not complete
    within the deadline: a slow device or a stuck one, not a wrong address or a broken link.

    A :class:`TransportTimeout` so that callers retrying on timeouts keep doing so; callers that
    hint at the cause tell it apart.  ``status``: the device's last status (driver-specific).
    """

    def __init__(self, *args: object, status: object = None) -> None:
        super().__init__(*args)
        self.status = status


class ProtocolError(DriverError):
    """A reply arrived but is not a valid frame for the protocol."""


class ChecksumError(ProtocolError):
    """A frame's checksum (BCC, CRC) does not match its contents."""


class DeviceError(DriverError):
    """The device answered with an error code."""

    def __init__(self, code: str | int, text: str, *, command: str = "") -> None:
        self.code = code
        self.text = text
        self.command = command
        where = f" to {command!r}" if command else ""
        super().__init__(f"device reported error {code}{where}: {text}")


def with_context(exc: DriverError, context: str, hint: str = "") -> DriverError:
    """A copy of ``exc`` (same type and attributes) whose message starts with ``context``."""
    if isinstance(exc, DeviceError):
        new: DriverError = type(exc)(exc.code, exc.text, command=exc.command)
    else:
        new = type(exc)()
    new.args = (f"{context}: {exc}{hint}",)
    return new
